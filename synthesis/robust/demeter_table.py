"""Table 1 of seed 004: every row's variant by both methods, the seed's numbers beside ours.

For each (variant, method) of :data:`satfmu.synthesis.robust.demeter_variants.SEED_TABLE1`:

- ``"Det"``: :func:`satfmu.synthesis.robust.demeter_design.deterministic` (D-G scalings or vertex separators);
- ``"Prob"``: :func:`satfmu.synthesis.robust.demeter_random.scenario` (Campi-Garatti sample count);

then, for the gain found, the seed's two analyses: deterministic (H-infinity with a
parameter-dependent Lyapunov function, impulse-to-peak with a common one:
:func:`satfmu.synthesis.robust.demeter_design.analyse`) and probabilistic (worst cases over the log-over-log
number of samples: :func:`satfmu.synthesis.robust.demeter_random.analyse`). Units: i2p in N m s per unit
impulse of w2, H-infinity in rad/(N m); seconds are the design's wall time on this machine.

Each run's rows go to ``table1.csv`` (:func:`write`), merged with the rows already there, so a
table can be built from several runs (rows or conventions apart); :func:`read` gives them back
and :func:`comparison` puts the two conventions side by side with each row's ratios to the seed.
"""
from __future__ import annotations

import csv
import math
import multiprocessing
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from satfmu.synthesis.core.progress import Progress
from satfmu.synthesis.robust import demeter_design
from satfmu.synthesis.robust import demeter_random
from satfmu.synthesis.robust.demeter_variants import SEED_TABLE1, SEED_TABLE1_COLUMNS, Variant, design_model

METHODS = ("Prob", "Det")


@dataclass
class Row:
    """One row of Table 1 (ours), with the seed's values (``seed``, None if it reports infeasible).

    Bounds and values are nan where not computed and inf where their program gave none.

    Attributes
    ----------
    variant : Variant
        The model variant.
    method : {"Prob", "Det"}
        Scenario or deterministic design.
    status : str
        ``"feasible"``, ``"infeasible (proved)"`` or ``"no design (<status>)"``.
    design_i2p : float, optional
        The design's impulse-to-peak bound, N m s.
    design_hinf : float, optional
        The design's H-infinity bound, rad/(N m).
    det_i2p : float, optional
        Deterministic analysis: impulse-to-peak bound, N m s.
    det_hinf : float, optional
        Deterministic analysis: H-infinity bound (parameter-dependent Lyapunov), rad/(N m).
    prob_i2p : float, optional
        Probabilistic analysis: worst sampled impulse-to-peak value, N m s.
    prob_hinf : float, optional
        Probabilistic analysis: worst sampled H-infinity norm, rad/(N m).
    seconds : float, optional
        Wall time of the design, s.
    total_seconds : float, optional
        Wall time of the row (design and analyses), s.
    note : str, optional
        Remarks: multipliers used, analyses skipped, obstruction, poles out of the region.
    seed : tuple of float, optional
        The seed's values of the row, in the order of
        :data:`~satfmu.synthesis.robust.demeter_variants.SEED_TABLE1_COLUMNS` (None: reported
        infeasible, or not a row of the seed).
    result : DeterministicResult or ScenarioResult, optional
        The design behind the row (gain, certificates).
    """

    variant: Variant
    method: str
    status: str
    design_i2p: float = math.nan
    design_hinf: float = math.nan
    det_i2p: float = math.nan
    det_hinf: float = math.nan
    prob_i2p: float = math.nan
    prob_hinf: float = math.nan
    seconds: float = math.nan
    total_seconds: float = math.nan
    note: str = ""
    seed: tuple[float, ...] | None = None
    result: demeter_design.DeterministicResult | demeter_random.ScenarioResult | None = field(default=None, repr=False,
                                                                                              compare=False)
    """The design behind the row (gain, certificates)."""


def _value(res, attr: str) -> float:
    """The bound, inf if its program gave none, nan if it was not run."""
    if res is None:
        return math.nan
    return getattr(res, attr) if res.status == "optimal" else math.inf


def run_row(variant: Variant, method: str, *, n_scenarios: int | None = None, seed: int = 0, n_samples: int = 0,
            convention: str = "satfmu", progress: Progress | None = None, analysis: bool = True) -> Row:
    """Design and analyse one row (module docstring). ``n_scenarios`` overrides the scenario count;
    ``n_samples`` plants are checked after a design (``result.check``; seed ``seed`` after a Det
    design, ``seed + 2`` after a Prob one, whose program drew its plants with ``seed``); the designs' LMIs and
    objective in ``convention`` (:func:`satfmu.synthesis.robust.robust_design.design`).

    Parameters
    ----------
    variant : Variant
        The model variant.
    method : {"Prob", "Det"}
        Scenario or deterministic design.
    n_scenarios : int, optional
        Number of scenarios of a Prob design; default the Campi-Garatti count.
    seed : int, optional
        Seed of the sampled plants of the design (Prob) or the check (Det); the probabilistic
        analysis uses ``seed + 1``, a Prob row's check ``seed + 2``.
    n_samples : int, optional
        Plants of the sampled check after a design (``result.check``).
    convention : {"satfmu", "romuloc"}, optional
        How the levels enter the designs' LMIs and objective.
    progress : callable, optional
        ``progress(done, total, message)`` after each stage of a Det row
        (:func:`satfmu.synthesis.robust.demeter_design.deterministic`).
    analysis : bool, optional
        Run the deterministic analysis of the row's gain over the box (the parameter-dependent
        H-infinity bound and the impulse-to-peak bound; minutes for a box of 5 or more
        parameters). Default True.

    Returns
    -------
    Row

    Raises
    ------
    ValueError
        If ``method`` is not one of ``METHODS`` ("Prob", "Det").
    """
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}")
    t0 = time.perf_counter()
    row = Row(variant, method, "", seed=SEED_TABLE1.get((variant, method)))
    res: demeter_design.DeterministicResult | demeter_random.ScenarioResult
    if method == "Det":
        res = demeter_design.deterministic(variant, n_samples=n_samples, seed=seed, convention=convention,
                                           progress=progress, analysis=analysis)
        design, K = res.design, res.K
        if K is not None:
            row.det_hinf, row.det_i2p = _value(res.analysis_hinf, "gamma"), _value(res.analysis_i2p, "nu")
            row.note = "; ".join(n for n in (res.note, res.analysis_skipped) if n)
        obstruction = res.obstruction
    else:
        res = demeter_random.scenario(variant, n=n_scenarios, seed=seed, analysis=False, convention=convention)
        design, K = res.design, res.K
        notes = [f"{res.n_samples} scenarios"]
        if K is not None:
            dm = design_model(variant)
            if n_samples:
                res.check = demeter_design.sampled_check(dm, K, n_samples, seed + 2)  # not the design's plants
            if analysis:
                a = demeter_design.analyse(dm, K, demeter_random.design_scale(dm))
                res.deterministic = a
                row.det_hinf, row.det_i2p = _value(a.hinf, "gamma"), _value(a.i2p, "nu")
                notes += [n for n in (a.i2p_note, a.skipped) if n]
            else:
                notes.append("Deterministic analysis not run (analysis=False)")
        obstruction = demeter_design.coincident_modes(variant)
        row.note = "; ".join(notes)
    row.seconds, row.result = res.seconds["design"], res
    if K is None:
        blocked = obstruction is not None and obstruction.proves_infeasible
        # the proof covers the whole box (Det); scenarios only come near the coincident set
        row.status = "infeasible (proved)" if blocked and method == "Det" else f"no design ({design.status})"
        if blocked:
            assert obstruction is not None  # blocked implies it
            row.note = (f"{row.note}; " if row.note else "") + (
                f"coincident modes: {obstruction.n_free} free oscillator(s), need zeta > "
                f"{obstruction.required_zeta:.3g}")
    else:
        row.status = "feasible"
        # a design with a gain is "optimal": both bounds are set (the weights W_HINF, W_I2P are > 0)
        assert design.nu is not None and design.gamma is not None
        row.design_i2p, row.design_hinf = design.nu, design.gamma
        p = demeter_random.analyse(variant, K, seed=seed + 1)
        row.prob_i2p, row.prob_hinf = p.i2p.estimate, p.hinf.estimate
        if not p.in_region:
            row.note = (row.note + "; " if row.note else "") + f"sampled max Re {p.max_real_pole:.2e} 1/s"
    row.total_seconds = time.perf_counter() - t0
    return row


def cost_order(keys: list[tuple[Variant, str]]) -> list[tuple[Variant, str]]:
    """``keys`` with the dearest rows first, for :func:`run` with several jobs: the more axes, the
    larger the design model (one axis: 6-10 states, two: 16, three: 24), and a scenario design
    (hundreds to thousands of sampled plants) before the deterministic one of the same variant;
    ties keep the seed's order. Longest first keeps the last row to finish short.

    Parameters
    ----------
    keys : list of tuple of (Variant, str)
        The rows to run, as (variant, method).
    """
    return sorted(keys, key=lambda k: (-len(k[0].axes), k[1] != "Prob"))


def run(selection: list[tuple[Variant, str]] | None = None, *, n_scenarios: int | None = None, seed: int = 0,
        progress=None, out_dir: Path | None = None, convention: str = "satfmu", jobs: int = 1) -> list[Row]:
    """Every row of the seed's table (or ``selection``) designed in ``convention``
    (:func:`run_row`), in the seed's order; with ``out_dir`` the files are rewritten after each row
    (:func:`write`), so a long run keeps what it has done.

    ``jobs`` rows run at once, each in a worker process, dearest first (:func:`cost_order`):
    every LMI solve uses one core (:data:`satfmu.synthesis.core.lmi.FACTORIZATION`), so ``jobs`` up to the
    core count shortens the wall time without slowing a row much. The rows returned keep the
    selection's order; ``progress`` is called as each one ends. The workers are started by
    ``multiprocessing``'s "spawn" (the same on Linux and Windows, no threads inherited), which
    imports the calling script again: a script that calls this with ``jobs > 1`` needs the
    ``if __name__ == "__main__":`` guard.

    Parameters
    ----------
    selection : list of tuple of (Variant, str), optional
        The rows to run, as (variant, method); default every row of
        :data:`~satfmu.synthesis.robust.demeter_variants.SEED_TABLE1`.
    n_scenarios : int, optional
        Number of scenarios of the Prob designs (:func:`run_row`).
    seed : int, optional
        Seed of every row (:func:`run_row`).
    progress : callable, optional
        ``progress(done, total, label)`` after each row (``label``: the variant and method).
    out_dir : Path, optional
        Folder of ``table1.md`` and ``table1.csv``, rewritten after each row.
    convention : {"satfmu", "romuloc"}, optional
        How the levels enter the designs' LMIs and objective.
    jobs : int, optional
        Rows run at once, each in a worker process.

    Returns
    -------
    list of Row

    Raises
    ------
    ValueError
        If ``jobs`` is below 1.
    """
    keys = list(SEED_TABLE1) if selection is None else list(selection)
    if not (isinstance(jobs, int) and jobs >= 1):
        raise ValueError(f"jobs must be an integer >= 1, got {jobs!r}")
    done: dict[tuple[Variant, str], Row] = {}

    def finished(row: Row) -> None:
        done[_key(row)] = row
        if out_dir is not None:
            write(list(done.values()), out_dir)
        if progress is not None:
            progress(len(done), len(keys), f"{row.variant.label} {row.method}")

    options: dict[str, Any] = {"n_scenarios": n_scenarios, "seed": seed, "convention": convention}
    if jobs == 1:
        for variant, method in keys:
            finished(run_row(variant, method, **options))
    else:
        with ProcessPoolExecutor(max_workers=min(jobs, len(keys)) or 1,
                                 mp_context=multiprocessing.get_context("spawn")) as pool:
            futures = [pool.submit(run_row, variant, method, **options) for variant, method in cost_order(keys)]
            for future in as_completed(futures):
                finished(future.result())
    return [done[k] for k in keys]


def _cell(v: float) -> str:
    return "Inf" if v == math.inf else "-" if math.isnan(v) else f"{v:.4g}"


def markdown(rows: list[Row]) -> str:
    """The table, ours then the seed's value in each cell ("ours / seed"; ours alone in a row
    that is not one of the seed's, such as a variant of your spacecraft).

    Parameters
    ----------
    rows : list of Row
        The rows, in the table's order.

    Returns
    -------
    str
        A Markdown table.
    """
    head = ("| axes | appendages | model | unc | method | status | design i2p | design Hinf | det i2p | det Hinf | "
            "prob i2p | prob Hinf | seconds | note |")
    lines = [head, "|" + "---|" * 14]
    for r in rows:
        if _key(r) not in SEED_TABLE1:
            cells = [_cell(getattr(r, c)) for c in SEED_TABLE1_COLUMNS]
        else:
            seed = r.seed if r.seed is not None else (None,) * len(SEED_TABLE1_COLUMNS)
            cells = [f"{_cell(getattr(r, c))} / {'infeasible' if s is None else _cell(s)}"
                     for c, s in zip(SEED_TABLE1_COLUMNS, seed)]
        v = r.variant
        lines.append(f"| {','.join(map(str, v.axes))} | {','.join(map(str, v.appendages))} | {v.model_type} | "
                     f"{v.uncertainty_type} | {r.method} | {r.status} | " + " | ".join(cells) + f" | {r.note} |")
    return "\n".join(lines)


def _key(row: Row) -> tuple[Variant, str]:
    return row.variant, row.method


def _merged(rows: list[Row], path_csv: Path) -> list[Row]:
    """``rows`` with those of ``path_csv`` that they do not replace, in the seed's order."""
    new = {_key(r): r for r in rows}
    old = [r for r in read(path_csv) if _key(r) not in new] if path_csv.exists() else []
    order = {k: i for i, k in enumerate(SEED_TABLE1)}
    return sorted(old + rows, key=lambda r: order.get(_key(r), len(order)))


def write(rows: list[Row], out_dir: Path) -> list[Path]:
    """``table1.md`` and ``table1.csv`` (one line per row, our columns then the seed's), with the
    rows already in ``table1.csv`` that ``rows`` do not replace (same variant and method).

    Parameters
    ----------
    rows : list of Row
        The rows to write.
    out_dir : Path
        Folder of the two files (created if missing).

    Returns
    -------
    list of Path
        The paths of ``table1.md`` and ``table1.csv``.
    """
    out_dir.mkdir(parents=True, exist_ok=True)
    md, path_csv = out_dir / "table1.md", out_dir / "table1.csv"
    rows = _merged(rows, path_csv)
    md.write_text("Seed 004 Table 1, ours / seed's (i2p N m s, H-infinity rad/(N m), seconds of the design)\n\n"
                  + markdown(rows) + "\n")
    with path_csv.open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["axes", "appendages", "model_type", "uncertainty_type", "method", "status",
                    *SEED_TABLE1_COLUMNS, "total_seconds", "note", *[f"seed_{c}" for c in SEED_TABLE1_COLUMNS]])
        for r in rows:
            seed = r.seed if r.seed is not None else ("infeasible",) * len(SEED_TABLE1_COLUMNS)
            w.writerow([" ".join(map(str, r.variant.axes)), " ".join(map(str, r.variant.appendages)),
                        r.variant.model_type, r.variant.uncertainty_type, r.method, r.status,
                        *[getattr(r, c) for c in SEED_TABLE1_COLUMNS], r.total_seconds, r.note, *seed])
    return [md, path_csv]


def read(path_csv: Path) -> list[Row]:
    """The rows of a ``table1.csv`` of :func:`write` (without their designs: ``result`` is None).

    Parameters
    ----------
    path_csv : Path
        The ``table1.csv`` to read.

    Returns
    -------
    list of Row

    Raises
    ------
    ValueError
        If the file is not such a table (a missing column or a value that is not a number).
    """
    out = []
    with Path(path_csv).open(newline="") as f:
        for i, line in enumerate(csv.DictReader(f), start=2):
            try:
                variant = Variant(tuple(map(int, line["axes"].split())), tuple(map(int, line["appendages"].split())),
                                  int(line["model_type"]), int(line["uncertainty_type"]))
                values: dict[str, Any] = {c: float(line[c]) for c in SEED_TABLE1_COLUMNS}  # Row's float fields
                row = Row(variant, line["method"], line["status"], **values, total_seconds=float(line["total_seconds"]),
                          note=line["note"], seed=SEED_TABLE1.get((variant, line["method"])))
            except (KeyError, TypeError, ValueError) as exc:
                raise ValueError(f"{path_csv}, line {i}: not a Table 1 row ({exc})") from exc
            out.append(row)
    return out


def _ratio(ours: float, seed: float | None) -> str:
    if seed is None or not (math.isfinite(ours) and math.isfinite(seed)) or seed == 0:
        return ""
    return f" ({ours / seed:.3g})"


def comparison(toolbox: list[Row], ours: list[Row]) -> str:
    """Markdown: every row of either list, in the seed's order: in the toolbox's convention
    beside the seed's values, with the ratio ours / seed of the design bounds and of the design
    time, then our convention's status, design bounds and time ("not run" where a list lacks the
    row); the wall time of each convention's rows in total.

    Parameters
    ----------
    toolbox : list of Row
        Rows designed in the R-RoMulOC toolbox's convention (``"romuloc"``).
    ours : list of Row
        Rows designed in satfmu's (``"satfmu"``).

    Returns
    -------
    str
        A Markdown table and a line of total wall times.
    """
    tb, ob = {_key(r): r for r in toolbox}, {_key(r): r for r in ours}
    order = {k: i for i, k in enumerate(SEED_TABLE1)}
    keys = sorted(set(tb) | set(ob), key=lambda k: order.get(k, len(order)))
    head = ("| axes | appendages | model | unc | method | status | design i2p (ratio) | design Hinf (ratio) | "
            "det i2p | det Hinf | prob i2p | prob Hinf | design s (ratio) | row s | satfmu: status | design i2p | "
            "design Hinf | det Hinf | design s | row s | note |")
    lines = [head, "|" + "---|" * 21]
    for key in keys:
        seed = SEED_TABLE1.get(key) or (None,) * len(SEED_TABLE1_COLUMNS)
        s = dict(zip(SEED_TABLE1_COLUMNS, seed))
        r, o = tb.get(key), ob.get(key)

        def pair(c: str, ratio: bool = False) -> str:
            v, sv = getattr(r, c), s[c]
            return f"{_cell(v)} / {'infeasible' if sv is None else _cell(sv)}" + (_ratio(v, sv) if ratio else "")

        if r is not None:
            cells = [r.status, pair("design_i2p", True), pair("design_hinf", True), pair("det_i2p"), pair("det_hinf"),
                     pair("prob_i2p"), pair("prob_hinf"), pair("seconds", True), _cell(r.total_seconds)]
        else:
            cells = ["not run"] + [""] * 8
        cols = ("design_i2p", "design_hinf", "det_hinf", "seconds", "total_seconds")
        cells += [o.status, *(_cell(getattr(o, c)) for c in cols)] if o is not None else ["not run"] + [""] * 5
        v, method = key
        note = "; ".join(dict.fromkeys(x.note for x in (r, o) if x is not None and x.note))
        lines.append(f"| {','.join(map(str, v.axes))} | {','.join(map(str, v.appendages))} | {v.model_type} | "
                     f"{v.uncertainty_type} | {method} | " + " | ".join(cells) + f" | {note} |")
    totals = [sum(x.total_seconds for x in rows if math.isfinite(x.total_seconds)) for rows in (toolbox, ours)]
    lines.append("")
    lines.append(f"Wall time of the rows (designs and analyses): {totals[0]:.0f} s in the toolbox's convention "
                 f"({len(toolbox)} rows), {totals[1]:.0f} s in ours ({len(ours)} rows).")
    return "\n".join(lines)
