"""The one ProxSuite wrapper of both QPs: a dense solver reused while the problem's sizes stay the same.

Determinism: ProxSuite's AVX2 and AVX-512 builds (the ones `import proxsuite` picks on this kind of
machine) return different solution bits for the same problem depending on where the heap placed the
solver's workspace (measured with ProxSuite 0.8.0: identical problems and calls, only an unrelated
allocation before the solver's creation changed, gave different iterates). Heap layout differs from
one process to the next, so a QP-driven run was not bit-reproducible. The plain SSE2 build does not
depend on it and is as fast on these small problems, so it is the one loaded here.
"""

from __future__ import annotations

import sys
import types
from dataclasses import dataclass

import numpy as np


def _load_plain_proxsuite() -> types.ModuleType:
    """`proxsuite` with its SSE2 build: its loader picks the widest instruction set it finds, so
    it is told there is none wider before it runs (only if proxsuite is not loaded yet)."""
    if "proxsuite" not in sys.modules:
        probe = types.ModuleType("proxsuite.instructionset")
        probe.has_AVX512F = probe.has_AVX2 = lambda: False  # type: ignore[attr-defined]
        sys.modules["proxsuite.instructionset"] = probe
    import proxsuite

    if proxsuite.proxqp.__name__ != "proxsuite.proxsuite_pywrap.proxqp":
        raise ImportError(f"proxsuite was imported before fallbench.dynamics.dense_qp and loaded {proxsuite.proxqp.__name__}, "
                          "whose results depend on memory placement; import fallbench first")
    return proxsuite


proxsuite = _load_plain_proxsuite()


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
    """One ProxSuite solver per problem size (sizes change with the number of contacts), kept for
    the episode unless its solve fails. With `warm_start` each solve starts from that solver's
    previous solution (fewer iterations on a sequence of similar problems); otherwise from the
    equality-constrained guess."""

    def __init__(self, eps_abs: float, max_iter: int, max_iter_in: int = 1500, warm_start: bool = False) -> None:
        self.eps_abs, self.max_iter, self.max_iter_in = eps_abs, max_iter, max_iter_in  # 1500: ProxSuite's default
        self.warm_start = warm_start
        self.solvers: dict[tuple[int, int, int], proxsuite.proxqp.dense.QP] = {}

    def _new_solver(self, dims: tuple[int, int, int]) -> proxsuite.proxqp.dense.QP:
        solver = proxsuite.proxqp.dense.QP(*dims, box_constraints=True)
        solver.settings.eps_abs = self.eps_abs
        solver.settings.max_iter = self.max_iter
        solver.settings.max_iter_in = self.max_iter_in
        guess = proxsuite.proxqp.InitialGuess
        solver.settings.initial_guess = guess.WARM_START_WITH_PREVIOUS_RESULT if self.warm_start else guess.EQUALITY_CONSTRAINED_INITIAL_GUESS
        solver.settings.verbose = False
        return solver

    def solve(self, problem: ScaledQP) -> tuple[str, bool, int, np.ndarray]:
        """(status, solved, iterations, x in physical units)."""
        args = (problem.H, problem.g, problem.A, problem.b, problem.C, problem.l, problem.u, problem.l_box, problem.u_box)
        dims = (problem.H.shape[0], problem.A.shape[0], problem.C.shape[0])
        solver = self.solvers.get(dims)
        if solver is None:
            solver = self.solvers[dims] = self._new_solver(dims)
            solver.init(*args)
        else:
            solver.update(*args)
        solver.solve()
        info = solver.results.info
        status = info.status.name.removeprefix("PROXQP_")
        if status != "SOLVED":
            del self.solvers[dims]  # a failed iterate is no start for the next solve
        return status, status == "SOLVED", int(info.iter), problem.scale * solver.results.x
