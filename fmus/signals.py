"""Signal generators: the disturbance profiles of a scenario as stateless models (and FMUs).

Each generator has one output ``y``, a function of time and of its parameters, and no inputs.
The analytic kinds are generic models, built once, with the signal's constants as FMU
parameters; a sampled signal (a table, a CSV column, a random sequence, a field sampled along
an orbit) is a :class:`satfmu.fmus.table.Table` compiled into its own model. The same expressions give
the master's in-process profile (:func:`evaluate`, used by :mod:`satfmu.fmus.profiles`), the generated
Python and the C of the native FMU, so a scenario run with its profiles as FMUs (an SSP file in
another tool) sees the very values the master sets.

Units: FMI 2.0 gives every variable one fixed unit, so a generator is made for the unit of
the input it drives (``unit``, from the target FMU's model description: :func:`satfmu.sims.interop.ssp.target_unit`);
``y`` and the value parameters (``value``, ``before``, ``after``, ``amplitude``, ``offset``)
declare it. Unit ``"1"`` (dimensionless) gives the catalog's generic FMUs ``signal_<kind>``; another
unit gives ``signal_<kind>__<unit tag>`` (:func:`model_name`, e.g. ``signal_step__N_m`` for N.m),
built when a scenario's SSP file needs it. Times are in s.

Kinds:

- ``signal_constant``: y = value
- ``signal_step``: y = before until ``step_time``, then after (a jump at ``step_time``, to
  the time tolerance :data:`satfmu.fmus.instants.TIME_TOL`); the parameter is not
  called ``time``, the name of the independent variable in result files
  and in Modelica
- ``signal_sinusoid``: y = offset + amplitude sin(2 pi frequency_Hz t + phase_rad), the
  argument reduced to one period (``frequency_Hz t`` modulo 1) where
  2 pi frequency_Hz t would overflow, so that it stays finite up to
  t = DBL_MAX (1.8e308 s) at 1 Hz
- ``signal_cosine_ramp``: from ``before`` at ``start`` to ``after`` at ``stop`` along
  (1 - cos(pi (t - start)/(stop - start)))/2 (seed 002 eq. 24-25), or
  its first or second time derivative (``derivative`` = 1, 2); a ramp
  of no duration (``stop <= start``) is a step at ``start`` whose
  derivatives are 0 (the impulse at ``start`` has no finite value)
- ``signal_table_<hash>``: the table (:class:`satfmu.fmus.table.Table`), ``"previous"`` or ``"linear"``

An output that is not finite all the same (an overflow: a ramp so short that its second
derivative exceeds 1.8e308) is refused by the native FMU with fmi2Error, never returned with
fmi2OK (``fmus/c/satfmu_core.h``).
"""
from __future__ import annotations

import hashlib
import json
from functools import lru_cache
from typing import Callable

import numpy as np
import sympy as sp
from sympy.printing.numpy import NumPyPrinter

from satfmu.fmus.model import Model, Output, Table, TableLookup, Variable, time_tolerance
from satfmu.fmus.units import DIMENSIONLESS, UNITS

OUTPUT = "y"
"""Name of every generator's output."""
_TAG = {".": "_", "/": "_per_", "^": "_pow_", "-": "_neg_"}

t = Model.t


def _at_or_after(t0: sp.Expr) -> sp.Basic:
    """``t`` has reached ``t0`` (within the time tolerance)."""
    return t >= t0 - time_tolerance(t)


def unit_tag(unit: str) -> str:
    """``unit`` as a part of a C identifier: letters and digits kept, ``.`` -> ``_``, ``/`` ->
    ``_per_``, ``^`` -> ``_pow_``, ``-`` -> ``_neg_``, any other character (``_`` too) ->
    ``_x<hex code>``, so that different units give different tags (``"N.m"`` -> ``"N_m"``).

    Parameters
    ----------
    unit : str
        A unit (``"N.m"``, ``"rad/s"``, ...).

    Returns
    -------
    str
        The tag.
    """
    return "".join(c if c.isascii() and c.isalnum() else _TAG.get(c, f"_x{ord(c):x}") for c in unit)


def model_name(kind: str, unit: str = DIMENSIONLESS) -> str:
    """The generator's model (and FMU) name: ``signal_<kind>`` for a dimensionless signal,
    ``signal_<kind>__<unit_tag(unit)>`` otherwise.

    Parameters
    ----------
    kind : str
        The generator kind (``"constant"``, ``"step"``, ``"sinusoid"``, ``"cosine_ramp"``).
    unit : str, optional
        Unit of the generator's output. Default ``"1"`` (dimensionless).

    Returns
    -------
    str
        The name (:func:`unit_tag` gives the unit's part).
    """
    return f"signal_{kind}" if unit == DIMENSIONLESS else f"signal_{kind}__{unit_tag(unit)}"


def _check_unit(unit: str) -> None:
    if unit not in UNITS:
        raise ValueError(f"a signal's unit must be one of satfmu.fmus.units.UNITS, got {unit!r}")


def _model(kind: str, unit: str, description: str, parameters: list[Variable], y: sp.Expr,
           stop: float = 10.0) -> Model:
    out = Output(Variable(OUTPUT, unit, "Signal value"), y)
    suffix = "" if unit == DIMENSIONLESS else f", in {unit}"
    return Model(model_name(kind, unit), description + suffix, states=[], inputs=[], parameters=parameters,
                 outputs=[out], default_stop_time=stop)


@lru_cache(maxsize=None)
def constant(unit: str = DIMENSIONLESS) -> Model:
    """``y = value``, in ``unit``.

    Parameters
    ----------
    unit : str, optional
        Unit of the output ``y`` (one of :data:`satfmu.fmus.units.UNITS`). Default ``"1"``.
    """
    _check_unit(unit)
    value = Variable("value", unit, "Signal value")
    return _model("constant", unit, "Constant signal", [value], value.symbol)


@lru_cache(maxsize=None)
def step(unit: str = DIMENSIONLESS) -> Model:
    """``y = before`` for ``t < step_time``, ``after`` from ``step_time`` on, in ``unit``.

    Parameters
    ----------
    unit : str, optional
        Unit of the output ``y`` (one of :data:`satfmu.fmus.units.UNITS`). Default ``"1"``.
    """
    _check_unit(unit)
    step_time = Variable("step_time", "s", "Time of the step", 1.0)
    before = Variable("before", unit, "Value before the step", 0.0)
    after = Variable("after", unit, "Value from the step time on", 1.0)
    y = sp.Piecewise((after.symbol, _at_or_after(step_time.symbol)), (before.symbol, True))
    return _model("step", unit, "Step signal", [step_time, before, after], y)


@lru_cache(maxsize=None)
def sinusoid(unit: str = DIMENSIONLESS) -> Model:
    """``y = offset + amplitude sin(2 pi frequency_Hz t + phase_rad)``, in ``unit``.

    Parameters
    ----------
    unit : str, optional
        Unit of the output ``y`` (one of :data:`satfmu.fmus.units.UNITS`). Default ``"1"``.
    """
    _check_unit(unit)
    amp = Variable("amplitude", unit, "Amplitude", 1.0)
    freq = Variable("frequency_Hz", "1/s", "Frequency, Hz", 1.0)
    phase = Variable("phase_rad", "rad", "Phase at t = 0", 0.0)
    offset = Variable("offset", unit, "Offset", 0.0)
    # sin(2 pi (f t mod 1) + phase) = sin(2 pi f t + phase) where 2 pi f t overflows (|f t| beyond
    # 2^1000 ~ 1e301 s x Hz, up to DBL_MAX: t = DBL_MAX at 1 Hz); below, the direct form, bit for bit
    ft = freq.symbol * t
    y = offset.symbol + amp.symbol * sp.Piecewise(
        (sp.sin(2 * sp.pi * ft + phase.symbol), sp.Abs(ft) < sp.Float(2.0**1000)),
        (sp.sin(2 * sp.pi * sp.Mod(ft, 1) + phase.symbol), True))
    return _model("sinusoid", unit, "Sinusoidal signal", [amp, freq, phase, offset], y)


@lru_cache(maxsize=None)
def cosine_ramp(unit: str = DIMENSIONLESS) -> Model:
    """Seed 002 eq. (24)-(25): a cosine ramp from ``before`` to ``after`` over [start, stop],
    or its first or second derivative (per s, per s^2), zero outside the ramp; with
    ``stop <= start`` a step from ``before`` to ``after`` at ``start`` (derivatives 0).

    ``unit`` is the output's (the input it drives: for a derivative the ramped value's unit per s
    or per s^2). ``before`` and ``after`` are the ramped values, in ``unit`` only for
    ``derivative`` = 0 (a parameter, set after the FMU is built): they are declared ``"1"``,
    their description says so.

    Parameters
    ----------
    unit : str, optional
        Unit of the output ``y`` (one of :data:`satfmu.fmus.units.UNITS`). Default ``"1"``.
    """
    _check_unit(unit)
    start = Variable("start", "s", "Start of the ramp", 0.0)
    stop = Variable("stop", "s", "End of the ramp (must exceed start)", 1.0)
    before = Variable("before", DIMENSIONLESS, "Value until start (in the unit of the ramped value)", 0.0)
    after = Variable("after", DIMENSIONLESS, "Value from stop on (in the unit of the ramped value)", 1.0)
    order = Variable("derivative", "1", "0: the ramp; 1, 2: its first, second time derivative",
                     0, "Integer", min=0, max=2)
    t0, t1, a, b, n = (v.symbol for v in (start, stop, before, after, order))
    w = sp.pi / (t1 - t0)
    x = w * (sp.Min(sp.Max(t, t0), t1) - t0)
    inside = sp.And(_at_or_after(t0), t <= t1 + time_tolerance(t))
    no_duration = t1 <= t0  # pi / (t1 - t0) is not finite: only the step branches are evaluated
    y = sp.Piecewise((sp.Piecewise((b, _at_or_after(t0)), (a, True)), sp.And(no_duration, n < sp.Rational(1, 2))),
                     (0, no_duration),
                     (a + (b - a) * (1 - sp.cos(x)) / 2, n < sp.Rational(1, 2)),
                     (0, sp.Not(inside)),
                     ((b - a) * w * sp.sin(x) / 2, n < sp.Rational(3, 2)),
                     ((b - a) * w**2 * sp.cos(x) / 2, True))
    return _model("cosine_ramp", unit, "Cosine ramp (seed 002 eq. 24-25) or its derivatives",
                  [start, stop, before, after, order], y)


def table(tb: Table, unit: str = DIMENSIONLESS) -> Model:
    """The table ``tb`` as a generator of values in ``unit``; its name carries a hash of the
    data and the unit (``signal_table_<12 hex>``), so equal tables of one unit give one FMU.

    Parameters
    ----------
    tb : Table
        The breakpoints (times in s), values and interpolation of the signal.
    unit : str, optional
        Unit of the values (one of :data:`satfmu.fmus.units.UNITS`). Default ``"1"``.

    Returns
    -------
    Model
        A model with no states, inputs or parameters whose output ``y`` looks the table up.
    """
    _check_unit(unit)
    key = json.dumps([tb.times, tb.values, tb.interpolation] + ([] if unit == DIMENSIONLESS else [unit])).encode()
    name = f"signal_table_{hashlib.sha256(key).hexdigest()[:12]}"
    span = tb.times[-1] - tb.times[0]
    return Model(name, f"Table of {len(tb.times)} breakpoints, {tb.interpolation} interpolation, in {unit}",
                 states=[], inputs=[], parameters=[],
                 outputs=[Output(Variable(OUTPUT, unit, "Signal value"), TableLookup(0, t))],
                 default_stop_time=span if span > 0 else 10.0, tables=[tb])


GENERIC: dict[str, Callable[..., Model]] = {"constant": constant, "step": step, "sinusoid": sinusoid,
                                            "cosine_ramp": cosine_ramp}
"""The generic generators by profile kind, called with the unit (default ``"1"``: the catalog's
FMUs, built once into ``build/fmus``)."""


NUMPY_MODULE = "signal_functions.py"
"""The module of :func:`numpy_source`'s text, beside this one (:mod:`satfmu.fmus.signal_functions`)."""


def numpy_source() -> str:
    """The text of :mod:`satfmu.fmus.signal_functions`: each generic generator's output as a
    numpy function of ``t`` (s) and its parameters, printed from the generator's expression
    (common subexpressions eliminated, as ``sympy.lambdify`` does), and its parameters' names
    and start values. The master's profiles evaluate them without importing sympy.

    ``scripts/generate_signal_functions.py`` writes it; ``tests/test_signals.py`` checks that the
    module's functions give the generators' values bit for bit.

    Returns
    -------
    str
        The module's text.
    """
    printer = NumPyPrinter({"fully_qualified_modules": True})
    lines = ['"""Generated by satfmu.fmus.signals.numpy_source from the generic signal generators of',
             "satfmu.fmus.signals; do not edit (scripts/generate_signal_functions.py writes it).",
             "",
             "Each function gives a generator's output ``y`` at the times ``t`` (s, any shape) from its parameters;",
             ":data:`PARAMETERS` holds each generator's parameter names and start values, in its parameter order.",
             '"""',
             "# ruff: noqa: E501 (sympy prints each expression on one line)",
             "import functools", "from typing import Any, Callable", "", "import numpy", "",
             f"SYMPY_VERSION = {sp.__version__!r}",
             '"""The sympy that printed this module: another one may print it otherwise (same values)."""', ""]
    parameters = {}
    for kind, build in GENERIC.items():
        model = build()
        parameters[kind] = tuple((v.name, float(v.start)) for v in model.parameters)
        names = ", ".join(v.name for v in model.parameters)
        replacements, (reduced,) = sp.cse([model.outputs[0].expression])
        lines += ["", f"def {kind}(t, {names}):", f'    """{model.description}: ``y`` at the times ``t``.', "",
                  "    Parameters", "    ----------", "    t : numpy.ndarray", "        Times, s (any shape)."]
        for v in model.parameters:
            unit = "" if v.unit == DIMENSIONLESS else f", {v.unit}"  # the value parameters': the signal's unit
            lines += [f"    {v.name} : numpy.float64", f"        {v.description}{unit}."]
        lines += ["", "    Returns", "    -------", "    numpy.ndarray or numpy.float64",
                  "        ``y``, in the generator's unit (a scalar for a constant).", '    """']
        lines += [f"    {symbol} = {printer.doprint(expr)}" for symbol, expr in replacements]
        lines += [f"    return {printer.doprint(reduced)}", ""]
    lines += ["", f"PARAMETERS: dict[str, tuple[tuple[str, float], ...]] = {parameters!r}",
              '"""Generator kind -> (name, start value) of each parameter, in its function\'s argument order."""',
              "FUNCTIONS: dict[str, Callable[..., Any]] = {" + ", ".join(f"{k!r}: {k}" for k in GENERIC) + "}",
              '"""Generator kind -> its function."""']
    return "\n".join(lines) + "\n"


def evaluate(model: Model, parameters: dict[str, float], times: np.ndarray) -> np.ndarray:
    """The output ``y`` of a generator at ``times`` (s), the parameters overriding the defaults.

    Parameters
    ----------
    model : Model
        A generator of this module (one output, no states or inputs).
    parameters : dict of str to float
        Parameter values by name, overriding the model's start values.
    times : numpy.ndarray
        Times, s (any shape).

    Returns
    -------
    numpy.ndarray
        ``y`` at each time, same shape as ``times``, in the generator's unit.
    """
    fn = _output_function(model)
    t = np.asarray(times, float)
    y = np.asarray(fn(t, [], [], model.parameter_vector(parameters)), float)[0, 0]
    return np.broadcast_to(y, t.shape).copy()


def _output_function(model: Model) -> Callable[..., np.ndarray]:
    cached = model.__dict__.get("_signal_function")
    if cached is None:
        cached = model.__dict__["_signal_function"] = model.lambdify([model.outputs[0].expression])
    return cached
