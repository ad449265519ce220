"""Code generation from a :class:`satfmu.fmus.model.Model`: Python and C of the same expressions.

Both generators share one lowering step (:func:`lower`): every state, input and
parameter symbol is replaced by an array element (``x[i]``, ``u[i]``, ``p[i]``),
common subexpressions are eliminated once, and the printers only differ in syntax.
The Python module is used by the in-process reference simulation and embedded in
the pythonfmu FMU; the C file is included by the generic FMI wrapper
of the native FMU (``fmus/c/satfmu_core.h``, shared by the FMI 2.0 and FMI 3.0 interfaces
``fmus/c/fmi2_cosim.c`` and ``fmus/c/fmi3.c``).
"""
from __future__ import annotations

import math
import uuid
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import Sequence

import sympy as sp
from sympy.printing.c import C99CodePrinter
from sympy.printing.pycode import PythonCodePrinter

from satfmu.fmus import noise
from satfmu.fmus.arrays import StateArray, array_variables, state_arrays
from satfmu.fmus.digest import model_digest
from satfmu.fmus.events import event_indicators, sided
from satfmu.fmus.model import Model, TableLookup
from satfmu.fmus.instants import TIME_TOL, TIME_TOL_MAX, TIME_ULPS

KIND_PARAMETER, KIND_INPUT, KIND_OUTPUT = 0, 1, 2
TYPE_CODES = {"Real": 0, "Integer": 1, "Boolean": 2}


@dataclass(frozen=True)
class LoweredFunction:
    """Expressions of one generated function after array substitution and CSE.

    Attributes
    ----------
    name : str
        Name of the generated function (``"derivatives"``, ``"outputs"``, ``"post_step"``,
        ``"sample_arguments"``, ``"jacobian"``, ``"switch_time"``).
    temporaries : list of tuple of (sympy.Symbol, sympy.Expr)
        Assignments computed before the results, in dependency order: the common
        subexpressions (``c_0``, ``c_1``, ...) and the model definitions used (``d_k``).
    results : list of sympy.Expr
        One expression per value the function returns, in the array symbols (``x[i]``,
        ``u[i]``, ``p[i]``, ...) and the temporaries.
    """

    name: str
    temporaries: list[tuple[sp.Symbol, sp.Expr]]
    results: list[sp.Expr]


def _array_substitution(model: Model) -> dict[sp.Symbol, sp.Symbol]:
    subs: dict[sp.Symbol, sp.Symbol] = {sym: sp.Symbol(f"d_{k}", real=True)
                                        for k, (sym, _) in enumerate(model.definitions)}
    for i, s in enumerate(model.state_symbols):
        subs[s] = sp.Symbol(f"x[{i}]", real=True)
    for i, s in enumerate(model.previous_symbols):
        subs[s] = sp.Symbol(f"xp[{i}]", real=True)
    for i, s in enumerate(model.input_symbols):
        subs[s] = sp.Symbol(f"u[{i}]", real=True)
    for i, s in enumerate(model.parameter_symbols):
        subs[s] = sp.Symbol(f"p[{i}]", real=True)
    n_p = len(model.parameters)  # held values follow the parameters in the runtime's p
    for i, s in enumerate(model.held_symbols):
        subs[s] = sp.Symbol(f"p[{n_p + i}]", real=True)
    return subs


def lower(model: Model, name: str, exprs: Sequence[sp.Expr], previous_is_current: bool = False,
          definitions: Sequence[tuple[sp.Symbol, sp.Expr]] | None = None) -> LoweredFunction:
    """Substitute array elements for symbols and eliminate common subexpressions.

    ``previous_is_current`` reads the substep-start state as the current state (outputs).
    The model's definitions that ``exprs`` use (directly or through other definitions)
    become temporaries too, ordered so every temporary follows what it uses.

    Parameters
    ----------
    model : Model
        The model whose state, previous-state, input, parameter, held and defined symbols
        are replaced.
    name : str
        Name of the generated function (``"derivatives"``, ``"outputs"``, ...).
    exprs : sequence of sympy.Expr
        The expressions the function returns, in the model's symbols.
    previous_is_current : bool, optional
        Replace the substep-start state symbols (:attr:`satfmu.fmus.model.Model.previous_symbols`) by the
        current state ``x[i]`` as well (for outputs and sampler arguments). Default False.
    definitions : sequence of (sympy.Symbol, sympy.Expr), optional
        Another form of the model's definitions (:meth:`satfmu.fmus.model.Model.used_definitions`).

    Returns
    -------
    LoweredFunction
        The temporaries and results in array elements.
    """
    exprs = list(exprs)
    if not exprs:
        return LoweredFunction(name, [], [])
    subs = _array_substitution(model)
    if previous_is_current:
        subs.update({p: subs[x] for p, x in zip(model.previous_symbols, model.state_symbols)})
    defs = [(subs[sym], sp.sympify(e).xreplace(subs)) for sym, e in model.used_definitions(exprs, definitions)]
    exprs = [sp.sympify(e).xreplace(subs) for e in exprs]
    temps, reduced = sp.cse([e for _, e in defs] + exprs, symbols=sp.numbered_symbols("c_"),
                            optimizations="basic")
    assignments = list(temps) + [(sym, e) for (sym, _), e in zip(defs, reduced)]
    return LoweredFunction(name, _dependency_order(assignments), list(reduced[len(defs):]))


def _dependency_order(assignments: list[tuple[sp.Symbol, sp.Expr]]) -> list[tuple[sp.Symbol, sp.Expr]]:
    """Assignments sorted so that each comes after the ones whose symbols it uses (stable)."""
    pending = {sym: set(e.free_symbols) for sym, e in assignments}
    defined = {sym for sym, _ in assignments}
    done: set[sp.Symbol] = set()
    ordered: list[tuple[sp.Symbol, sp.Expr]] = []
    remaining = list(assignments)
    while remaining:
        ready = [a for a in remaining if not (pending[a[0]] & defined) - done]
        if not ready:
            raise ValueError("cyclic definitions: " + ", ".join(str(a[0]) for a in remaining))
        for a in ready:
            ordered.append(a)
            done.add(a[0])
        remaining = [a for a in remaining if a[0] not in done]
    return ordered


_LOWERED: dict[str, tuple[LoweredFunction, ...]] = {}
"""Lowered functions by model digest: a model is lowered once per process."""


def functions(model: Model) -> list[LoweredFunction]:
    """The generated functions: derivatives, outputs, post_step (identity if absent),
    sample_arguments for a model with a :class:`satfmu.fmus.model.Sampler`, and for the exact
    integrator jacobian (``d rhs / d x`` row-major) and switch_time (``oo`` if not given).

    Lowering (common subexpression elimination) is the expensive part of code generation;
    its result is kept per :func:`satfmu.fmus.digest.model_digest`, so the C, the Python and the
    native and pythonfmu FMUs of one model share one lowering.

    Parameters
    ----------
    model : Model
        The model to generate code for.

    Returns
    -------
    list of LoweredFunction
        The functions, in the order above.
    """
    key = model_digest(model)
    if key not in _LOWERED:
        _LOWERED[key] = tuple(_lower_all(model))
    return list(_LOWERED[key])


_EVENTS: dict[str, LoweredFunction] = {}
"""Lowered event indicators by model digest."""


def event_function(model: Model) -> LoweredFunction:
    """The event indicators of a model-exchange FMU (:func:`satfmu.fmus.events.event_indicators`),
    lowered, the substep-start state read as the current one (lowered once per process).

    Parameters
    ----------
    model : Model
        The model.

    Returns
    -------
    LoweredFunction
        ``event_indicators``: one result per indicator.
    """
    key = model_digest(model)
    if key not in _EVENTS:
        _EVENTS[key] = lower(model, "event_indicators", event_indicators(model), previous_is_current=True)
    return _EVENTS[key]


_SIDED: dict[str, tuple[LoweredFunction, LoweredFunction]] = {}
"""Lowered sided derivatives and outputs by model digest."""


def sided_functions(model: Model) -> tuple[LoweredFunction, LoweredFunction]:
    """The right-hand side and the outputs of a model-exchange FMU with each indicator's relations
    read from its side ``s[k]`` (:func:`satfmu.fmus.events.sided`): ``derivatives_sided`` and
    ``outputs_sided`` (lowered once per process).

    Parameters
    ----------
    model : Model
        The model.

    Returns
    -------
    tuple of LoweredFunction
        ``derivatives_sided`` (the substep-start state as ``xp``) and ``outputs_sided``.
    """
    key = model_digest(model)
    if key not in _SIDED:
        sides = [sp.Symbol(f"s[{k}]", real=True) for k in range(len(event_indicators(model)))]
        definitions = list(zip([sym for sym, _ in model.definitions],
                               sided(model, [e for _, e in model.definitions], sides)))
        _SIDED[key] = (
            lower(model, "derivatives_sided", sided(model, list(model.rhs), sides), definitions=definitions),
            lower(model, "outputs_sided", sided(model, [o.expression for o in model.outputs], sides),
                  previous_is_current=True, definitions=definitions))
    return _SIDED[key]


def draws_noise(model: Model) -> bool:
    """Whether the model's generated code calls the counter-based noise of :mod:`satfmu.fmus.noise`
    (its Python and C forms are then emitted with it).

    Parameters
    ----------
    model : Model
        The model.

    Returns
    -------
    bool
        True when an expression of a generated function holds a noise function.
    """
    return any(e.has(*noise.NOISE_FUNCTIONS) for f in functions(model)
               for e in [*f.results, *(v for _, v in f.temporaries)])


def _lower_all(model: Model) -> list[LoweredFunction]:
    post = model.post_step if model.post_step is not None else sp.Matrix(model.state_symbols)
    out = [
        lower(model, "derivatives", list(model.rhs)),
        lower(model, "outputs", [o.expression for o in model.outputs], previous_is_current=True),
        lower(model, "post_step", list(post)),
    ]
    if model.sampler is not None:
        out.append(lower(model, "sample_arguments", model.sampler.arguments, previous_is_current=True))
    if model.integrator == "exact":
        switch = model.switch_time if model.switch_time is not None else sp.oo
        out += [lower(model, "jacobian", list(model.jacobian)),
                lower(model, "switch_time", [switch], previous_is_current=True)]
    return out


def sampler_table(model: Model) -> dict | None:
    """The sampler's run-time description (plain data), or None.

    Parameters
    ----------
    model : Model
        The model; None is returned when it has no :class:`satfmu.fmus.model.Sampler`.

    Returns
    -------
    dict or None
        ``module`` (embedded module name, None for an expression sampler), ``function``,
        ``options``, ``period_index`` and ``phase_index`` (indices into the parameters) and
        ``n_held`` (number of held values).
    """
    smp = model.sampler
    if smp is None:
        return None
    names = [v.name for v in model.parameters]
    return {"module": None if smp.is_expression else sampler_module_name(model), "function": smp.function,
            "options": dict(smp.options), "period_index": names.index(smp.period),
            "phase_index": None if smp.phase is None else names.index(smp.phase), "n_held": len(smp.held)}


def sampler_module_name(model: Model) -> str:
    """Name under which the sampler's module file is embedded in the FMU.

    Parameters
    ----------
    model : Model
        A model whose sampler calls a function of a Python module file.

    Returns
    -------
    str
        ``satfmu_sampler_<module file stem>``.

    Raises
    ------
    ValueError
        If the model has no sampler or its sampler has no Python module.
    """
    if model.sampler is None or model.sampler.module is None:
        raise ValueError(f"{model.name}: no Python sampler module")
    return f"satfmu_sampler_{Path(model.sampler.module).stem}"


def variable_table(model: Model) -> list[dict]:
    """FMU variables in value-reference order, as plain data (shared by both backends).

    Parameters
    ----------
    model : Model
        The model whose parameters, inputs and outputs become FMU variables (in that order).

    Returns
    -------
    list of dict
        One row per variable: ``vr``, ``name``, ``kind`` (``KIND_PARAMETER``, ``KIND_INPUT``,
        ``KIND_OUTPUT``), ``index`` (within its kind), ``type``, ``start``, ``min``, ``max``.
    """
    rows = []
    kinds = ([(KIND_PARAMETER, i, v) for i, v in enumerate(model.parameters)]
             + [(KIND_INPUT, i, v) for i, v in enumerate(model.inputs)]
             + [(KIND_OUTPUT, i, o.variable) for i, o in enumerate(model.outputs)])
    for vr, (kind, index, v) in enumerate(kinds):
        rows.append({"vr": vr, "name": v.name, "kind": kind, "index": index, "type": v.type,
                     "start": float(v.start), "min": v.min, "max": v.max})
    return rows


def guid_bytes(guid: str) -> bytes:
    """The 16 bytes of an FMU's GUID (``{xxxxxxxx-...}``, :func:`satfmu.fmus.description.fmu_guid`): the
    model identity the native FMU writes into every FMU state and compares when a state is
    restored (a state of another FMU, even with the same layout, is refused).

    Parameters
    ----------
    guid : str
        The GUID, with or without braces.

    Returns
    -------
    bytes
        ``uuid.UUID(guid).bytes``.
    """
    return uuid.UUID(guid).bytes


MAX_PRODUCT_POWER = 8
"""Integer powers ``x**n`` with ``2 <= |n| <= MAX_PRODUCT_POWER`` are printed as products, identically in C and
Python."""


def _product_power(printer: C99CodePrinter | PythonCodePrinter, expr: sp.Pow, one: str) -> str | None:
    """``x**n`` for an integer ``2 <= |n| <= MAX_PRODUCT_POWER`` as ``((x)*(x)*...)`` (``one/(...)`` for
    n < 0), multiplied left to right in both languages; None for any other power.

    Why: gcc -O2 turns ``pow(x, 2)`` into ``x*x`` while Python's ``x**2`` calls the C library's pow,
    and the two differ in the last bit now and then; over a long run the native and pythonfmu FMUs
    then drift apart (121,060 of 162,015 values of cubesat_detumble, up to 8.5e-14). Products in
    both keep them identical bit for bit, and spare the native FMU the pow calls."""
    base, exp = expr.as_base_exp()
    if not (exp.is_Integer and 2 <= abs(int(exp)) <= MAX_PRODUCT_POWER):
        return None
    product = "(" + "*".join([f"({printer._print(base)})"] * abs(int(exp))) + ")"
    return product if exp > 0 else f"({one}/{product})"


# ----------------------------------------------------------------------------- Python
class _Py(PythonCodePrinter):
    def _print_Symbol(self, expr: sp.Symbol) -> str:  # keep x[i] verbatim
        return expr.name

    def _print_Pow(self, expr: sp.Pow, rational: bool = False) -> str:
        return _product_power(self, expr, "1.0") or super()._print_Pow(expr, rational)

    def _print_TableLookup(self, expr: TableLookup) -> str:
        return f"table_lookup({int(expr.args[0])}, {self._print(expr.args[1])})"

    def _print_UniformNoise(self, expr: noise.UniformNoise) -> str:
        return f"uniform_noise({', '.join(self._print(a) for a in expr.args)})"

    def _print_GaussianNoise(self, expr: noise.GaussianNoise) -> str:
        return f"gaussian_noise({', '.join(self._print(a) for a in expr.args)})"


# The lookup of satfmu.fmus.table.Table.evaluate, one time at a time (generated Python and C).
_PY_TABLE_LOOKUP = """
def time_tolerance(t):
    a = abs(t)
    return max(min(TIME_TOL * max(1.0, a), TIME_TOL_MAX), TIME_ULPS * 2.0**-52 * a)


def table_lookup(k, t):
    times, values, previous = TABLES[k]
    n = len(times)
    if previous:
        i = bisect.bisect_right(times, t + time_tolerance(t)) - 1
        return values[max(i, 0)]
    if n == 1 or t <= times[0]:
        return values[0]
    if t >= times[-1]:
        return values[-1]
    i = bisect.bisect_right(times, t) - 1
    return values[i] + (values[i + 1] - values[i]) * ((t - times[i]) / (times[i + 1] - times[i]))
"""

_C_TABLE_LOOKUP = """
static double table_lookup(int k, double t) {
    const TableData *tb = &TABLES[k];
    size_t lo = 0, hi = tb->n, i;
    const double key = tb->previous ? t + time_tolerance(t) : t;
    if (!tb->previous && (tb->n == 1 || t <= tb->times[0])) return tb->values[0];
    if (!tb->previous && t >= tb->times[tb->n - 1]) return tb->values[tb->n - 1];
    while (lo < hi) { /* lo = number of breakpoints <= key */
        size_t mid = lo + (hi - lo) / 2;
        if (tb->times[mid] <= key) lo = mid + 1; else hi = mid;
    }
    i = lo > 0 ? lo - 1 : 0;
    if (tb->previous) return tb->values[i];
    return tb->values[i] + (tb->values[i + 1] - tb->values[i]) * \
((t - tb->times[i]) / (tb->times[i + 1] - tb->times[i]));
}
"""


def python_source(model: Model, guid: str) -> str:
    """A self-contained Python module (``math`` only) evaluating the model.

    It defines ``derivatives(t, x, xp, u, p)``, ``outputs(t, x, u, p)``,
    ``post_step(t, x, xp, u, p)`` (each returning a list; ``xp`` is the state at the start
    of the integration substep), ``VARIABLES`` (the variable
    table), ``STATE_INITIAL`` (parameter index of each state's initial value) and
    ``GUID``; with a sampler also ``sample_arguments(t, x, u, p)`` and ``SAMPLER``
    (:func:`sampler_table`), the held values following the parameters in ``p``; ``INTEGRATOR``
    and, for the exact one, ``jacobian(t, x, xp, u, p)`` and ``switch_time(t, x, u, p)``.

    Parameters
    ----------
    model : Model
    guid : str
        The GUID of the FMU the module goes into (:func:`satfmu.fmus.description.fmu_guid` of the
        pythonfmu FMU), written as ``GUID``: the slave's FMU states carry it.

    Returns
    -------
    str
        The module's text.
    """
    pr = _Py({"fully_qualified_modules": True, "standard": "python3"})
    lines = [repr(f"Generated by satfmu from the symbolic model {model.name!r}. Do not edit."),
             "import bisect", "import math", "",
             f"TIME_TOL = {TIME_TOL!r}", f"TIME_TOL_MAX = {TIME_TOL_MAX!r}", f"TIME_ULPS = {TIME_ULPS!r}",
             f"NAME = {model.name!r}", f"GUID = {guid!r}",
             f"N_STATES = {len(model.states)}",
             f"VARIABLES = {variable_table(model)!r}",
             f"STATE_INITIAL = {_state_initial(model)!r}",
             f"SAMPLER = {sampler_table(model)!r}",
             f"INTEGRATOR = {model.integrator!r}",
             "TABLES = " + repr([(list(t.times), list(t.values), t.interpolation == "previous")
                                 for t in model.tables]), _PY_TABLE_LOOKUP]
    if draws_noise(model):
        lines.append(noise.PYTHON_SOURCE)
    sig = {"derivatives": "t, x, xp, u, p", "outputs": "t, x, u, p", "post_step": "t, x, xp, u, p",
           "sample_arguments": "t, x, u, p", "jacobian": "t, x, xp, u, p", "switch_time": "t, x, u, p"}
    for f in functions(model):
        lines.append(f"def {f.name}({sig[f.name]}):")
        for sym, e in f.temporaries:
            lines.append(f"    {sym} = {pr.doprint(e)}")
        lines.append("    return [" + ", ".join(pr.doprint(e) for e in f.results) + "]")
        lines.append("")
    return "\n".join(lines) + "\n"


def load_python(model: Model) -> ModuleType:
    """Compile :func:`python_source` into a module object (for in-process simulation).

    The module is cached on the model object: code generation runs once per model.

    Parameters
    ----------
    model : Model
        The model to simulate in process.

    Returns
    -------
    types.ModuleType
        The generated module (the one embedded in the model's pythonfmu FMU).
    """
    cached = model.__dict__.get("_python_module")
    if cached is not None:
        return cached
    from satfmu.fmus.description import PYTHON, fmu_guid  # the description imports this module

    mod = ModuleType(f"satfmu_generated_{model.name}")
    source = python_source(model, fmu_guid(model, PYTHON))  # the module of the pythonfmu FMU
    exec(compile(source, f"<generated {model.name}>", "exec"), mod.__dict__)  # noqa: S102
    model.__dict__["_python_module"] = mod
    return mod


def _state_initial(model: Model) -> list[int]:
    names = [v.name for v in model.parameters]
    return [names.index(s.initial.name) for s in model.states]


# ----------------------------------------------------------------------------- C
class _C(C99CodePrinter):
    """C99 without the POSIX math macros (M_PI is not in strict C99): constants as literals."""

    def __init__(self) -> None:
        super().__init__({"math_macros": {}})

    def _print_Symbol(self, expr: sp.Symbol) -> str:
        return expr.name

    def _print_NumberSymbol(self, expr: sp.Expr) -> str:
        return repr(float(expr))

    def _print_TableLookup(self, expr: TableLookup) -> str:
        return f"table_lookup({int(expr.args[0])}, {self._print(expr.args[1])})"

    def _print_UniformNoise(self, expr: noise.UniformNoise) -> str:
        return f"uniform_noise({', '.join(self._print(a) for a in expr.args)})"

    def _print_GaussianNoise(self, expr: noise.GaussianNoise) -> str:
        return f"gaussian_noise({', '.join(self._print(a) for a in expr.args)})"

    def _print_Pow(self, expr: sp.Pow) -> str:
        return _product_power(self, expr, "1.0") or super()._print_Pow(expr)

    _print_Pi = _print_Exp1 = _print_NumberSymbol

    # Every operand of && and || in parentheses: gcc -Wparentheses (an error with -Werror).
    def _print_And(self, expr: sp.And) -> str:
        return " && ".join(f"({self._print(a)})" for a in sorted(expr.args, key=sp.default_sort_key))

    def _print_Or(self, expr: sp.Or) -> str:
        return " || ".join(f"({self._print(a)})" for a in sorted(expr.args, key=sp.default_sort_key))


def _c_double(v: float | None, default: str) -> str:
    if v is None or (isinstance(v, float) and math.isinf(v)):
        return default
    return repr(float(v))


MAX_STEP_ROUTINE_SAMPLES = 10_000
"""Most sample instants one fmi2DoStep of a native FMU may span when its sampler is a C routine (the
online SDRE's Riccati solve, 0.12 ms: ~1.2 s): the bound of ``fmus/pyslave.py`` for a Python
sampler, so both FMUs of a model refuse the same steps (the expression samplers' bound, 1e6, is
``satfmu_core.h``'s own)."""


def require_c_form(model: Model) -> None:
    """Raise ``ValueError`` if the model has no C form (it samples a Python function with no C twin).

    Parameters
    ----------
    model : Model
        The model to check before building its native FMU.

    Raises
    ------
    ValueError
        If the model's sampler calls a Python function with no C routine.
    """
    if model.sampler is not None and not model.sampler.has_c_form:
        raise ValueError(f"model {model.name!r} samples a Python function ({model.sampler.function}) with no C "
                         "routine; it has no native FMU, build its pythonfmu FMU")


def c_headers(model: Model) -> list[Path]:
    """The library headers (``fmus/c/``) the model's C code includes, to ship in ``sources/``.

    Parameters
    ----------
    model : Model
        The model whose native FMU is built.

    Returns
    -------
    list of Path
        The sampler's C header, or nothing when the model has none.
    """
    path = model.sampler.c_header_path if model.sampler is not None else None
    return [path] if path is not None else []


def _c_sample(model: Model) -> list[str]:
    """``model_sample``: the held values of an instant, 1; or 0 and a message (a routine's refusal)."""
    head = ("static int model_sample(double t, const double *x, const double *u, const double *p, double *held, "
            "char *message, size_t size) {")
    smp = model.sampler
    if smp is None or smp.is_expression:
        return [head, "    (void)size;", "    message[0] = '\\0';",
                "    model_sample_arguments(t, x, u, p, held);", "    return 1;", "}"]
    return [head, f"    double arguments[{len(smp.arguments)}];",
            "    model_sample_arguments(t, x, u, p, arguments);",
            f"    return {smp.c_function}(arguments, held, message, size);", "}"]


C_HEADER = "model.h"
"""Name, in an FMU's ``sources/``, of the generated model code (:func:`c_source`).

A header, not a ``.c`` file: it is no translation unit of its own (it uses the wrapper's
``VariableInfo`` and defines ``static`` functions for it), and an importing tool may compile every
``.c`` file under ``sources/``, so the only ``.c`` file an FMU ships is the wrapper, which includes
this header."""


def _state_groups(model: Model) -> list[StateArray] | None:
    """:func:`satfmu.fmus.arrays.state_arrays` of ``model``, or None when its states do not form
    FMI 3.0 variables (it then has no FMI 3.0 model-exchange FMU)."""
    try:
        return state_arrays(model)
    except ValueError:
        return None


def c_source(model: Model, guid: str, events: bool = False) -> str:
    """The model-specific C header (:data:`C_HEADER`) included by ``satfmu_core.h``, which the
    interface's wrapper (``fmi2_cosim.c``, ``fmi2_me.c``, ``fmi3.c`` or ``fmi3_me.c``, the FMU's one
    translation unit) includes.

    Parameters
    ----------
    model : Model
    guid : str
        The native FMU's GUID (:func:`satfmu.fmus.description.fmu_guid`) or the FMI 3.0 FMU's
        instantiation token: ``MODEL_GUID``, which instantiation requires, and ``MODEL_ID``, its 16
        bytes (:func:`guid_bytes`), the identity of the FMU states.
    events : bool, optional
        Also ``NZ`` and ``model_event_indicators`` (:func:`event_function`), for model exchange,
        and for FMI 3.0 the continuous states' variables (``NG``, ``STATE_GROUPS``:
        :func:`satfmu.fmus.arrays.state_arrays`). Default False.

    Returns
    -------
    str
        The header's text.

    Raises
    ------
    ValueError
        If the model has a Python sampler (pythonfmu FMUs only).
    """
    require_c_form(model)
    pr = _C()
    table = variable_table(model)
    n = {"NX": len(model.states), "NU": len(model.inputs), "NP": len(model.parameters),
         "NY": len(model.outputs)}
    pnames = [v.name for v in model.parameters]
    lines = [f"/* Generated by satfmu from the symbolic model '{model.name}'. Do not edit.",
             " * Included by satfmu_core.h (after its VariableInfo declaration); not compiled on its own. */",
             "#ifndef SATFMU_MODEL_H", "#define SATFMU_MODEL_H",
             f"#define MODEL_IDENTIFIER {model.name}",
             f'#define MODEL_GUID "{guid}"']
    lines += [f"#define {k} {v}" for k, v in n.items()]
    lines.append(f"#define NV {len(table)}")
    lines.append(f"#define P_N_SUBSTEPS {pnames.index('n_substeps') if 'n_substeps' in pnames else -1}")
    lines.append(f"#define P_H_MAX {pnames.index('h_max') if 'h_max' in pnames else -1}")
    smp = sampler_table(model)
    lines.append(f"#define NH {smp['n_held'] if smp else 0}")
    lines.append(f"#define P_PERIOD {smp['period_index'] if smp else -1}")
    phase = smp["phase_index"] if smp else None
    lines.append(f"#define P_PHASE {-1 if phase is None else phase}")
    lines.append(f"#define EXACT {int(model.integrator == 'exact')}")
    lines.append(f"#define TIME_TOL {TIME_TOL!r} /* satfmu.fmus.model.time_tolerance: relative (times max(1, |t|)), */")
    lines.append(f"#define TIME_TOL_MAX {TIME_TOL_MAX!r} /* at most this (s), */")
    lines.append(f"#define TIME_ULPS {float(TIME_ULPS)!r} /* at least this many ulp of |t| */")
    lines.append("static double time_tolerance(double t) {")
    lines.append("    return fmax(fmin(TIME_TOL * fmax(1.0, fabs(t)), TIME_TOL_MAX), "
                 "TIME_ULPS * DBL_EPSILON * fabs(t));")
    lines.append("}")
    lines.append("static const unsigned char MODEL_ID[16] = {" + ", ".join(f"0x{b:02x}" for b in guid_bytes(guid))
                 + "}; /* in every FMU state */")
    lines.append("static const VariableInfo VARIABLES[NV] = {")
    for r in table:
        lines.append(f'    {{"{r["name"]}", {r["kind"]}, {TYPE_CODES[r["type"]]}, {r["index"]}, '
                     f'{_c_double(r["start"], "0.0")}, {_c_double(r["min"], "-INFINITY")}, '
                     f'{_c_double(r["max"], "INFINITY")}}},')
    lines.append("};")
    arrays = array_variables(model)
    lines.append("#if defined(SATFMU_FMI3) /* the FMI 3.0 variables (satfmu.fmus.arrays), value references 1.. */")
    lines.append(f"#define NA {len(arrays)}")
    lines.append("static const ArrayInfo ARRAYS[NA] = {")
    lines += [f'    {{"{a.name}", {a.first}, {a.size}}},' for a in arrays]
    lines.append("};")
    groups = _state_groups(model) if events else None
    if groups is not None:  # the FMI 3.0 model-exchange FMU's continuous states (fmi3_common.h)
        lines.append(f"#define NG {len(groups)} /* state groups: satfmu.fmus.arrays.state_arrays */")
        if groups:
            lines.append("static const ArrayInfo STATE_GROUPS[NG] = { /* name, first state, size */")
            lines += [f'    {{"{g.name}", {g.first}, {g.size}}},' for g in groups]
            lines.append("};")
    lines.append("#endif")
    if model.tables:
        lines.append("typedef struct { size_t n; const double *times, *values; int previous; } TableData;")
        for k, tb in enumerate(model.tables):
            for label, data in (("T", tb.times), ("V", tb.values)):
                lines.append(f"static const double TABLE_{k}_{label}[{len(data)}] = {{"
                             + ", ".join(repr(float(v)) for v in data) + "};")
        lines.append(f"static const TableData TABLES[{len(model.tables)}] = {{"
                     + ", ".join(f"{{{len(tb.times)}, TABLE_{k}_T, TABLE_{k}_V, {int(tb.interpolation == 'previous')}}}"
                                 for k, tb in enumerate(model.tables)) + "};")
        lines.append(_C_TABLE_LOOKUP)
    if draws_noise(model):
        lines.append(noise.C_SOURCE)
    init = _state_initial(model) or [0]
    lines.append(f"static const int STATE_INITIAL[{max(1, n['NX'])}] = {{{', '.join(map(str, init))}}};")
    sig = {"derivatives": "double t, const double *x, const double *xp, const double *u, const double *p, "
                          "double *out",
           "outputs": "double t, const double *x, const double *u, const double *p, double *out",
           "post_step": "double t, const double *x, const double *xp, const double *u, const double *p, "
                        "double *out",
           "sample_arguments": "double t, const double *x, const double *u, const double *p, double *out",
           "switch_time": "double t, const double *x, const double *u, const double *p, double *out"}
    sig["jacobian"] = sig["derivatives"]
    generated = functions(model)
    if events:
        indicators = event_function(model)
        sig["event_indicators"] = sig["derivatives"]
        lines.append(f"#define NZ {len(indicators.results)}")
        generated = generated + ([indicators] if indicators.results else []) + list(sided_functions(model))
        sig["derivatives_sided"] = ("double t, const double *x, const double *xp, const double *u, const double *p, "
                                    "const double *s, double *out")
        sig["outputs_sided"] = ("double t, const double *x, const double *u, const double *p, const double *s, "
                                "double *out")
    if model.sampler is None:  # the wrapper calls it only when NH > 0
        generated = generated + [LoweredFunction("sample_arguments", [], [])]
    if model.sampler is not None and model.sampler.c_header is not None:
        lines.append(f"#define MAX_STEP_INSTANTS {float(MAX_STEP_ROUTINE_SAMPLES)!r} "
                     "/* a routine's instants per step */")
        lines += [f"#define SAMPLER_{k.upper()} {v!r}" for k, v in model.sampler.options.items()]
        lines.append(f'#include "{model.sampler.c_header}"')
    for f in generated:
        lines.append(f"static void model_{f.name}({sig[f.name]}) {{")
        unused = {"outputs": "t x u p out", "sample_arguments": "t x u p out", "switch_time": "t x u p out",
                  "derivatives_sided": "t x xp u p s out", "outputs_sided": "t x u p s out"}.get(f.name,
                                                                                               "t x xp u p out")
        lines.append("    " + " ".join(f"(void){a};" for a in unused.split()))
        for sym, e in f.temporaries:
            lines.append(f"    const double {sym} = {pr.doprint(e)};")
        for i, e in enumerate(f.results):
            lines.append(f"    out[{i}] = {pr.doprint(e)};")
        lines.append("}")
    lines += _c_sample(model)
    lines.append("#endif /* SATFMU_MODEL_H */")
    return "\n".join(lines) + "\n"
