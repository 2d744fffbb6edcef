"""The control loop of one fall and the recorder of its time series.

Physics at `physics_dt`, controller every `control_dt`: state -> fall detector -> pre-impact
strategy -> impact detector -> gain policy -> servo references and gains written into the
actuators. Everything the metrics need is recorded at the physics rate from MuJoCo's sensors
(computed in C inside the step).

Impacts switch the motors to the gain policy on the takeover schedule (`takeover.py`: all at the
first impact, or per chain). Contacts the strategy planned (a footstep) are not impacts, nor,
before the first impact, is a foot set down while a foot of the other leg touches (a step: the foot
joins the support; in a drop no foot touches, and the first foot down is the impact). A
whole-fall controller (`hands_over` False, a learned fall policy) never hands its motors over: it
commands them from fall detection to the episode's end, and impacts are only logged.

Impacts are watched inside the physics substeps: after fall detection, and until every motor has
switched, a body touching for the first time (its contact sensor's "found" column) ends the substeps
and runs a control step at once, which logs the impact at the time of the first sample showing the
contact. The motors of that impact switch to the gain policy `timing.takeover_latency` seconds
later (the substeps end then too), whatever the physics step. The regular control grid then
resumes.
"""

from __future__ import annotations

import math
import time
from typing import Any, NamedTuple

import mujoco
import numpy as np

from fallbench.scenario import Scenario
from fallbench.sim.controllers import Observation, PostImpactController, PreImpactController
from fallbench.sim.events import FallWatch, ImpactDetector, SignalLog, make_fall_detector
from fallbench.sim.impacts import ImpactLog, body_sides
from fallbench.sim.push import PushForce
from fallbench.sim.recorder import Recording, Trace
from fallbench.sim.rest import DivergenceWatch, RestWatch
from fallbench.sim.sensing import DetectorInputs, Sensing
from fallbench.sim.servo import ServoCommand, write_servo
from fallbench.sim.takeover import Takeover
from fallbench.sim.world import World, initial_state

# Divergence is read from data.warning and stored with the run; MuJoCo's own printout (and its
# MUJOCO_LOG.TXT in the working folder) would only clutter a sweep's output.
mujoco.set_mju_user_warning(lambda message: None)


class Sensed(NamedTuple):
    """What the first half of a control step found, for its second half."""

    t: float  # s
    started: float  # perf_counter s at the step's start (the controller's timing)
    found: np.ndarray  # per contact body: touching since the last control step
    switched_now: bool  # motors switched to the gain policy at this step


class Episode:
    """One fall of a built world under a pre-impact strategy and a gain policy (the data path of
    docs/architecture.md): each control step runs the fall detector, the strategy, the impact detector, the gain
    policy and the servo, then the physics substeps record the trace."""

    def __init__(
        self,
        world: World,
        scenario: Scenario,
        policy: PostImpactController,
        strategy: PreImpactController,
        pre_impact: str,
    ) -> None:
        self.world, self.scenario, self.pre_impact = world, scenario, pre_impact
        self.policy, self.strategy = policy, strategy
        model = world.model
        self.data = data = initial_state(world, scenario)
        # views of MjData's arrays the substeps record, fetched once (each read of an MjData array
        # makes a new view)
        self.recorded = (data.qpos, data.qvel, data.sensordata, data.actuator_force)
        self.per_control = scenario.physics_steps_per_control
        self.n_steps = math.ceil(scenario.duration / scenario.control_dt - 1e-9) * self.per_control
        self.trace = Trace(self.n_steps, model.nsensordata, model.nq, model.nv, model.nu)
        # a control step's substeps record their rows here, in the caches, and the trace takes them
        # at once: written one by one into the trace's fresh memory, they cost ~2 us a substep
        self.block = tuple(np.empty((self.per_control, len(array))) for array in self.recorded)
        self.impacts = ImpactLog(world)
        self.sensing = Sensing(world)
        self.fall, self.impact = make_fall_detector(scenario), ImpactDetector()
        self.signals = SignalLog()
        detection = scenario.detection
        self.watch = FallWatch(detection.hand_back_margin, detection.tilt, detection.hand_back_hold)
        feet = world.robot.body_groups.get("feet", ())
        self.feet = np.isin(world.contact_bodies, list(feet))
        self.not_feet = ~self.feet  # contact bodies whose touch is an impact
        sides = body_sides(world)
        self.sides = [sides.get(body, "") for body in world.contact_bodies]  # the leg a foot hangs from
        self.found_columns = columns = world.contact_found_index
        # MjData's "found" columns (or its whole sensor row), a view: while none is nonzero, no
        # contact body touches
        self.touch_columns = data.sensordata[columns] if isinstance(columns, slice) else data.sensordata
        self.takeover = Takeover(world, scenario.timing, strategy.per_chain_switching)
        self.push = PushForce.of(world, scenario)
        self.pre_command = ServoCommand(
            world.default_kp, world.default_kd, data.qpos[world.qpos_adr].copy(), np.zeros(model.nu)
        )
        self.stance = self.pre_command  # the stance controller a strategy hands back to
        self.started: float | None = None  # s: the strategy's start (see `start_strategy`)
        self.policy_command: ServoCommand | None = None
        self.written = self.pre_command
        # before the first forward pass: the run's model holds the scene's unscaled gains
        write_servo(model, data, self.written)
        self.trace.changes.append((0, self.written))
        mujoco.mj_forward(model, data)
        self.sensor_row = data.sensordata.copy()
        self.controller_ms: list[float] = []
        self.seen = np.zeros(len(world.contact_bodies), dtype=bool)  # bodies in contact at detection or since
        # bodies whose contact would be an impact (not a planned footstep)
        self.unplanned: np.ndarray | bool = True
        self.step = self.since = 0  # physics step now, and at the previous control step
        self.physics_s, self.status, self.error = 0.0, "ok", ""
        self.rest = RestWatch(scenario, world.qvel_adr)
        self.divergence = DivergenceWatch(data)

    @property
    def finished(self) -> bool:
        """The episode's end: the robot at rest, the cap (`duration`) reached, or the run diverged."""
        return self.rest.settled or self.capped or self.status == "diverged"

    @property
    def capped(self) -> bool:
        """Whether the run reached its cap before coming to rest."""
        return self.step >= self.n_steps and not self.rest.settled

    def run(self) -> Recording:
        while not self.finished:
            self.act(self.sense())
        return self.recording()

    def sense(self) -> Sensed:
        """The first half of a control step: fall detection, impacts, takeovers falling due. A
        caller driving the episode itself (the Gymnasium environment) may read the state between
        `sense` and `act`: nothing between them moves the simulation."""
        t = self.step * self.scenario.physics_dt
        started = time.perf_counter()
        watching_fall = self.impact.time is None and not self.fall.all_fired
        inputs = self.detector_inputs() if watching_fall or self.signals.watching else None
        if inputs is not None:
            body = np.count_nonzero(inputs.found & self.not_feet) > 0
            self.signals.log(t, inputs.distance, inputs.tilt, inputs.acc, body)
            if watching_fall:
                self.detect_fall(t, inputs)
            self.start_strategy(t)
            self.watch_fall(t)
        switched_now = False
        if self.fall.time is None:
            found = self.seen
        else:  # the contact sensors this step, read once
            found = inputs.found if inputs is not None else self.found()
        if self.fall.time is not None:
            self.detect_impacts(found)
            if self.takeover.due:  # (nothing to switch otherwise)
                switched_now = self.takeover.take_over(t, self.data.qpos[self.world.qpos_adr])
        return Sensed(t, started, found, switched_now)

    def strategy_steps_now(self) -> bool:
        """Whether `act` will ask the strategy for a command at this control step."""
        return (
            self.started is not None
            and self.watch.time is None
            and not self.takeover.all_switched
            and self.step % self.per_control == 0
        )

    def act(self, sensed: Sensed) -> None:
        """The second half of a control step: the strategy, the gain policy, the servo, the push,
        and the physics substeps to the next control step."""
        t = sensed.t
        self.strategy_step(t)
        command = self.command(t, sensed.found, sensed.switched_now)
        self.controller_ms.append(
            (time.perf_counter() - sensed.started) * 1e3 if self.fall.time is not None else 0.0
        )
        self.write(command)
        self.apply_push(t)
        self.physics()
        if not self.diverged():
            self.rest.update(self.step * self.scenario.physics_dt, self.recorded[1])

    def found(self) -> np.ndarray:
        """Per contact body: whether its contact sensor found a contact since the last control step
        (read from the substeps' rows while they are in the caches: the trace's copy of them)."""
        rows = self.block[2][: self.step - self.since] if self.step else self.sensor_row[None]
        # (np.maximum.reduce: `.max(axis=0)` without its Python wrapper)
        return np.maximum.reduce(rows[:, self.found_columns], axis=0) > 0

    def names(self, mask: np.ndarray) -> set[str]:
        return {self.world.contact_bodies[i] for i in np.flatnonzero(mask)}

    def detector_inputs(self) -> DetectorInputs:
        """What the fall detectors read at this control step (`sensing.Sensing.detector_inputs`)."""
        return self.sensing.detector_inputs(self.data, self.sensor_row, self.found())

    def detect_fall(self, t: float, inputs: DetectorInputs) -> None:
        """Feed the fall detectors (every one is watched until the first impact); at detection,
        note the bodies already touching."""
        detected = self.fall.time is not None
        if (
            self.fall.observe(t, len(inputs.support) > 0, inputs.distance, inputs.tilt, inputs.acc)
            and not detected
        ):
            self.seen = self.sensing.whole_feet(inputs.found)
            self.impact.start(self.names(self.seen))

    def start_strategy(self, t: float) -> None:
        """A whole-fall controller starts at the declared detection; a pre-impact strategy once
        one of `detection.act_on` sees the robot topple, at the declaration or later, before a body
        other than the feet touches (free fall alone is no topple: a drop may land on its feet)."""
        if self.started is not None or self.fall.time is None:
            return
        if self.strategy.hands_over and not self.toppling():
            return
        self.started = t
        self.strategy.start(t, self.data)

    def toppling(self) -> bool:
        """Whether a detector of `detection.act_on` fires at this control step (from the logged
        signals, by the detectors' own rules)."""
        if not self.signals.watching:
            return False
        _, distance, tilt, _ = self.signals.rows[-1]
        detection = self.scenario.detection
        margin = self.strategy.start_margin
        margin = detection.capture_point_margin if margin is None else margin
        return ("capture_point" in detection.act_on and distance > margin) or (
            "tilt" in detection.act_on and tilt > detection.tilt
        )

    def watch_fall(self, t: float) -> None:
        """After the strategy started, until a body other than the feet touches: on a fall that
        does not go on (`events.FallWatch`), the strategy stops and its motors go back to the stance
        controller: the stance gains, holding the posture the robot has then (snapping back to the
        starting posture toppled TALOS in docs/detection.md's example). The strategy does not act
        again in the run; motors already under the gain policy stay there."""
        acting = self.started is not None and self.watch.time is None and self.strategy.hands_over
        if not acting or not self.signals.watching or not self.scenario.detection.hand_back:
            return
        _, distance, tilt, _ = self.signals.rows[-1]
        if self.watch.update(t, distance, tilt):  # hold the posture it has, with the stance gains
            q = self.data.qpos[self.world.qpos_adr].copy()
            self.pre_command = ServoCommand(self.stance.kp, self.stance.kd, q, np.zeros_like(q))

    def detect_impacts(self, found: np.ndarray) -> None:
        """Log bodies touching for the first time since detection (planned footsteps excepted) at
        the time their contact was first sampled, and schedule the switch of their chains' motors
        (all motors, unless the strategy switches per chain) `timing.takeover_latency` s later."""
        planned = self.strategy.planned_contacts()
        self.unplanned = ~np.isin(self.world.contact_bodies, list(planned)) if planned else True
        fresh = found > self.seen  # found & ~seen, in one operation
        if planned:
            fresh &= self.unplanned
        if not np.count_nonzero(fresh):
            return
        if self.impact.time is None:  # before the first impact, a foot set down beside another is a step
            fresh = self.without_steps(found, fresh)
            if not np.count_nonzero(fresh):
                return
        self.seen |= fresh
        new, touched = self.names(fresh), self.first_sampled(fresh)
        first = self.impact.time is None
        self.impact.update(touched, new)
        self.impacts.update(touched, new, self.data, self.data.qpos, self.data.qvel)
        if self.impact.time is None or self.takeover.all_switched or not self.strategy.hands_over:
            return  # a whole-fall controller (`hands_over` False) keeps its motors
        self.takeover.schedule(touched, new, first)

    def without_steps(self, found: np.ndarray, fresh: np.ndarray) -> np.ndarray:
        """`fresh` less the steps: a foot touching down while a foot of another leg touches (the
        robot rocked onto one foot setting the other down) joins the support, as the capture point
        and the hand-back watch already take it; it is no impact (no takeover, not the first
        impact, not in the impact log). In a drop no foot touches: the first foot down is the impact."""
        landing = fresh & self.feet
        if not np.count_nonzero(landing):
            return fresh
        legs = {self.sides[i] for i in np.flatnonzero(landing)}
        supporting = found & self.feet & ~fresh
        if not any(self.sides[i] not in legs for i in np.flatnonzero(supporting)):
            return fresh
        self.seen |= self.sensing.whole_feet(landing)  # the foot and its chain are support from now on
        return fresh & ~self.seen

    def first_sampled(self, bodies: np.ndarray) -> float:
        """s: the first physics sample since the last control step in which one of `bodies` touched
        (sensor rows are computed from the state at the start of their step)."""
        if not self.step:
            return 0.0
        rows = self.trace.sensordata[self.since : self.step][:, self.world.contact_found_columns[bodies]]
        return (self.since + int(np.argmax(rows.max(axis=1) > 0))) * self.scenario.physics_dt

    def strategy_step(self, t: float) -> None:
        """The strategy's own command on its control grid, until every motor has switched or it
        handed back."""
        if self.strategy_steps_now():
            self.pre_command = self.strategy.step(t, self.data) or self.pre_command

    def command(self, t: float, found: np.ndarray, switched_now: bool) -> ServoCommand:
        """The servo command: the gain policy's on switched motors, the strategy's on the others."""
        takeover, policy = self.takeover, self.policy
        if not takeover.any_switched:
            return self.pre_command
        if switched_now or not policy.static or self.policy_command is None:
            world, qpos, qvel = self.world, self.data.qpos, self.data.qvel
            touching = self.names(found) if policy.needs_contacts else set()
            observation = Observation(
                t, qpos.copy(), qvel.copy(), qpos[world.qpos_adr], qvel[world.qvel_adr], touching, self.data
            )
            assert takeover.q_ref is not None
            self.policy_command = policy.after_impact(observation, takeover.q_ref)
        return takeover.compose(self.policy_command, self.pre_command)

    def write(self, command: ServoCommand) -> None:
        if command is not self.written:
            write_servo(self.world.model, self.data, command)
            self.written = command
            self.trace.changes.append((self.step, command))

    def apply_push(self, t: float) -> None:
        if self.push is not None:
            self.push.apply(self.data, t)

    def physics(self) -> None:
        """The physics substeps up to the next control step, recorded; until every motor has
        switched (never under a whole-fall controller), a body touching for the first time ends
        them at once (to log the impact), and so does a takeover falling due."""
        self.since = self.step
        # a whole-fall controller hands nothing over: its impacts are logged from the trace alone
        watching = self.fall.time is not None and not self.takeover.all_switched and self.strategy.hands_over
        watched = self.world.contact_found_columns[self.watched_bodies()] if watching else None
        model, data, trace = self.world.model, self.data, self.trace
        trace.reserve(self.step + self.per_control)
        # s: the earliest takeover falling due (the list does not change during the substeps)
        due_at = self.takeover.due_at()
        # the substeps run some 800 000 times a sweep: MjData's and the trace's arrays, the step,
        # the physics time and the functions called are read once here, not per substep
        mj_step, clock, nonzero = mujoco.mj_step, time.perf_counter, np.count_nonzero
        qpos, qvel, sensordata, actuator_force = self.recorded
        touching = self.touch_columns
        block_qpos, block_qvel, block_sensordata, block_actuator_force = self.block
        step, physics_dt, physics_s = self.step, self.scenario.physics_dt, self.physics_s
        substeps = self.per_control - step % self.per_control
        if due_at < math.inf:  # the first substep ending at or past it is the last (found here, once)
            substeps = next((k for k in range(1, substeps) if (step + k) * physics_dt >= due_at), substeps)
        for row in range(substeps):
            block_qpos[row] = qpos
            block_qvel[row] = qvel
            stepped = clock()
            mj_step(model, data)
            physics_s += clock() - stepped
            # sensors and actuator forces are computed inside the step, from the state before it
            block_sensordata[row] = sensordata
            block_actuator_force[row] = actuator_force
            step += 1
            # (count_nonzero: `.any()`'s answer, NaN included, without a reduction's ~0.7 us; the
            # watched columns are read only once a body touches)
            if watched is not None and nonzero(touching) and nonzero(sensordata.take(watched)):
                break
        since, rows = self.since, step - self.since
        trace.qpos[since:step], trace.qvel[since:step] = block_qpos[:rows], block_qvel[:rows]
        trace.sensordata[since:step] = block_sensordata[:rows]
        trace.actuator_force[since:step] = block_actuator_force[:rows]
        self.step, self.physics_s = step, physics_s
        self.sensor_row = trace.sensordata[step - 1]

    def watched_bodies(self) -> np.ndarray:
        """The contact bodies not seen touching yet whose contact would be an impact (unplanned)."""
        fresh = ~self.seen
        return fresh if self.unplanned is True else fresh & self.unplanned

    def diverged(self) -> bool:
        """A divergence warning or a NaN or inf anywhere: the run stops and is stored as diverged."""
        reason = self.divergence.reason()
        if reason is None:
            return False
        self.status, self.error = "diverged", reason
        return True

    def recording(self) -> Recording:
        step, trace, scenario = self.step, self.trace, self.scenario
        held = trace.held(step, self.world.model.nu)
        return Recording(
            world=self.world,
            scenario=scenario,
            time=np.arange(step) * scenario.physics_dt,
            sensordata=trace.sensordata[:step],
            qpos=trace.qpos[:step],
            qvel=trace.qvel[:step],
            actuator_force=trace.actuator_force[:step],
            kp=held[0],
            kd=held[1],
            q_ref=held[2],
            qd_ref=held[3],
            fall_time=self.fall.time,
            fall_reason=self.fall.reason,
            fall_times=dict(self.fall.times),
            detection_signals=self.signals.array(),
            body_contact_time=self.signals.body_contact_time,
            hand_back_time=self.watch.time,
            strategy_start_time=self.started,
            impact_time=self.impact.time,
            impact_bodies=self.impact.bodies,
            controller_ms=np.array(self.controller_ms),
            physics_s=self.physics_s,
            pre_impact=self.pre_impact,
            impact_events=self.impacts.events,
            first_contacts=self.impacts.first_contacts,
            policy_stats=self.policy.stats() | self.strategy.stats(),
            strategy=self.strategy,
            switch_time=self.takeover.time,
            policy_failure_times=self.policy.failure_times(),
            steps=step,
            status=self.status,
            error=self.error,
            time_to_rest=self.rest.time_to_rest,
            rest_frame=self.world.robot.torso_frame(self.data.xmat[self.world.torso_body].reshape(3, 3)),
        )


def run_episode(
    world: World,
    scenario: Scenario,
    policy: PostImpactController,
    strategy: PreImpactController,
    pre_impact: str = "none",
    stat_columns: dict[str, Any] | None = None,
) -> Recording:
    """Simulate one fall; `world` is built from `scenario` (with the baseline gains the run uses),
    `pre_impact` names the strategy in the recording, and `stat_columns` are the columns every run's
    row has (`Recording.stat_columns`)."""
    recording = Episode(world, scenario, policy, strategy, pre_impact).run()
    recording.stat_columns = dict(stat_columns or {})
    return recording
