"""Constraint generation: a scenario program over many certain plants, solved on a subset of its LMIs.

:func:`~satfmu.synthesis.robust.robust_design.design` over more than :data:`SCENARIO_BATCH` certain
plants (``_constraint_generation``) minimizes over a changing subset of their LMIs: every LMI of
the first :data:`SCENARIO_FIRST` plants, then, round after round, those that bind (dual weight
above :data:`SUPPORT_TOL` of the largest) and the most violated of the others, until the
certificate verifies on every LMI of every plant.
"""
from __future__ import annotations

import logging
from dataclasses import replace
from typing import Any

import numpy as np

from satfmu.synthesis.robust.certificate import _merge_checks, certify
from satfmu.synthesis.robust.checks import RobustCheck, _allowance
from satfmu.synthesis.robust.design_result import RobustDesign
from satfmu.synthesis.robust.dual_lmis import ROBUST_LMIS, _specs
from satfmu.synthesis.robust.lft_plant import LFTPlant
from satfmu.synthesis.robust.rescaling import _back_to_caller, _rescaled_program
from satfmu.synthesis.robust.solve_strategy import BACKOFFS, _back_off, _minimize, _Minimizer

LOG = logging.getLogger(__name__)

SCENARIO_BATCH = 100
"""The most LMIs ``_constraint_generation`` adds per round; :func:`~satfmu.synthesis.robust.robust_design.design`
solves more certain plants than this by constraint generation."""

SCENARIO_FIRST = 10
"""Plants in the first program of ``_constraint_generation`` (every LMI of each)."""

SUPPORT_TOL = 1e-4
"""An LMI whose dual weight (``_Minimizer`` ``support``) is below this fraction of the
largest does not bind: ``_constraint_generation`` leaves it out of the next round (DEMETER
row 1: 9 plants of 110 between 0.03 and 1, the others at 2e-6 to 8e-6, the interior-point
path's floor)."""


def _lmi_margins(check: RobustCheck) -> dict[str, float]:
    """Each LMI's margin in one plant's check (as :attr:`RobustCheck.margin`): the robust LMIs
    by name, ``"i2p"`` the two i2p blocks', ``"Y"`` the Lyapunov matrix's."""
    allowance = _allowance(check.scale)
    out = {k: -float(v.max()) - allowance for k, v in check.max_eig.items() if k in ROBUST_LMIS}
    out["i2p"] = min(float(check.min_eig["i2p/B2"].min()), -float(check.max_eig["i2p/C2"].max())) - allowance
    out["Y"] = float(check.min_eig["Y"].min()) - allowance
    return out


def _i2p_representatives(plants: tuple[LFTPlant, ...]) -> list[int]:
    """For each plant, the first plant with the same ``(B2, C2)``: the same i2p blocks."""
    first: dict[bytes, int] = {}
    return [first.setdefault(p.B2.tobytes() + p.C2.tobytes() + bytes(str(p.B2.shape + p.C2.shape), "ascii"), i)
            for i, p in enumerate(plants)]


def _constraint_generation(plants: tuple[LFTPlant, ...], K: np.ndarray | None, rescale: bool, **options
                           ) -> RobustDesign:
    """The program over many certain plants (scenarios), solved on a changing subset of their LMIs.

    Each plant brings its robust LMIs (:func:`_specs`: "hinf", "alpha", "beta", "sector") and
    its i2p blocks ("i2p", one per distinct ``(B2, C2)``); the subset is a set of such
    ``(plant, LMI)`` pairs. Minimize over every LMI of the first :data:`SCENARIO_FIRST` plants;
    :func:`certify` every plant at the minimizer (levels at each of :data:`BACKOFFS` in turn
    while only LMIs of the subset fail: larger levels loosen every LMI); if any outside the
    subset is violated, the next subset is the LMIs that bind (dual weight above
    :data:`SUPPORT_TOL`; one left out once stays in when it comes back, so the rounds end; if
    the smaller subset gives no answer, those left out are put back) and the most violated
    outside (at most :data:`SCENARIO_BATCH`), minimized again in the coordinates where the last
    minimizer's Y has a unit diagonal (as :func:`_rescaled_program`). When only LMIs of the
    subset fail, the back-off solves at the minimizer's levels in those coordinates
    (:func:`_back_off`, from the back-off that verified in the last round: DEMETER row 13
    failed at 1e-4 and 1e-3 and verified at 1e-2 in each round; failing them, the subset's
    certified solve :func:`_rescaled_program`) and :func:`certify` of every plant at the
    answer; LMIs it violates join the subset and the rounds go on.

    Leaving out LMIs that do not bind keeps the optimum (convex program, complementary
    slackness), so each subset's optimum is a lower bound of the whole program's, and the
    returned certificate, verified on every LMI of every plant, is feasible for it at the last
    optimum times ``1 + backoff``. An infeasible subset proves the whole program infeasible. A
    scenario program has at most as many support constraints as decision variables, and in
    practice far fewer, so the solver never sees the thousands of LMIs at once; of a binding
    plant's LMIs often only one binds (DEMETER row 9: 131 LMIs of 110 plants in its second
    round, against 330 when every LMI of a plant came with it).
    """
    convention = options["convention"]
    check_options = {"alpha": options["alpha"], "beta": options["beta"], "sector": options["sector"],
                     "convention": convention}
    names = [s.name for s in _specs(plants[0], options["alpha"], options["beta"], options["hinf"],
                                    options["sector"])]
    rep = _i2p_representatives(plants)
    first = range(min(SCENARIO_FIRST, len(plants)))
    active = list(dict.fromkeys([(i, name) for i in first for name in names] + [(rep[i], "i2p") for i in first]))
    left_out: set[tuple[int, str]] = set()
    T = np.ones(plants[0].A.shape[0])
    seconds: dict[str, Any] = {"solve_seconds": 0.0, "build_seconds": 0.0}  # floats, passed as keywords
    status: list[str] = []

    def subset(T: np.ndarray) -> tuple[list[int], tuple[LFTPlant, ...], np.ndarray | None, dict]:
        """The subset's plants (indices; in the coordinates T), gain and solve options."""
        idx = list(dict.fromkeys(i for i, _ in active))
        chosen: dict[int, set[str]] = {i: set() for i in idx}
        for i, name in active:
            chosen[i].add(name)
        return (idx, tuple(plants[i].scale_states(T) for i in idx), None if K is None else K * T,
                {**options, "only": tuple(frozenset(chosen[i]) for i in idx)})

    def size() -> str:
        return f"{len(active)} LMIs of {len({i for i, _ in active})} plants"

    def say(line: str) -> None:
        """One round's line of the result's ``solver_status``, also logged (INFO)."""
        status.append(line)
        LOG.info("constraint generation: %s", line)

    def account(res) -> None:
        for k in seconds:
            seconds[k] += res.times[k] if isinstance(res, _Minimizer) else getattr(res, k)

    def check_all(K, Y, gamma, nu) -> tuple[list[RobustCheck], list[tuple[int, str]]]:
        """Every plant's check in the coordinates T, and the worst violated LMIs outside the subset
        (Y > 0 is in every subset)."""
        checks = [certify(p.scale_states(T), K, Y, gamma, nu, {}, **check_options) for p in plants]
        inside = set(active)
        worst = sorted((v, key) for i, c in enumerate(checks) if not c.ok for name, v in _lmi_margins(c).items()
                       if v <= 0 and name != "Y" and (key := (rep[i] if name == "i2p" else i, name)) not in inside)
        return checks, list(dict.fromkeys(key for _, key in worst))[:SCENARIO_BATCH]

    def binding(m: _Minimizer, idx: list[int]) -> set[tuple[int, str]]:
        top = max(m.support.values())
        return {(rep[idx[j]] if name == "i2p" else idx[j], name) for (j, name), w in m.support.items()
                if w >= SUPPORT_TOL * top}

    restore: list[tuple[int, str]] = []  # the LMIs the last round left out
    first_backoff = 0  # index in BACKOFFS of the back-off solves' first try
    while True:
        idx, sub, Ks, sub_options = subset(T)
        m = _minimize(sub, Ks, **sub_options)
        res = None
        if not isinstance(m, _Minimizer) and m.status != "infeasible" and restore:
            # no answer without them (DEMETER row 7: NumericalError at 24 plants, not at 39)
            say(f"{size()}: {m.solver_status}; the {len(restore)} left out put back")
            account(m)
            active, restore = restore + active, []
            continue
        if isinstance(m, _Minimizer):
            account(m)
            say(f"{size()}: {m.times['solver_status']}")
            for b in BACKOFFS:  # larger levels only loosen the LMIs: those outside stay met
                g, nv = m.levels(convention, b)
                checks, new = check_all(m.K, m.Y, g, nv)
                if new or all(c.ok for c in checks):
                    break
            if all(c.ok for c in checks):  # the minimizer is the certificate
                res = RobustDesign("optimal", m.K, g, nv, m.Y, {}, _merge_checks(checks), m.optimum, **m.info,
                                   **seconds, solver_status="; ".join(status) + f"; the minimizer verified at "
                                   f"back-off {b:g}", backoff=b)
                return replace(_back_to_caller(res, T), active_plants=len(idx))
            if rescale and np.all(np.diag(m.Y) > 0):
                T = T * np.sqrt(np.diag(m.Y))
            if new:
                keep = binding(m, idx)
                dropped = {k for k in active if k not in keep and k not in left_out}
                left_out |= dropped
                restore = [k for k in active if k in dropped]
                active = [k for k in active if k not in dropped] + new
                continue
            idx, sub, Ks, sub_options = subset(T)
            res = _back_off(sub, Ks, replace(m, times={k: 0.0 for k in seconds} | {"solver_status": ""}),
                            BACKOFFS[first_backoff:], **sub_options)  # m's times already counted
            account(res)
            if res.status == "optimal":  # smaller back-offs failed: the next round starts at this one
                first_backoff = BACKOFFS.index(res.backoff)
            say(f"{size()} at the minimizer's levels: {res.solver_status.removeprefix('; ')}")
        if res is None or res.status != "optimal":  # m: this program's failed minimization, if it was
            res = _rescaled_program(sub, Ks, rescale, minimizer=None if res is not None else m, **sub_options)
            account(res)
            say(f"{size()}, certified: {res.solver_status}")
        res = replace(res, **seconds, solver_status="; ".join(status), active_plants=len(idx))
        if res.status != "optimal":
            return res
        res = _back_to_caller(res, T)
        # optimal: K and Y are set, and _back_to_caller sets the scaling
        assert res.K is not None and res.Y is not None and res.state_scaling is not None
        T = res.state_scaling  # the coordinates of res.check
        checks, new = check_all(res.K * T, res.Y / T[:, None] / T[None, :], res.gamma, res.nu)
        if not new:
            if all(c.ok for c in checks):
                return replace(res, check=_merge_checks(checks))
            # an LMI of the subset fails in the total coordinates (rounding): no certificate
            return replace(res, status="unverified", K=None, gamma=None, nu=None, Y=None,
                           check=_merge_checks(checks))
        active, restore = active + new, []
