"""The one builder of both QPs: variables y, joint accelerations q_ddot = M y + m, motor torques
tau = T y + t, set-point costs (summed in joint-acceleration space, then carried into y once),
regularisations, equality and inequality rows on y, limits (`LimitRows` on q_ddot or tau, carried
into y), bounds on y; then scaled for the solver (physical y = scale * x)."""

from __future__ import annotations

import numpy as np

from fallbench.dynamics.dense_qp import ScaledQP
from fallbench.dynamics.kernels import scaled_problem
from fallbench.dynamics.limits.limit import LimitRows, Space
from fallbench.dynamics.limits.torque import TorqueMap
from fallbench.dynamics.objective import AccelerationMap, SetPoint, task_metric


class QPBuilder:
    def __init__(
        self,
        acceleration: AccelerationMap,
        scale: np.ndarray,
        v: np.ndarray,
        torques: TorqueMap | None = None,
    ) -> None:
        """`torques`: how the variables give the motor torques, for torque limits."""
        n = len(scale)
        self.acceleration, self.scale, self.v, self.torques = acceleration, scale, v, torques
        self.tasks: list[SetPoint] = []
        self.regularisation = np.zeros(n)  # added to the Hessian's diagonal
        self.equalities: list[tuple[np.ndarray, np.ndarray]] = []
        self.inequalities: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
        self.lower, self.upper = np.full(n, -np.inf), np.full(n, np.inf)

    def cost(self, tasks: list[SetPoint]) -> None:
        self.tasks.extend(tasks)

    def regularise(self, variables: slice, weight: float) -> None:
        """weight |y[variables]|^2."""
        self.regularisation[variables] += weight

    def equal(self, A: np.ndarray, b: np.ndarray) -> None:
        """A y = b."""
        self.equalities.append((A, b))

    def within(self, C: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> None:
        """lower <= C y <= upper."""
        self.inequalities.append((C, lower, upper))

    def limit(self, rows: LimitRows) -> None:
        """A limit's rows, carried into y through the acceleration or torque map."""
        if rows.space is Space.ACCELERATION:
            self._acceleration_limit(rows)
        else:
            self._torque_limit(rows)

    def _acceleration_limit(self, rows: LimitRows) -> None:
        acceleration = self.acceleration
        if rows.matrix is None:  # bounds on q_ddot: bounds on y only when q_ddot is y's leading part
            if not acceleration.leading:
                raise ValueError("bounds on q_ddot need q_ddot among the variables")
            self.bound(slice(0, len(acceleration.m)), rows.lower, rows.upper)
            return
        # R q_ddot = R M y + R m
        matrix, offset = rows.matrix @ acceleration.M, rows.matrix @ acceleration.m
        if rows.equality:
            self.equal(matrix, rows.lower - offset)
        else:
            self.within(matrix, rows.lower - offset, rows.upper - offset)

    def _torque_limit(self, rows: LimitRows) -> None:
        torques = self.torques
        if torques is None or rows.matrix is not None or rows.equality:
            raise ValueError("torque limits are bounds, on a QP that gives its torque map")
        motors = torques.motors
        self.within(torques.matrix, rows.lower[motors] - torques.bias, rows.upper[motors] - torques.bias)

    def bound(self, variables: slice, lower: float | np.ndarray, upper: float | np.ndarray) -> None:
        self.lower[variables], self.upper[variables] = lower, upper

    def build(self, ridge: float = 0.0, equilibrate: bool = False) -> ScaledQP:
        """The scaled problem. With `equilibrate` the variables are further scaled so that the
        Hessian's diagonal is one (Jacobi scaling: on these problems it cut ProxSuite's iterations
        several times over, more on lighter robots whose cost curvatures spread wider). `ridge`
        then adds ridge |x|^2 in solver units, a numerical regularisation that keeps nearly free
        directions (redundant friction-cone coefficients, gains whose error is near zero) from
        slowing the solver down."""
        n = len(self.scale)
        rows, values = np.zeros((0, n)), np.zeros(0)  # when there are none
        A, b = (
            _stacked([a for a, _ in self.equalities], rows),
            _stacked([b for _, b in self.equalities], values),
        )
        C = _stacked([c for c, _, _ in self.inequalities], rows)
        l, u = (
            _stacked([lo for _, lo, _ in self.inequalities], values),
            _stacked([up for _, _, up in self.inequalities], values),
        )
        acceleration = self.acceleration
        H, g, A, C, l_box, u_box, scale = scaled_problem(
            acceleration.M,
            acceleration.m,
            acceleration.leading,
            *task_metric(self.tasks, self.v),
            self.regularisation,
            A,
            C,
            self.lower,
            self.upper,
            self.scale,
            float(ridge),
            equilibrate,
        )
        return ScaledQP(H=H, g=g, A=A, b=b, C=C, l=l, u=u, l_box=l_box, u_box=u_box, scale=scale)


def _stacked(blocks: list[np.ndarray], empty: np.ndarray) -> np.ndarray:
    """The blocks one after the other along their first axis; `empty` when there are none."""
    if not blocks:
        return empty
    return blocks[0] if len(blocks) == 1 else np.concatenate(blocks)
