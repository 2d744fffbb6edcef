"""When a fall is over: the robot at rest, read from the root's and the joints' speeds (or the
simulation diverged, `divergence`).

A run ends once, after the last disturbance (the push's end), the root body's linear speed (m/s),
its angular speed (rad/s) and every actuated joint's speed (rad/s) have stayed under the scenario's
`rest` thresholds for `rest.hold` seconds; or at its cap (`duration`), flagged as not settled.
Every whole-run measure is then read over the whole fall, not over a window that may stop before
it (a drop that tips over after 1.5 s).
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from fallbench.scenario import Scenario

DIVERGENCE_WARNINGS = np.array(
    [
        int(mujoco.mjtWarning.mjWARN_BADQACC),
        int(mujoco.mjtWarning.mjWARN_BADQVEL),
        int(mujoco.mjtWarning.mjWARN_BADQPOS),
    ]
)


class DivergenceWatch:
    """`divergence`'s test at every control step, on Python numbers: the views of MjData's warning
    counts and accelerations fetched once, and read as lists (a control step's first NumPy
    reduction, with the physics step's code in the caches, took ~5 us; this ~1.5 us).

    The accelerations' sum is added in order rather than pairwise: only whether it is finite counts,
    and that is the same for both orders unless a term exceeds the largest double / nv (~5e306 for
    TALOS; one order may then overflow where the other does not), far past the 1e10 at which
    MuJoCo flags mjWARN_BADQACC, which is read first."""

    def __init__(self, data: mujoco.MjData) -> None:
        self.data, self.counts, self.qacc = data, data.warning.number, data.qacc
        self.warnings = DIVERGENCE_WARNINGS.tolist()

    def reason(self) -> str | None:
        """`divergence(data)`."""
        counts = self.counts.tolist()
        if not any([counts[w] for w in self.warnings]) and math.isfinite(sum(self.qacc.tolist())):
            return None
        return divergence(self.data)


def divergence(data: mujoco.MjData) -> str | None:
    """Why the simulation diverged (MuJoCo's divergence warnings, or a NaN or inf in the
    accelerations), None if it did not: the run then stops and is stored as diverged."""
    counts = data.warning.number
    if not counts[DIVERGENCE_WARNINGS].any() and math.isfinite(data.qacc.sum()):
        return None
    return (
        ", ".join(mujoco.mjtWarning(w).name for w in DIVERGENCE_WARNINGS if counts[w]) or "non-finite state"
    )


# Rest postures (`rest_posture`), from the torso's axes and the root's height at the end of the run.
UPRIGHT_TILT = 45.0  # deg: a torso within this of upright is standing, sitting or kneeling


class RestWatch:
    """Watches the speeds at each control step; `settled` once they have stayed under the
    thresholds for the hold time (s) after the last disturbance."""

    def __init__(self, scenario: Scenario, qvel_adr: np.ndarray) -> None:
        rest, push = scenario.rest, scenario.push
        self.rest, self.qvel_adr = rest, qvel_adr
        self.after = push.start + push.duration if push is not None and push.force > 0 else 0.0  # s
        self.still_since: float | None = None  # s: start of the current still stretch
        self.settled = False

    def update(self, t: float, qvel: np.ndarray) -> bool:
        """Read the state at `t` (s); True once the robot has come to rest."""
        rest = self.rest
        # the root's speeds on Python floats: the same squares and sums as on NumPy's scalars
        vx, vy, vz, wx, wy, wz = qvel[:6].tolist()
        still = (
            t >= self.after - 1e-9
            and math.sqrt(vx**2 + vy**2 + vz**2) < rest.linear_speed
            and math.sqrt(wx**2 + wy**2 + wz**2) < rest.angular_speed
            and float(np.abs(qvel[self.qvel_adr]).max()) < rest.joint_speed
        )
        if not still:
            self.still_since = None
        elif self.still_since is None:
            self.still_since = t
        self.settled = self.still_since is not None and t - self.still_since >= rest.hold - 1e-9
        return self.settled

    @property
    def time_to_rest(self) -> float | None:
        """s from the run's start to the start of the stretch at rest; None if not settled."""
        return self.still_since if self.settled else None


def rest_posture(frame: np.ndarray, fell: bool) -> str:
    """standing, sitting (or kneeling), leaning, lying_front, lying_back or lying_side, from the
    torso's forward, left and up axes in the world (columns of `frame`) and whether the root is
    below its fallen height (`fell`). Upright is a torso within UPRIGHT_TILT of vertical; a tilted
    torso with the root still high leans (on an object); otherwise the robot lies, on the side
    whose axis points most nearly down or up (forward down: on the front)."""
    forward, left, up = frame[:, 0], frame[:, 1], frame[:, 2]
    if up[2] >= math.cos(math.radians(UPRIGHT_TILT)):
        return "sitting" if fell else "standing"
    if not fell:
        return "leaning"
    if abs(forward[2]) >= abs(left[2]):
        return "lying_front" if forward[2] < 0 else "lying_back"
    return "lying_side"
