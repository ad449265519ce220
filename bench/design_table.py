"""The "methods x spacecraft" table of issue 53: every design method of the five seed papers tried
on three rigid spacecraft and a flexible one.

One row per (method, spacecraft): the outcome (the artifact's certificate status when the design
returns, usually ``certified``; ``refused`` when it raises :class:`satfmu.DesignError`; ``not
applicable`` when the method is for the other kind of spacecraft: seed 004's for a flexible
spacecraft with reaction wheels, the others for a rigid body), its key numbers or the refusal's reason (the
message's first 200 characters), the design's wall time, and whether the designed controller's
FMU closed loop passes a short scenario on that spacecraft.

Spacecraft: ``seed_000`` (:data:`satfmu.SEED_000`, diag(15, 16, 12.5) kg m^2, 5 N m), ``bus``
(200 kg class, products of inertia, 20 N m), ``cubesat_3u`` (diag(0.01, 0.05, 0.05) kg m^2,
0.01 N m, 0.2 A m^2) and ``my_flex`` (the flexible spacecraft of
``examples/my_flexible_spacecraft.toml``: 60 kg m^2 hub with products of inertia, a solar array
with bending and torsion modes of their own, an antenna boom, wheels of 0.02 N m and 0.5 N m s).

Methods (:mod:`satfmu.synthesis.designs`):

- ``hinf``: seed 000, :func:`satfmu.design_hinf` judged on a 90 deg manoeuvre about (1, -1, 1)
  within the spacecraft's torque limit; reduced to one certified decay rate (0.02 1/s) and 5000
  samples of the L2 estimate unless ``--full``. Numbers: certificate status, L2 gain bound ``c``.
- ``h2hinf``: seed 001, :func:`satfmu.design_h2hinf` at gamma 0.7 (gamma 100 for the cubesat,
  whose 0.01 N m cannot hold its MRPs against more; its default weight ``Rh = I / 0.01^2``), 6
  SDPs per line search (12 with ``--full``). Numbers: gamma, lambda, alpha, beta and the
  summary's first line.
- ``sdre``: seed 002's method for a rigid spacecraft, :func:`satfmu.design_sdre` (SDRE servo of the
  MRP plant, gain fit over the operating box, SOS region of the fitted law). Numbers: the fit's
  degree and off-sample error, the certified region.
- ``periodic``: seed 003, :func:`satfmu.design_cubesat_periodic` (principal axes only). Numbers:
  gamma and the summary's first line.
- ``robust``: seed 004, :func:`satfmu.design_demeter` on axis 1 with both appendages of
  ``my_flex`` (norm-bounded box, wheel dynamics), its deterministic analysis only with ``--full``
  (minutes for this 7-parameter box). Numbers: the design's H-infinity and impulse-to-peak bounds
  over the box, the sampled check.

Closed loop (``hinf`` and ``h2hinf``, when designed): the artifact is written into a temporary
satfmu home (``$SATFMU_HOME`` is set to a temporary folder for the whole run, so nothing reaches
the user's folder; FMUs are built there on demand) and the 90 deg rest-to-rest manoeuvre runs
through the native FMUs (plant ``mrp_satellite`` with the spacecraft's parameters, no
saturation) for 120 s (seed_000), 300 s (bus) or 120 s (cubesat_3u). It passes when the angle
error at the end is below :data:`ANGLE_BOUND_DEG` and the peak torque within the spacecraft's
torque limit. ``robust``: the worst initial error (15 deg, 0.08 deg/s on axis 1) through the
native FMUs of the flexible plant (built from the artifact's description, wheel limits on) and
the controller, 60 s at 1 ms (:func:`satfmu.sims.workflows.demeter_loops.scenario`: the
certified impulse-to-peak bound on the wheel-momentum proxy, the wheel momentum below its limit,
the attitude within the initial error). ``periodic``: the gains beside B-dot on the nonlinear
magnetorquer plant (the spacecraft's moments, dipole clipped at its limit) from
:data:`DAMPING_RATE`, two orbits (:func:`satfmu.sims.workflows.detumble.rate_scenario`); passes
when they bring ``|w|`` down 10x (the periodic design is a rate-damping law: it does not detumble
from tumbling rates, docs/models.md).

Prints the table as Markdown (and the total wall time), writes it with ``--out`` and the raw rows
as JSON with ``--json``; progress goes to stderr. The reduced table took 464 s on 2 shared
cores::

    python bench/design_table.py [--full] [--only METHOD] [--spacecraft NAME] [--out FILE] [--json FILE]
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
import warnings
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Callable, Sequence

import satfmu
from satfmu.controllers import mrp_servo_sdc
from satfmu.sims.workflows import demeter_loops, detumble
from satfmu.synthesis import designs

FLEXIBLE = Path(__file__).resolve().parents[1] / "examples" / "my_flexible_spacecraft.toml"
SPACECRAFT: dict[str, satfmu.Spacecraft | satfmu.FlexibleSpacecraft] = {
    "seed_000": satfmu.SEED_000,
    "bus": satfmu.Spacecraft("bus", [[100.0, 2.0, -1.0], [2.0, 120.0, 0.5], [-1.0, 0.5, 80.0]], torque_limit=20.0),
    "cubesat_3u": satfmu.Spacecraft("cubesat_3u", [0.01, 0.05, 0.05], torque_limit=1e-2, dipole_limit=0.2),
    "my_flex": satfmu.FlexibleSpacecraft.from_toml(FLEXIBLE),
}
"""The table's columns: name -> spacecraft."""
METHODS: dict[str, str] = {
    "hinf": "000 design_hinf",
    "h2hinf": "001 design_h2hinf",
    "sdre": "002 design_sdre",
    "periodic": "003 design_cubesat_periodic",
    "robust": "004 design_demeter",
}
"""Method key (``--only``) -> its label in the table (seed number and design function)."""
FLEXIBLE_METHODS = ("robust",)
"""The methods for a flexible spacecraft (:class:`satfmu.FlexibleSpacecraft`); the others take a rigid one."""
ROBUST_AXES, ROBUST_APPENDAGES = (1,), (1, 2)
"""The robust design's variant on a flexible spacecraft."""
H2HINF_GAMMA = {"seed_000": 0.7, "bus": 0.7, "cubesat_3u": 100.0}
"""The L2-gain bound of seed 001's design per spacecraft."""
STOP_TIME = {"seed_000": 120.0, "bus": 300.0, "cubesat_3u": 120.0}
"""Length of the closed-loop manoeuvre per spacecraft, s."""
ANGLE_BOUND_DEG = 0.1
"""Largest attitude angle error at the end of the manoeuvre that passes, deg."""
DAMPING_RATE = 1e-3
"""Initial rate of the periodic designs' loop (rate damping after detumbling), rad/s."""
MANOEUVRE_DEG, MANOEUVRE_AXIS = 90.0, (1.0, -1.0, 1.0)
REASON_CHARS = 200
"""A refusal's reason is cut to this many characters in the table (the JSON keeps it whole)."""


@dataclass
class Row:
    """One (method, spacecraft) cell of the table.

    Attributes
    ----------
    method, spacecraft : str
        Keys of :data:`METHODS` and :data:`SPACECRAFT`.
    outcome : str
        The certificate status of a design (``"certified"``, ...), ``"refused"`` or ``"not applicable"``.
    numbers : str
        Key numbers of the design, the refusal's reason, or why the method does not apply.
    seconds : float or None
        Wall time of the design call, s (None: not run).
    closed_loop : str
        The closed-loop scenario's verdict and figures, or why none ran.
    details : dict
        Raw data for the JSON file (full message, certificate numbers, metrics).
    """

    method: str
    spacecraft: str
    outcome: str
    numbers: str
    seconds: float | None
    closed_loop: str = "not run"
    details: dict[str, Any] = field(default_factory=dict)


def shorten(text: str, limit: int = REASON_CHARS) -> str:
    """``text`` on one line (runs of whitespace made one space), cut to ``limit`` characters with "...".

    Parameters
    ----------
    text : str
        Any message.
    limit : int
        Largest length of the result.

    Returns
    -------
    str
        The shortened text.
    """
    flat = " ".join(text.split())
    return flat if len(flat) <= limit else flat[:limit - 3].rstrip() + "..."


def cell(text: str) -> str:
    """``text`` safe in a Markdown table cell: one line, ``|`` escaped."""
    return " ".join(str(text).split()).replace("|", "\\|")


def markdown(rows: Sequence[Row]) -> str:
    """The rows as a Markdown table: method | spacecraft | outcome | numbers or reason | time | closed loop.

    Parameters
    ----------
    rows : sequence of Row
        The table's rows, in order.

    Returns
    -------
    str
        The table, one line per row after the header and its rule, no trailing newline.
    """
    lines = ["| method | spacecraft | outcome | numbers / reason | design time | closed loop |",
             "|---|---|---|---|---:|---|"]
    for r in rows:
        t = "-" if r.seconds is None else f"{r.seconds:.1f} s"
        lines.append("| " + " | ".join(cell(c) for c in (METHODS.get(r.method, r.method), r.spacecraft, r.outcome,
                                                             r.numbers, t, r.closed_loop)) + " |")
    return "\n".join(lines)


def not_applicable(method: str, spacecraft: str) -> Row | None:
    """The "not applicable" row of ``method`` on ``spacecraft`` when the method is for the other
    kind of spacecraft (:data:`FLEXIBLE_METHODS`), else None.

    Parameters
    ----------
    method, spacecraft : str
        Keys of :data:`METHODS` and :data:`SPACECRAFT`.

    Returns
    -------
    Row or None
        The row (nothing run) or None when the method applies.
    """
    flexible = isinstance(SPACECRAFT[spacecraft], satfmu.FlexibleSpacecraft)
    if (method in FLEXIBLE_METHODS) == flexible:
        return None
    why = ("a rigid spacecraft: seed 004's method designs for flexible appendages and reaction wheels "
           "(satfmu.FlexibleSpacecraft)" if not flexible else
           "a flexible spacecraft: this method designs for a rigid body (satfmu.Spacecraft)")
    return Row(method, spacecraft, "not applicable", why, None, "not run")


def scenario(controller: str, spacecraft: satfmu.Spacecraft, stop_time: float, servo: bool = False) -> satfmu.Scenario:
    """The 90 deg rest-to-rest manoeuvre of ``spacecraft`` under ``controller`` through the FMUs.

    Parameters
    ----------
    controller : str
        Artifact (controller FMU) name.
    spacecraft : Spacecraft
        The plant's inertia and torque limit.
    stop_time : float
        Length of the run, s.
    servo : bool, optional
        The controller is an MRP SDRE servo (:mod:`satfmu.controllers.mrp_servo_sdc`: its signals
        connect element by element, its reference stays 0). Default False.

    Returns
    -------
    Scenario
        Metrics: the angle error at the end (max :data:`ANGLE_BOUND_DEG`) and the peak torque
        (max the spacecraft's torque limit).
    """
    start = satfmu.manoeuvre(MANOEUVRE_DEG, axis=MANOEUVRE_AXIS)
    return satfmu.Scenario(
        name=f"table_{controller}", stop_time=stop_time, step_size=0.05,
        description=f"{spacecraft.name}: {MANOEUVRE_DEG:g} deg rest-to-rest under {controller}",
        fmus={"plant": satfmu.FmuSpec(model="mrp_satellite", parameters={**spacecraft.parameters(), **start}),
              "controller": satfmu.FmuSpec(model=controller)},
        connections=([satfmu.Connection(a, b) for a, b in mrp_servo_sdc.plant_connections()] if servo else
                     [satfmu.Connection("plant.omega", "controller.omega"),
                      satfmu.Connection("plant.sigma", "controller.sigma"),
                      satfmu.Connection("controller.u", "plant.u")]),
        record=["plant.phi", "controller.u"],
        metrics=[satfmu.Metric("angle error", "final", ["plant.phi"], unit="deg",
                               max=ANGLE_BOUND_DEG),
                 satfmu.Metric("peak torque", "peak", ["controller.u"], unit="N.m", max=spacecraft.torque_limit)])


def closed_loop(design: satfmu.Design, spacecraft: satfmu.Spacecraft, stop_time: float,
                servo: bool = False) -> tuple[str, dict[str, Any]]:
    """Write ``design``'s artifact into the user's artifact folder (the run's temporary home) and
    fly :func:`scenario` with it.

    Parameters
    ----------
    design : Design
        A returned seed 000, 001 or 002 (rigid spacecraft) design.
    spacecraft : Spacecraft
        The spacecraft it was designed for.
    stop_time : float
        Length of the run, s.
    servo : bool, optional
        The design is an MRP SDRE servo (:func:`scenario`). Default False.

    Returns
    -------
    str
        ``"pass: ..."`` or ``"FAIL: ..."`` with the final angle error and peak torque, or ``"error: ..."``
        when the run raised a satfmu error.
    dict
        The metrics' values, bounds and pass/fail, the run's wall time and any warnings.
    """
    design.write(satfmu.user_artifacts(), fmu_dir=None)
    t0 = time.perf_counter()
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", satfmu.SatfmuWarning)
            result = satfmu.run(scenario(design.names[0], spacecraft, stop_time, servo))
    except satfmu.SatfmuError as exc:
        return f"error: {shorten(str(exc), 120)}", {"error": str(exc), "seconds": time.perf_counter() - t0}
    metrics = {m.name: m for m in result.metrics}
    angle, peak = metrics["angle error"], metrics["peak torque"]
    text = (f"{'pass' if result.passed else 'FAIL'}: {angle.value:.3g} deg at {stop_time:g} s "
            f"(<= {ANGLE_BOUND_DEG:g}), peak {peak.value:.3g} of {spacecraft.torque_limit:g} N m")
    details = {"passed": result.passed, "seconds": time.perf_counter() - t0, "stop_time": stop_time,
               "metrics": {m.name: {"value": m.value, "max": m.max, "unit": m.unit, "passed": m.passed}
                           for m in result.metrics},
               "warnings": [str(w.message) for w in caught]}
    return text, details


def flexible_loop(design: satfmu.Design) -> tuple[str, dict[str, Any]]:
    """Write a robust design's artifact into the user's artifact folder (the run's temporary home)
    and fly its worst initial error through the FMUs (:func:`satfmu.sims.workflows.demeter_loops.scenario`).

    Parameters
    ----------
    design : Design
        A returned seed 004 design for a flexible spacecraft.

    Returns
    -------
    str
        ``"pass: ..."`` or ``"FAIL: ..."`` with the peak of the wheel-momentum proxy against its
        certified bound and the peak wheel momentum against the limit.
    dict
        The metrics' values, bounds and pass/fail, and the run's wall time.
    """
    design.write(satfmu.user_artifacts(), fmu_dir=None)
    t0 = time.perf_counter()
    result = satfmu.run(demeter_loops.scenario(design.names[0], start="both"))
    m = {x.name: x for x in result.metrics}
    xw, h = m["peak |z2| = |xw|"], m["peak wheel momentum"]
    text = (f"{'pass' if result.passed else 'FAIL'}: peak xw {xw.value:.3g} (bound {xw.max:.3g}) N m s, "
            f"wheel momentum {h.value:.3g} of {h.max:g} N m s, theta(60 s) {m['|theta| at the end'].value:.3g} rad")
    return text, {"passed": result.passed, "seconds": time.perf_counter() - t0,
                  "metrics": {x.name: {"value": x.value, "max": x.max, "unit": x.unit, "passed": x.passed}
                              for x in result.metrics}}


def periodic_loop(design: satfmu.Design, spacecraft: satfmu.Spacecraft) -> tuple[str, dict[str, Any]]:
    """Write a periodic design's artifact into the user's artifact folder (the run's temporary home)
    and fly it beside B-dot on the nonlinear magnetorquer plant from :data:`DAMPING_RATE`, two orbits
    (:func:`satfmu.sims.workflows.detumble.rate_scenario`): it passes when the periodic gains bring
    ``|w|`` down 10x.

    Parameters
    ----------
    design : Design
        A returned seed 003 design.
    spacecraft : Spacecraft
        The spacecraft it was designed for (principal axes).

    Returns
    -------
    str
        ``"pass: ..."`` or ``"FAIL: ..."`` with both laws' ``|w(end)| / |w(0)|``.
    dict
        The metrics' values, bounds and pass/fail, and the run's wall time.
    """
    design.write(satfmu.user_artifacts(), fmu_dir=None)
    t0 = time.perf_counter()
    result = satfmu.run(detumble.rate_scenario(spacecraft, design.names[0], DAMPING_RATE, expected="periodic"))
    m = {x.name: x for x in result.metrics}
    text = (f"{'pass' if result.passed else 'FAIL'}: from {DAMPING_RATE:g} rad/s, |w| after two orbits "
            f"{m['periodic: |w(end)| / |w(0)|'].value:.3g} of |w(0)| (<= {detumble.REDUCTION:g}; B-dot "
            f"{m['bdot: |w(end)| / |w(0)|'].value:.3g}), dipole clipped at "
            f"{spacecraft.dipole_limit or 0.2:g} A m^2")
    return text, {"passed": result.passed, "seconds": time.perf_counter() - t0, "rate": DAMPING_RATE,
                  "metrics": {x.name: {"value": x.value, "max": x.max, "unit": x.unit, "passed": x.passed}
                              for x in result.metrics}}


def design_row(method: str, name: str, full: bool) -> Row:
    """Run ``method`` on the spacecraft ``name`` and make its row (closed loop included).

    Parameters
    ----------
    method : str
        Key of :data:`METHODS`.
    name : str
        Key of :data:`SPACECRAFT`.
    full : bool
        The methods' default sizes instead of the reduced ones.

    Returns
    -------
    Row
        The row; a :class:`satfmu.DesignError` becomes a "refused" row (any other error propagates);
        a method for the other kind of spacecraft, a "not applicable" row (:func:`not_applicable`).
    """
    row = not_applicable(method, name)
    if row is not None:
        return row
    craft = SPACECRAFT[name]
    artifact = f"table_{method}_{name}"
    call: Callable[[], satfmu.Design]
    if isinstance(craft, satfmu.FlexibleSpacecraft):
        call = lambda: designs.design_demeter(ROBUST_AXES, ROBUST_APPENDAGES, plant=craft,  # noqa: E731
                                              name=artifact, analysis=full)
    elif method == "hinf":
        reduced: dict[str, Any] = {} if full else {"decay_rates": (0.02,), "n_samples": 5_000}
        call = lambda: designs.design_hinf(  # noqa: E731
            craft, name=artifact, start=satfmu.manoeuvre(MANOEUVRE_DEG, axis=MANOEUVRE_AXIS),
            torque_budget=craft.torque_limit, **reduced)
    elif method == "h2hinf":
        call = lambda: designs.design_h2hinf(H2HINF_GAMMA[name], craft, name=artifact,  # noqa: E731
                                             evaluations=12 if full else 6)
    elif method == "periodic":
        call = lambda: designs.design_cubesat_periodic(plant=craft, name=artifact)  # noqa: E731
    elif method == "sdre":
        call = lambda: designs.design_sdre(craft, name=artifact)  # noqa: E731
    else:
        raise ValueError(f"unknown method {method!r} (known: {', '.join(METHODS)})")
    gamma_note = f"gamma = {H2HINF_GAMMA[name]:g}: " if method == "h2hinf" else ""
    t0 = time.perf_counter()
    try:
        design = call()
    except satfmu.DesignError as exc:
        seconds = time.perf_counter() - t0
        return Row(method, name, "refused", gamma_note + shorten(str(exc)), seconds, "not run",
                   {"message": str(exc)})
    seconds = time.perf_counter() - t0
    cert = design.artifact.get("certificate", {})
    status = str(cert.get("status", "designed"))
    first = design.summary.splitlines()[0] if design.summary else ""
    details: dict[str, Any] = {"summary": design.summary, "certificate_status": status,
                               "certificate_numbers": cert.get("numbers", {})}
    if method == "hinf":
        c = cert["l2_gain"]["c"]
        numbers = f"L2 gain c = {c:.4g} on {cert['l2_gain']['region']}"
        details["l2_gain"] = {k: v for k, v in cert["l2_gain"].items() if k != "checks"}
    elif method == "h2hinf":
        r = design.result
        numbers = (f"gamma = {r.gamma:g}, lambda = {r.lam:.4g}, alpha = {r.alpha:.4g} s, beta = {r.beta:.4g} s; "
                   f"{shorten(first, 160)}")
        details.update(gamma=r.gamma, lam=r.lam, alpha=r.alpha, beta=r.beta)
    elif method == "sdre":
        n = cert["numbers"]
        numbers = (f"fit degree {design.result.fit.degree}, off-sample error {n['offgrid_max_rel_error']:.3g}; "
                   f"region {shorten(cert['region'], 140)}")
    elif method == "periodic":
        gamma = float(design.result.design.gamma)
        numbers = f"gamma = {gamma:.4g}; {shorten(first, 160)}"
        details["gamma"] = gamma
    else:
        n, check = cert["numbers"], design.result.check
        numbers = (f"axis 1, appendages 1-2, {len(cert['region'].split(' in ')) - 1} parameters: H-inf < "
                   f"{n['design_hinf_bound']:.4g} rad/(N m), i2p < {n['design_i2p_bound']:.4g} N m s; "
                   f"{check.n} sampled plants: H-inf {n['sampled_max_hinf']:.4g}, i2p {n['sampled_max_i2p']:.4g}, "
                   f"max Re s {n['sampled_max_real_pole']:.2g} 1/s")
    row = Row(method, name, status, numbers, seconds, "not run", details)
    if isinstance(craft, satfmu.FlexibleSpacecraft):
        row.closed_loop, row.details["closed_loop"] = flexible_loop(design)
    elif method in ("hinf", "h2hinf", "sdre"):
        row.closed_loop, row.details["closed_loop"] = closed_loop(design, craft, STOP_TIME[name],
                                                                  servo=method == "sdre")
    elif method == "periodic":
        row.closed_loop, row.details["closed_loop"] = periodic_loop(design, craft)
    return row


def table(methods: Sequence[str], spacecraft: Sequence[str], full: bool,
          log: Callable[[str], None] = lambda s: None) -> list[Row]:
    """Every (method, spacecraft) row, methods outer.

    Parameters
    ----------
    methods : sequence of str
        Keys of :data:`METHODS`.
    spacecraft : sequence of str
        Keys of :data:`SPACECRAFT`.
    full : bool
        The methods' default sizes instead of the reduced ones.
    log : callable, optional
        Called with a progress line before and after each row.

    Returns
    -------
    list of Row
        The rows.
    """
    rows = []
    for method in methods:
        for name in spacecraft:
            log(f"[{method} x {name}] ...")
            t0 = time.perf_counter()
            row = design_row(method, name, full)
            log(f"[{method} x {name}] {row.outcome} in {time.perf_counter() - t0:.1f} s; closed loop: "
                f"{row.closed_loop}")
            rows.append(row)
    return rows


def header(mode: str) -> str:
    """The table's title and what its columns mean.

    Parameters
    ----------
    mode : str
        The run's mode as it reads in the text (reduced, with the reduced sizes, or full).

    Returns
    -------
    str
        Markdown: the title and one paragraph.
    """
    return (f"# Design methods x spacecraft (issue 53)\n\nMode: {mode}. Closed loop, through native FMUs: seeds "
            f"000-002, {MANOEUVRE_DEG:g} deg rest-to-rest about {MANOEUVRE_AXIS}, no saturation, passing when the "
            f"angle error at the end is <= {ANGLE_BOUND_DEG:g} deg and the peak torque <= the torque limit; seed "
            f"003, the gains beside B-dot on the nonlinear magnetorquer plant (dipole clipped) from "
            f"{DAMPING_RATE:g} rad/s, passing when |w| falls 10x in two orbits; seed 004, the worst initial error "
            "through the flexible plant with its wheel limits, passing when the wheel-momentum proxy stays within "
            "its certified bound, the wheel momentum within its limit and the attitude within the initial error.")


def main(argv: Sequence[str] | None = None) -> int:
    """Run the table and print it (see the module docstring).

    Parameters
    ----------
    argv : sequence of str, optional
        Command-line arguments (default ``sys.argv[1:]``).

    Returns
    -------
    int
        0.
    """
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--full", action="store_true", help="the methods' default sizes (slower)")
    parser.add_argument("--only", choices=list(METHODS), action="append", help="run only this method (repeatable)")
    parser.add_argument("--spacecraft", choices=list(SPACECRAFT), action="append",
                        help="run only on this spacecraft (repeatable)")
    parser.add_argument("--out", type=Path, help="also write the Markdown table here")
    parser.add_argument("--json", type=Path, help="write the raw rows here as JSON")
    args = parser.parse_args(argv)

    def log(line: str) -> None:
        print(line, file=sys.stderr, flush=True)

    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="satfmu_design_table_") as home:
        os.environ["SATFMU_HOME"] = home  # artifacts and FMUs of this run only, removed at the end
        log(f"SATFMU_HOME={home}")
        rows = table(args.only or list(METHODS), args.spacecraft or list(SPACECRAFT), args.full, log)
    total = time.perf_counter() - t0
    mode = "full" if args.full else "reduced (design_hinf: decay_rates=(0.02,), n_samples=5000; design_h2hinf: " \
                                    "evaluations=6)"
    text = f"{header(mode)}\n\n{markdown(rows)}\n\nTotal wall time: {total:.0f} s.\n"
    print(text, end="")
    if args.out:
        args.out.write_text(text)
    if args.json:
        args.json.write_text(json.dumps({"mode": "full" if args.full else "reduced", "total_seconds": total,
                                         "rows": [asdict(r) for r in rows]}, indent=1, default=str) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
