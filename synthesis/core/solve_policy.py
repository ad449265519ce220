"""One solve policy for every conic program of the synthesis layer (SOS, robust and periodic LMIs).

The SOS layer (:meth:`satfmu.synthesis.core.sos.SOSProgram.solve`, Clarabel on its own arrays) runs it through
:func:`solve_with` and :func:`ladder_with`, and so do the robust and PDLF LMIs
(:meth:`satfmu.synthesis.core.lmi.LMIProgram.solve`); the periodic LMIs (cvxpy problems) go through
:func:`solve_cvxpy`.

A program is solved by trying the rungs of a *ladder* (solver and settings) in turn:

1. Clarabel with its default tolerances (1e-8);
2. Clarabel with relaxed tolerances (:data:`RELAXED_TOLERANCES`): a poorly conditioned program (a
   fixed slow mode, as DEMETER's momentum at -1e-3 1/s) often stalls just short of 1e-8;
3. Clarabel with a larger static KKT regularization (:data:`REGULARIZED`): some programs fail at
   the first iteration with the default (the two-axis DEMETER design model, whose KKT system is
   singular to working precision after chordal decomposition); it perturbs the Newton steps, not
   the problem.

No first-order solver (SCS) follows: its answers (1e-4 to 1e-6 accurate) do not pass the
verification margins of the certificates this project writes, so trying one only costs time.

The statuses are read the same way everywhere:

- a solution (``optimal`` or ``optimal_inaccurate``) ends the ladder: the caller's independent
  verification judges it, so an inaccurate one is not retried;
- a clean certificate of infeasibility or unboundedness ends it too: it is final;
- a solver error, an inaccurate infeasibility claim or no status at all goes to the next rung.

The outcome says ``solved``, ``infeasible`` (a certificate, clean or, when no later rung solved
the program, inaccurate) or ``failed``, with every attempt's solver, settings, status and time.
"""
from __future__ import annotations

import time
import warnings
from dataclasses import dataclass
from typing import Any, Callable, Sequence

import cvxpy as cp
from satfmu.fmus.errors import SolverFailure

RELAXED_TOLERANCES = {"tol_gap_abs": 1e-6, "tol_gap_rel": 1e-6, "tol_feas": 1e-7, "tol_ktratio": 1e-5}
"""Clarabel tolerances of the second rung (the defaults are 1e-8)."""

REGULARIZED = {**RELAXED_TOLERANCES, "static_regularization_constant": 1e-7}
"""Clarabel settings of the third rung: the static KKT regularization raised from 1e-8 to 1e-7."""

LADDER: tuple[tuple[str, dict[str, Any]], ...] = (
    ("CLARABEL", {}), ("CLARABEL", RELAXED_TOLERANCES), ("CLARABEL", REGULARIZED))
"""The default ladder: (solver, settings) tried in turn."""


class RungMemory:
    """A ladder for a family of programs (the minimizations of one design, say) that starts at
    the rung that solved the last of them when the rungs before it failed without a status.

    Programs of one family share their conditioning: DEMETER's two-axis design ends in
    ``NumericalError`` at the first two rungs in each of its minimizations and solves at the
    third, 20-150 s a failed rung. Every rung is still tried (the remembered one first, then the
    others in the ladder's order), so a program that needs another rung still gets it, and it
    becomes the one remembered.

    Parameters
    ----------
    ladder : sequence of (str, dict)
        The rungs (default :data:`LADDER`).
    """

    def __init__(self, ladder: Sequence[tuple[str, dict[str, Any]]] = LADDER) -> None:
        if not ladder:
            raise ValueError("the solve ladder is empty")
        self.ladder = tuple(ladder)
        self.start = 0

    def rungs(self) -> tuple[tuple[str, dict[str, Any]], ...]:
        """The rungs in the order to try them: the remembered one first."""
        return self.ladder[self.start:] + self.ladder[:self.start]

    def record(self, outcome: SolveOutcome) -> None:
        """Remember the rung that solved ``outcome`` after rungs that stopped without a status.

        Parameters
        ----------
        outcome : SolveOutcome
            The outcome of a ladder run in the order of :meth:`rungs`; kept only when it solved
            and every attempt before the last was a solver error.
        """
        failed = outcome.attempts[:-1]
        if outcome.solved and failed and all(a.status.startswith("solver error") for a in failed):
            self.start = (self.start + len(failed)) % len(self.ladder)


def ladder_with(settings: dict[str, Any] | None = None) -> tuple[tuple[str, dict[str, Any]], ...]:
    """The ladder of :data:`LADDER` with a caller's Clarabel settings on every rung (a rung's
    own settings win on the rungs after the first: they are what the retry changes).

    Parameters
    ----------
    settings : dict, optional
        Clarabel settings (e.g. ``{"tol_feas": 1e-10}``) asked for by the caller.
    """
    settings = dict(settings or {})
    return tuple((solver, {**settings, **rung}) for solver, rung in LADDER)


SOLVED = ("optimal", "optimal_inaccurate")
"""Statuses that end the ladder with a solution (verification judges it)."""
FINAL = ("infeasible", "unbounded")
"""Statuses that end the ladder with a certificate."""
INACCURATE_CERTIFICATES = ("infeasible_inaccurate", "unbounded_inaccurate")
"""Certificates that go to the next rung, and count as infeasibility if no rung solves."""


@dataclass(frozen=True)
class Attempt:
    """One rung tried: solver, settings, the status it returned (or ``solver error: ...``) and
    its wall time, s.

    Attributes
    ----------
    solver : str
        The solver's name (``"CLARABEL"``).
    settings : dict
        The settings it was given.
    status : str
        The status it returned in cvxpy's vocabulary, ``"no status"``, or ``"solver error: ..."``.
    seconds : float
        Wall time of the attempt, s.
    """

    solver: str
    settings: dict[str, Any]
    status: str
    seconds: float


@dataclass(frozen=True)
class SolveOutcome:
    """What the ladder gave.

    Attributes
    ----------
    status : {"solved", "infeasible", "failed"}
    attempts : tuple of Attempt
        Every rung tried, in order; the last one is the one whose answer is in the problem.
    """

    status: str
    attempts: tuple[Attempt, ...]

    @property
    def solved(self) -> bool:
        """Whether the problem holds a solution (to be verified by the caller)."""
        return self.status == "solved"

    @property
    def solver(self) -> str:
        """The solver of the last attempt."""
        return self.attempts[-1].solver if self.attempts else ""

    @property
    def solver_status(self) -> str:
        """The attempts' statuses, ``"; "``-separated, each after the first naming its rung (the
        first too when it is not the default rung: a :class:`RungMemory` started there)."""
        if not self.attempts:
            return ""
        first = self.attempts[0]
        label = _label(first.settings)
        parts = [f"{first.solver.lower()} {label}: {first.status}" if label else first.status]
        parts += [f"retry {a.solver.lower()}{' ' + _label(a.settings) if _label(a.settings) else ''}: {a.status}"
                  for a in self.attempts[1:]]
        return "; ".join(parts)

    @property
    def seconds(self) -> float:
        """Wall time of all attempts, s."""
        return sum(a.seconds for a in self.attempts)


def _label(settings: dict[str, Any]) -> str:
    """The rung's name in a status: ``regularized``, ``relaxed`` or none (the default tolerances)."""
    if "static_regularization_constant" in settings:
        return "regularized"
    return "relaxed" if all(settings.get(k) == v for k, v in RELAXED_TOLERANCES.items()) else ""


def solve_with(run: Callable[[str, dict[str, Any]], str],
               ladder: Sequence[tuple[str, dict[str, Any]]] | RungMemory = LADDER) -> SolveOutcome:
    """Try ``run(solver, settings)`` on each rung of ``ladder`` (the module docstring's rules).

    Parameters
    ----------
    run : callable
        Solves the program with one solver and its settings and returns the status in cvxpy's
        vocabulary (``"optimal"``, ``"infeasible_inaccurate"``, ...); raises
        :class:`SolverFailure` (or cvxpy's ``SolverError``) when the solver stops without one.
    ladder : sequence of (str, dict) or RungMemory
        Solver names and settings, tried in order (a :class:`RungMemory`: in its order, and
        told the outcome).

    Returns
    -------
    SolveOutcome
    """
    if isinstance(ladder, RungMemory):
        outcome = solve_with(run, ladder.rungs())
        ladder.record(outcome)
        return outcome
    if not ladder:
        raise ValueError("the solve ladder is empty")
    attempts: list[Attempt] = []
    for solver, settings in ladder:
        t0 = time.perf_counter()
        try:
            with warnings.catch_warnings():  # "inaccurate" is in the status; verification judges
                warnings.simplefilter("ignore", UserWarning)
                status = str(run(solver, dict(settings)) or "no status")
        except (SolverFailure, cp.error.SolverError) as exc:
            status = f"solver error: {exc}"
        attempts.append(Attempt(solver, dict(settings), status, time.perf_counter() - t0))
        if status in SOLVED:
            return SolveOutcome("solved", tuple(attempts))
        if status in FINAL:
            return SolveOutcome("infeasible", tuple(attempts))
    infeasible = any(a.status in INACCURATE_CERTIFICATES for a in attempts)
    return SolveOutcome("infeasible" if infeasible else "failed", tuple(attempts))


def solve_cvxpy(prob: cp.Problem, ladder: Sequence[tuple[str, dict[str, Any]]] = LADDER) -> SolveOutcome:
    """:func:`solve_with` for a cvxpy problem (its variables hold the last attempt's values).

    Parameters
    ----------
    prob : cvxpy.Problem
        The problem, solved in place by ``prob.solve(solver=..., **settings)``.
    ladder : sequence of (str, dict)
        Solver names and settings, tried in order (default :data:`LADDER`).

    Returns
    -------
    SolveOutcome
        The status and every attempt.
    """

    def run(solver: str, settings: dict[str, Any]) -> str:
        prob.solve(solver=solver, **settings)
        return str(prob.status)

    return solve_with(run, ladder)
