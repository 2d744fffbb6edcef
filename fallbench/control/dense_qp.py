"""One ProxSuite dense solver reused across control steps while the problem's sizes stay the same."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import proxsuite


@dataclass
class ScaledQP:
    """min 1/2 x'Hx + g'x, Ax = b, l <= Cx <= u, l_box <= x <= u_box; physical = scale * x."""

    H: np.ndarray
    g: np.ndarray
    A: np.ndarray
    b: np.ndarray
    C: np.ndarray
    l: np.ndarray
    u: np.ndarray
    l_box: np.ndarray
    u_box: np.ndarray
    scale: np.ndarray


class DenseQP:
    def __init__(self, eps_abs: float, max_iter: int, max_iter_in: int = 1500) -> None:
        self.eps_abs, self.max_iter, self.max_iter_in = eps_abs, max_iter, max_iter_in  # 1500: ProxSuite's default
        self.solver: proxsuite.proxqp.dense.QP | None = None
        self.dims: tuple[int, int, int] | None = None

    def solve(self, problem: ScaledQP) -> tuple[str, bool, int, np.ndarray]:
        """(status, solved, iterations, x in physical units)."""
        args = (problem.H, problem.g, problem.A, problem.b, problem.C, problem.l, problem.u, problem.l_box, problem.u_box)
        dims = (problem.H.shape[0], problem.A.shape[0], problem.C.shape[0])
        if dims != self.dims or self.solver is None:
            self.solver = proxsuite.proxqp.dense.QP(*dims, box_constraints=True)
            self.solver.settings.eps_abs = self.eps_abs
            self.solver.settings.max_iter = self.max_iter
            self.solver.settings.max_iter_in = self.max_iter_in
            self.solver.settings.initial_guess = proxsuite.proxqp.InitialGuess.EQUALITY_CONSTRAINED_INITIAL_GUESS
            self.solver.settings.verbose = False
            self.solver.init(*args)
            self.dims = dims
        else:
            self.solver.update(*args)
        self.solver.solve()
        info = self.solver.results.info
        status = info.status.name.removeprefix("PROXQP_")
        return status, status == "SOLVED", int(info.iter), problem.scale * self.solver.results.x
