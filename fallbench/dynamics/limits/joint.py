"""Joint-range limits as joint-acceleration bounds over a short horizon (002 Sec. IV: joint limits
among the reshaping QP's constraints), optionally inside a margin and with the lag of a position
servo, so that a servo tracking the QP's motion stays inside the range."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from fallbench.dynamics.kernels import compiled
from fallbench.dynamics.limits.limit import Limit, LimitRows, Space
from fallbench.dynamics.state import RobotState

QDD_BOUND = 1e4  # rad/s^2: bounds beyond this add nothing and would only worsen the conditioning


@dataclass
class JointLimit(Limit):
    """Every actuated joint's servo rest point q + lag q_dot within [lo + margin, hi - margin] at the
    end of the horizon, if q_ddot is held over it. A PD servo K (q_ref - q) + B (qd_ref - q_dot) at
    rest settles at q_ref + (B / K) qd_ref: with lag = B / K (s) a joint heading for a range end is
    slowed to at most (distance to it) / lag, so that the servo does not carry it past (a velocity
    bound near the ends only). margin 0 and lag 0: the range itself, reached exactly.

    With a braking deceleration b (rad/s^2, per actuator) the joint's speed toward a range end at
    the end of the horizon is also held to what b can stop within the distance left,
    v_h^2 <= 2 b (end - q_h) (a viability bound): a 20 ms horizon alone lets a fast joint reach its
    end with more speed than its motor can take out, and the servo overshoots."""

    joint_range: np.ndarray  # (actuators, 2) rad, per actuator (MuJoCo order)
    horizon: float  # s
    margin: float = 0.0  # rad kept from each end of the range
    lag: np.ndarray = field(default_factory=lambda: np.zeros(0))  # s, per actuator; empty: 0
    # rad/s^2, per actuator; empty or 0: no braking bound
    braking: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def compute(self, state: RobotState) -> LimitRows:
        """Bounds on q_ddot (rad/s^2, all nv entries) that keep every actuated joint's servo rest
        point within its range less the margin over the horizon (`joint_acceleration_bounds`)."""
        lag = self.lag if len(self.lag) else np.zeros(len(self.joint_range))
        braking = self.braking if len(self.braking) else np.zeros(len(self.joint_range))
        band = reachable_band(self.joint_range, self.margin, state.q[state.robot.actuated_v + 1])
        lower, upper = joint_acceleration_bounds(
            state.q, state.v, state.robot.actuated_v, band, self.horizon, lag
        )
        if braking.any():
            lower, upper = self._brake(state, band, braking, lower, upper)
        return LimitRows.bounds(Space.ACCELERATION, lower, upper)

    def _brake(
        self, state: RobotState, band: np.ndarray, braking: np.ndarray, lower: np.ndarray, upper: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """The bounds narrowed by `braking_bounds` on the joints with braking > 0, where the two
        intervals meet (the range's alone where they do not)."""
        joints = state.robot.actuated_v
        position, rate = state.q[joints + 1], state.v[joints]
        distance = np.column_stack([position - band[:, 0], band[:, 1] - position])
        slow, fast = braking_bounds(distance, rate, self.horizon, braking)
        low, high = np.maximum(lower[joints], slow), np.minimum(upper[joints], fast)
        keep = (braking > 0.0) & (low <= high)
        lower, upper = lower.copy(), upper.copy()
        lower[joints[keep]], upper[joints[keep]] = low[keep], high[keep]
        return lower, upper


def inner_range(joint_range: np.ndarray, margin: float) -> np.ndarray:
    """[lo + margin, hi - margin] per joint (rad, (n, 2)); a range narrower than 2 margin shrinks to
    its midpoint."""
    middle = joint_range.mean(axis=1)
    low = np.minimum(joint_range[:, 0] + margin, middle)
    high = np.maximum(joint_range[:, 1] - margin, middle)
    return np.column_stack([low, high])


def reachable_band(joint_range: np.ndarray, margin: float, q: np.ndarray) -> np.ndarray:
    """The inner range (rad, (n, 2)) widened to each joint's position q (rad) where it lies between
    the inner range and the range's end: a joint in the margin may stay there but not go deeper
    (forcing it out within the horizon asked for accelerations the motors lack, and the QP failed)."""
    band = inner_range(joint_range, margin)
    low = np.minimum(band[:, 0], np.maximum(q, joint_range[:, 0]))
    high = np.maximum(band[:, 1], np.minimum(q, joint_range[:, 1]))
    return np.column_stack([low, high])


def servo_lag(kp: np.ndarray, kd: np.ndarray) -> np.ndarray:
    """B / K per joint (s): how far (rad) a PD servo's rest point q_ref + (B / K) qd_ref leads its
    position reference per rad/s of velocity reference; 0 where K is 0."""
    return np.divide(kd, kp, out=np.zeros(len(kp)), where=kp > 0)


def bounded_reference(
    q_ref: np.ndarray, qd_ref: np.ndarray, band: np.ndarray, lag: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Servo references (rad, rad/s) with q_ref inside `band` ((n, 2) rad) and the servo's rest point
    q_ref + lag qd_ref (lag in s) too: a reference clipped at a range end carries no velocity past it."""
    position = np.clip(q_ref, band[:, 0], band[:, 1])
    lead = qd_ref * lag
    lead = np.clip(lead, band[:, 0] - position, band[:, 1] - position)
    velocity = np.divide(lead, lag, out=qd_ref.copy(), where=lag > 0)
    return position, velocity


@compiled
def joint_acceleration_bounds(
    q: np.ndarray,
    v: np.ndarray,
    actuated_v: np.ndarray,
    joint_range: np.ndarray,
    horizon: float,
    lag: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """q_ddot bounds (rad/s^2, all nv velocity entries) from the configuration q and velocity v
    (Pinocchio's): on the actuated joints (velocity indices actuated_v, ranges joint_range and servo
    lags lag (s) in the same order) those that keep q_h + lag v_h within range, with q_h = q + v h +
    q_ddot h^2 / 2 and v_h = v + q_ddot h at the end of the horizon h (s), never an empty interval;
    +-QDD_BOUND elsewhere."""
    low, high = np.full(len(v), -QDD_BOUND), np.full(len(v), QDD_BOUND)
    for k in range(len(actuated_v)):
        i = actuated_v[k]
        position, rate = q[i + 1], v[i]  # a 1-dof joint's q index is its v index + 1 (the base's quaternion)
        reach, gain = horizon + lag[k], horizon**2 + 2 * lag[k] * horizon
        first = min(max(2 * (joint_range[k, 0] - position - rate * reach) / gain, -QDD_BOUND), QDD_BOUND)
        second = min(max(2 * (joint_range[k, 1] - position - rate * reach) / gain, -QDD_BOUND), QDD_BOUND)
        low[i], high[i] = min(first, second), max(first, second)
    return low, high


def braking_bounds(
    distance: np.ndarray, rate: np.ndarray, horizon: float, braking: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """q_ddot bounds (rad/s^2, per joint) held over the horizon h (s) after which each joint, at
    distance[:, 0] (rad) above its lower end and distance[:, 1] below its upper end, moving at rate
    (rad/s), can still stop before either end decelerating at braking (rad/s^2): the larger root of
    v_h^2 = 2 b (d - v h - q_ddot h^2 / 2) with v_h = v + q_ddot h toward that end; where no root is
    real, the bound that stops the joint at once (-v / h - b / 2)."""

    def largest(gap: np.ndarray, speed: np.ndarray) -> np.ndarray:
        discriminant = (
            4 * speed * horizon * braking + (braking * horizon) ** 2 + 8 * braking * (gap - speed * horizon)
        )
        root = np.sqrt(np.maximum(discriminant, 0.0))
        return np.clip((root - 2 * speed - braking * horizon) / (2 * horizon), -QDD_BOUND, QDD_BOUND)

    return -largest(distance[:, 0], -rate), largest(distance[:, 1], rate)
