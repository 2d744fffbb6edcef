"""The QP solvers of both QPs, behind one `solve(problem)`: ProxSuite's dense solver (the default)
and DAQP's dual active-set solver (an option, `solver: daqp`).

Determinism: ProxSuite's AVX2 and AVX-512 builds (the ones `import proxsuite` picks on this kind of
machine) return different solution bits for the same problem depending on where the heap placed the
solver's workspace (measured with ProxSuite 0.8.0: identical problems and calls, only an unrelated
allocation before the solver's creation changed, gave different iterates). Heap layout differs from
one process to the next, so a QP-driven run was not bit-reproducible. The plain SSE2 build does not
depend on it and is as fast on these small problems, so it is the one loaded here.

Speed: on the adaptive-gain QP (24-80 variables) ProxSuite's interior steps cost ~40-100 us each
(one KKT factorisation over all variables and constraints, box constraints included), ~0.2-0.3 ms
per solve; DAQP's active-set steps are rank-one updates of a factorisation, ~0.05 ms per solve from
scratch. DAQP solves exactly up to its primal tolerance; ProxSuite up to eps_abs.
"""

from __future__ import annotations

import sys
import types
from dataclasses import dataclass
from typing import Protocol

import daqp
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
        raise ImportError(
            f"proxsuite was imported before fallbench.dynamics.dense_qp and loaded {proxsuite.proxqp.__name__}, "
            "whose results depend on memory placement; import fallbench first"
        )
    return proxsuite


proxsuite = _load_plain_proxsuite()

QP_SOLVERS = ("proxsuite", "daqp")


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


class QPSolver(Protocol):
    def solve(self, problem: ScaledQP) -> tuple[str, bool, int, np.ndarray]:
        """(status, solved, iterations, x in physical units); status as ProxSuite names it."""


class ProxSuiteQP:
    """One ProxSuite dense solver per problem size (sizes change with the number of contacts), kept
    for the episode unless its solve fails. With `warm_start` each solve starts from that solver's
    previous solution (fewer iterations on a sequence of similar problems); otherwise from the
    equality-constrained guess."""

    def __init__(
        self, eps_abs: float, max_iter: int, max_iter_in: int = 1500, warm_start: bool = False
    ) -> None:
        self.eps_abs, self.max_iter, self.max_iter_in = (
            eps_abs,
            max_iter,
            max_iter_in,
        )  # 1500: ProxSuite's default
        self.warm_start = warm_start
        self.solvers: dict[tuple[int, int, int], proxsuite.proxqp.dense.QP] = {}

    def _new_solver(self, dims: tuple[int, int, int]) -> proxsuite.proxqp.dense.QP:
        solver = proxsuite.proxqp.dense.QP(*dims, box_constraints=True)
        solver.settings.eps_abs = self.eps_abs
        solver.settings.max_iter = self.max_iter
        solver.settings.max_iter_in = self.max_iter_in
        guess = proxsuite.proxqp.InitialGuess
        solver.settings.initial_guess = (
            guess.WARM_START_WITH_PREVIOUS_RESULT
            if self.warm_start
            else guess.EQUALITY_CONSTRAINED_INITIAL_GUESS
        )
        solver.settings.verbose = False
        return solver

    def solve(self, problem: ScaledQP) -> tuple[str, bool, int, np.ndarray]:
        args = (
            problem.H,
            problem.g,
            problem.A,
            problem.b,
            problem.C,
            problem.l,
            problem.u,
            problem.l_box,
            problem.u_box,
        )
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


DAQP_INFINITY = 1e30  # DAQP's own infinity: bounds at or beyond it are absent
DAQP_EQUALITY = 5  # sense flags ACTIVE | IMMUTABLE: the row is an equality
DAQP_STATUS = {
    1: "SOLVED",
    2: "SOLVED",
    -1: "PRIMAL_INFEASIBLE",
    -2: "CYCLING",
    -3: "DUAL_INFEASIBLE",
    -4: "MAX_ITER_REACHED",
    -5: "NONCONVEX",
    -6: "PRIMAL_INFEASIBLE",
    -7: "TIME_LIMIT",
}  # -6: inconsistent equalities


class DaqpQP:
    """DAQP's dual active-set solver, from scratch at each solve (a cold DAQP solve is already
    faster than a warm ProxSuite one here). Needs H positive definite, which both QPs' ridges and
    regularisations give. `primal_tol` (same units as the constraints) plays eps_abs's part."""

    def __init__(self, primal_tol: float, iter_limit: int = 1000) -> None:  # 1000: DAQP's default
        self.primal_tol, self.iter_limit = primal_tol, iter_limit

    def solve(self, problem: ScaledQP) -> tuple[str, bool, int, np.ndarray]:
        n, n_eq = len(problem.g), len(problem.b)
        # DAQP's rows: simple bounds on the first n variables, then the general rows (A, then C)
        upper = np.minimum(np.concatenate([problem.u_box, problem.b, problem.u]), DAQP_INFINITY)
        lower = np.maximum(np.concatenate([problem.l_box, problem.b, problem.l]), -DAQP_INFINITY)
        sense = np.zeros(len(upper), dtype=np.int32)
        sense[n : n + n_eq] = DAQP_EQUALITY
        x, _, exitflag, info = daqp.solve(
            problem.H,
            problem.g,
            np.vstack([problem.A, problem.C]),
            upper,
            lower,
            sense,
            primal_tol=self.primal_tol,
            iter_limit=self.iter_limit,
        )
        status = DAQP_STATUS.get(exitflag, f"DAQP_EXIT_{exitflag}")
        return status, exitflag in (1, 2), int(info["iterations"]), problem.scale * np.asarray(x)


def make_solver(
    name: str, eps_abs: float, max_iter: int, max_iter_in: int, warm_start: bool = False
) -> QPSolver:
    """The named solver (QP_SOLVERS); the iteration caps are ProxSuite's."""
    if name == "proxsuite":
        return ProxSuiteQP(eps_abs, max_iter, max_iter_in, warm_start)
    if name == "daqp":
        return DaqpQP(eps_abs)
    raise ValueError(f"unknown QP solver {name!r} (known: {', '.join(QP_SOLVERS)})")
