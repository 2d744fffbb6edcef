"""Parameters of the `direction` strategy (`policy_params.direction`); 004 hand-tuned and did not
report most of them, so they are exposed here (docs/methods/direction.md)."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from fallbench.analysis.obstacles import OutcomeSettings


@dataclass(frozen=True)
class DirectionConfig:
    mode: str = "auto"  # auto, or a forced no_action | lift_leg | take_step | take_step_pis | whole_body_is
    selection: str = "cascade"  # cascade (NA -> LL -> TS, first safe) | argmin (best score)
    # the geometry the plan shares with the outcome among objects (`fallbench.analysis.obstacles`),
    # which reads the same keys of `policy_params.direction`: same defaults
    robot_radius: float = OutcomeSettings.robot_radius  # m
    cone_margin: float = 0.0  # deg added to each side of every blocked cone when planning (004: 0); the judge's cones stay exact
    consider_factor: float = (
        OutcomeSettings.consider_factor
    )  # objects within this times the robot height count
    robot_height: float = OutcomeSettings.robot_height  # m
    w1: float = OutcomeSettings.w1  # eq. 4; w2 = 1 - w1
    trigger_window: int = 8  # capture points tested for collinearity (control steps)
    trigger_tolerance: float = 0.003  # m RMS off their line
    trigger_min_travel: float = 0.01  # m along the line
    trigger_timeout: float = 0.2  # s after the fall trigger
    touchdown_fraction: float = (
        OutcomeSettings.touchdown_fraction
    )  # CoM height at touchdown / standing CoM height
    lift_height: float = 0.08  # m, Lift a Leg and the step's swing clearance
    step_radius_min: float = 0.15  # m, step grid from the swing foot's centre
    step_radius_max: float = 0.6  # m
    step_radius_step: float = 0.05  # m
    step_heading_step: float = 15.0  # deg
    min_foot_separation: float = (
        0.15  # m: the target stays this far on the swing foot's side of the stance foot
    )
    foot_speed: float = 1.0  # m/s, the swing foot's speed cap (eq. 5)
    # Step landing time after the control trigger, offset + per_m x length: a least-squares fit to 26 completed
    # forced steps in free space (scenarios/direction_step_timing.yaml; 0.15-0.45 m, 393/618 N forward and right);
    # 004's reading (length / foot_speed) is offset 0, per_m 1/foot_speed, and lands 0.06-0.17 s early
    step_time_offset: float = 0.24  # s
    step_time_per_m: float = 0.55  # s/m
    step_gain: float = 20.0  # 1/s, eq. 5
    inertia_gain: float = 10.0  # 1/s, eqs. 6 and 8
    damping: float = 1e-3  # damped pseudo-inverses
    step_tolerance: float = 0.05  # m: the foot starts down within half of this from its target; a step is complete when it lands within this
    allow_capture: bool = False  # keep steps whose polygon holds the capture point (004's falls are certain)
    partial_shaping: str = "upper_body"  # upper_body: arms and torso only (never the stance leg, which undoes a lift) | eq7: 004's eq. 7, every joint but the swing leg | off
    whole_body_shaping: str = "off"  # off | on (004: No Action chosen unsafe, and tracking after a landed step, run whole-body inertia shaping)
    # What runs when no candidate is predicted safe: no_action, the fall as it is (whole-body shaping if on,
    # as in 004 Fig. 9; chosen on the development falls: the best of all turned 2 of 15 clear falls into hits
    # and avoided one more hit of 96) | best: the best score of all (our first reading of 004's lost rule)
    when_none_safe: str = "no_action"
    capture: str = "off"  # off (004: falls are certain) | prefer: a step predicted to stop the fall (capture point inside its polygon at the predicted landing), the widest margin, held after landing
    tracking: bool = (
        True  # 004 Secs. IV, VI: re-predict while the strategy runs; whole-body inertia shaping once unsafe
    )
    tracking_period: float = 0.02  # s between tracking predictions
    predictor: str = "pendulum"  # pendulum (004's) | rollout: a short simulation of each candidate without the objects, then the pendulum (rollout.py; not real time) | oracle: each candidate simulated in a copy of the scene (oracle.py; not real time)
    rollout_horizon: float = 0.7  # s: the longest rollout
    rollout_after_landing: float = (
        0.2  # s: a step's rollout goes on this long after its foot is down (then ends)
    )
    rollout_remainder: str = "pendulum"  # pendulum: 004's pendulum from the rolled-out state | velocity: the CoM's horizontal velocity direction then
    rollout_candidates: str = "swing"  # swing: Take a Step and Lift a Leg rolled out, No Action by the pendulum | steps: Take a Step only | all
    rollout_physics_dt: float = 0.0  # s: the rollouts' physics step; 0: the scenario's (1 ms moved rolled-out directions by 0.06 deg median on development falls, at 0.6 x the cost)
    rollout_radius_step: float = 0.15  # m between rolled-out step lengths (from step_radius_min)
    rollout_heading_step: float = 30.0  # deg between rolled-out step headings
    # Forced candidates, for measuring steering authority (a forced `mode` only; null: chosen by score)
    swing_side: str = ""  # left | right: the lifted or stepping foot
    step_length: float | None = None  # m: the step nearest this length and `step_bearing` ...
    step_bearing: float | None = None  # deg ... off No Action's predicted fall direction (+ counterclockwise)

    @property
    def w2(self) -> float:
        return 1.0 - self.w1


DIRECTION_PARAMS = {f.name: f.default for f in dataclasses.fields(DirectionConfig)}
