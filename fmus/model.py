"""Symbolic model definition: the single source of truth of every plant and law.

A :class:`Model` holds named variables (states, inputs, parameters, outputs) with
units, defaults and descriptions, and sympy expressions for the right-hand side,
the output map and an optional post-step projection (e.g. the MRP shadow set).
Everything else is generated from it:

- Python source of the same expressions (:mod:`satfmu.fmus.codegen`), used by the
  in-process reference simulation and embedded in the pythonfmu FMU;
- C source of the same expressions, compiled into the native FMU;
- the state-dependent coefficient (SDC) form ``f = A(x) x + B(x) v``, checked
  against the right-hand side symbolically and at random points;
- vectorized numpy functions (``sympy.lambdify``) for synthesis.
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Callable, Literal, Sequence

import numpy as np
import sympy as sp

from satfmu.fmus.xml_text import xml_problem
from satfmu.fmus.errors import ModelDefinitionError
from satfmu.fmus.instants import TIME_TOL, TIME_TOL_MAX, TIME_ULPS
from satfmu.fmus.table import Table
from satfmu.fmus.units import UNITS

VariableType = Literal["Real", "Integer", "Boolean"]

_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*(\[[0-9]+(,[0-9]+)*\])?$")
_IDENTIFIER = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")


@dataclass(frozen=True)
class Variable:
    """One named scalar of a model.

    Parameters
    ----------
    name : str
        FMI structured name, e.g. ``"omega[1]"``.
    unit : str
        Unit, one of :data:`satfmu.fmus.units.UNITS`.
    description : str
        Human-readable description (goes into the FMU).
    start : float
        Default value (for parameters and inputs) in ``unit``.
    type : {"Real", "Integer", "Boolean"}
        FMI base type. Integer and Boolean values enter expressions as reals
        (Boolean as 0/1).
    min, max : float, optional
        Admissible range; the FMUs reject values outside it with fmi2Error.
    """

    name: str
    unit: str = "1"
    description: str = ""
    start: float = 0.0
    type: VariableType = "Real"
    min: float | None = None
    max: float | None = None

    @property
    def symbol(self) -> sp.Symbol:
        """The sympy symbol standing for this variable in expressions."""
        return sp.Symbol(self.name, real=True)

    @property
    def base_name(self) -> str:
        """Name without the index, ``"omega"`` for ``"omega[1]"``."""
        return self.name.split("[", 1)[0]


@dataclass(frozen=True)
class State:
    """A continuous state; its initial value is the parameter ``initial``.

    Attributes
    ----------
    variable : Variable
        The state itself (name, unit, description); internal to the FMU unless an output
        carries it.
    initial : Variable
        The parameter holding the initial value (e.g. ``omega_0[1]`` of ``omega[1]``), same
        unit.
    """

    variable: Variable
    initial: Variable

    @property
    def symbol(self) -> sp.Symbol:
        return self.variable.symbol


@dataclass(frozen=True)
class Output:
    """An output variable and the expression that computes it.

    Attributes
    ----------
    variable : Variable
        The FMU output variable.
    expression : sympy.Expr
        Its value, in the model's time, state, input, parameter, held and defined symbols.
    """

    variable: Variable
    expression: sp.Expr


@dataclass(frozen=True)
class SDCForm:
    """State-dependent coefficient form ``f(x, v) = A(x) x + B(x) v``.

    ``inputs`` names the model inputs forming ``v``; ``assumptions`` substitutes
    parameters (e.g. saturation off) under which the identity holds.

    Attributes
    ----------
    A : sympy.Matrix
        ``A(x)``, shape (nx, nx), in the model's state and parameter symbols.
    B : sympy.Matrix
        ``B(x)``, shape (nx, nv), in the model's state and parameter symbols.
    inputs : tuple of str
        Names of the model inputs forming ``v``, in the column order of ``B``.
    assumptions : dict of str to float, optional
        Parameter values (by name) under which ``f = A x + B v`` holds, e.g.
        ``{"saturation_on": 0.0}``. Default none.
    """

    A: sp.Matrix
    B: sp.Matrix
    inputs: tuple[str, ...]
    assumptions: dict[str, float] = field(default_factory=dict)


@dataclass(frozen=True)
class Sampler:
    """Values held between sample instants and computed at them (a zero-order hold).

    The instants are the start time and every time ``t`` with ``t + phase`` a multiple of
    the period (without a phase: ``start + k * period``). At each instant the FMU evaluates
    ``arguments`` at the current time, state, inputs, parameters and held values (the
    ones of the previous instant) and holds the result until the next instant:

    - an *expression sampler* (no ``module``): the held values ARE the arguments, one
      expression each. Native and pythonfmu FMUs (a periodic gain schedule, a sampled
      B-dot law);
    - a *routine sampler*: a routine computes the held values from the arguments (an online
      SDRE law holds its gain this way: the Riccati solve is no expression). Its Python form,
      ``function(arguments, **options)`` of the module file ``module``, runs in pythonfmu
      FMUs and in process; its C form, ``c_function`` of the header ``c_header`` in
      ``fmus/c/``, in native FMUs (a model without it has no native FMU). The two are twins
      that the tests hold to a stated agreement.

    The expressions of the model read the held values through the symbols of ``held``.

    Parameters
    ----------
    held : list of Variable
        The held values (internal; expose one through an output to show it).
    arguments : list of sympy.Expr
        Expressions in the model's time, state, input and parameter symbols and the held
        values' symbols.
    period : str
        Name of the model parameter giving the sample period, s.
    module : str, optional
        Path of a Python file that imports only the standard library, numpy and scipy; it
        is embedded in the FMU.
    function : str, optional
        Name of the function in ``module``; it returns ``len(held)`` numbers and raises
        on failure (the FMU then reports fmi2Error with the message).
    options : dict
        Keyword arguments of the call (plain data).
    phase : str, optional
        Name of the model parameter giving the phase of the instants, s (an orbit time at
        ``t = 0``, say, so that the instants fall on orbit times ``k * period``).
    c_header : str, optional
        File name, in ``fmus/c/``, of the C header defining ``c_function``; a native FMU
        carries it in ``sources/``. Its code reads the options as macros ``SAMPLER_<KEY>``
        (upper case, integer or float values).
    c_function : str, optional
        Name of the C routine, ``int f(const double *arguments, double *held, char *message,
        size_t size)``: it writes ``len(held)`` numbers and returns 1, or returns 0 with a
        message (the FMU then reports fmi2Error with it, as the Python form's exception).
    """

    held: list[Variable]
    arguments: list[sp.Expr]
    period: str
    module: str | None = None
    function: str | None = None
    options: dict = field(default_factory=dict)
    phase: str | None = None
    c_header: str | None = None
    c_function: str | None = None

    @property
    def is_expression(self) -> bool:
        """Whether the held values are the arguments themselves (no routine)."""
        return self.module is None and self.c_function is None

    @property
    def has_c_form(self) -> bool:
        """Whether a native FMU can sample it (an expression sampler or a C routine)."""
        return self.is_expression or self.c_function is not None

    @property
    def c_header_path(self) -> Path | None:
        """The C header's file (in ``fmus/c/``), or None."""
        return None if self.c_header is None else Path(__file__).resolve().parent / "c" / self.c_header

    def load(self) -> Callable[..., list[float]]:
        """The function itself, ``values -> held`` with the options bound (in-process use)."""
        import functools
        import importlib.util

        if self.module is None:
            return list
        if self.function is None:
            raise ModelDefinitionError(f"sampler module {self.module!r}: no function named")
        spec = importlib.util.spec_from_file_location(f"satfmu_sampler_{id(self)}", self.module)
        if spec is None or spec.loader is None:
            raise ModelDefinitionError(f"sampler module {self.module!r} cannot be loaded")
        mod = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(mod)
        return functools.partial(getattr(mod, self.function), **self.options)


def time_tolerance(t: sp.Expr) -> sp.Expr:
    """The time tolerance at time ``t`` (a sympy expression), s:
    ``max(min(TIME_TOL max(1, |t|), TIME_TOL_MAX), TIME_ULPS eps |t|)`` with eps = 2^-52.

    Parameters
    ----------
    t : sympy.Expr
        The time, s.

    Returns
    -------
    sympy.Expr
        The tolerance, s.
    """
    return sp.Max(sp.Min(TIME_TOL * sp.Max(1, sp.Abs(t)), TIME_TOL_MAX), TIME_ULPS * 2.0**-52 * sp.Abs(t))


class TableLookup(sp.Function):
    """``TableLookup(k, t)``: the model's table ``k`` (``Model.tables``) at ``t``."""

    nargs = 2


#: Parameters every model with states gets, read by the integrators of both FMU backends.
INTEGRATOR_PARAMETERS = (
    Variable("n_substeps", "1", "Minimum number of RK4 substeps per communication step",
             start=4, type="Integer", min=1, max=100000),
    Variable("h_max", "s", "Largest RK4 substep; more substeps are taken when the "
             "communication step divided by n_substeps exceeds it", start=0.0125,
             min=1e-9, max=1e6),
)


@dataclass
class Model:
    """A symbolic model: the one definition from which every artifact is generated.

    Parameters
    ----------
    name : str
        Identifier (also the native FMU's modelIdentifier), e.g. ``"mrp_satellite"``.
    description : str
        One-line description.
    states : list of State
    inputs : list of Variable
    parameters : list of Variable
        Physical constants and switches; state initial values and the integrator
        parameters are appended automatically.
    outputs : list of Output
    rhs : sympy.Matrix
        Time derivative of the states, in terms of state, input and parameter
        symbols (and ``t``).
    post_step : sympy.Matrix, optional
        State map applied after every integration substep (projection, switching,
        stopping an axis in stiction).

    The right-hand side and the post-step map may also use the state at the start of
    the integration substep, :meth:`previous`: a piecewise law (a friction mode, say)
    frozen over the substep, and a zero crossing detected against the substep's start.
    In the outputs it stands for the current state.
    sdc : SDCForm, optional
    definitions : list of (sympy.Symbol, sympy.Expr)
        Named intermediate quantities in evaluation order; later definitions and all
        expressions above may use their symbols. Code generation emits each once (a
        stick-slip friction law, say, shared by the right-hand side, the outputs and the
        post-step map), which keeps large piecewise laws small and fast to build.
    default_stop_time, default_step_size : float
        DefaultExperiment of the FMU, s.
    default_h_max : float
        Default of the ``h_max`` parameter (largest RK4 substep), s.
    sampler : Sampler, optional
        Values computed by a Python function at sample instants and held in between.
    integrator : {"rk4", "exact"}
        ``"rk4"``: classical RK4 substeps (parameters ``n_substeps``, ``h_max``).
        ``"exact"``: the right-hand side is affine in the state once the substep-start
        state (:meth:`previous`) is frozen, ``x' = A x + b`` with ``A`` and ``b`` constant
        over the substep (no ``t``), and every step is the exact flow
        ``x(h) = e^{A h} x + (integral_0^h e^{A s} ds) b`` (a linear plant with inputs held
        over a communication step is then exact for any step size).
    tables : list of Table
        Time tables the expressions read as ``TableLookup(k, t)`` (``k`` indexes this list);
        the data is compiled into the FMU.
    switch_time : sympy.Expr, optional
        With ``integrator="exact"``: the time, s, from the substep start (state ``x``,
        inputs held) at which the frozen piecewise law stops being valid (a momentum
        integrator reaching its bound, say), ``oo`` when never; the step is cut there and
        continues with the law of the new substep start, so the switch is exact too.
    driven_inputs : tuple of str
        Names of the inputs a co-simulation must drive (connect or feed from a profile): a
        controller's, a sensor's or an estimator's measurements, whose start value is no
        meaningful default. The FMU lists them in its ``VendorAnnotations``
        (:func:`satfmu.fmus.annotations.driven_inputs`); a scenario leaving one undriven is refused.
        Default none (a plant's torques and disturbances may stay at their start values).
    """

    name: str
    description: str
    states: list[State]
    inputs: list[Variable]
    parameters: list[Variable]
    outputs: list[Output]
    rhs: sp.Matrix = field(default_factory=lambda: sp.zeros(0, 1))
    post_step: sp.Matrix | None = None
    sdc: SDCForm | None = None
    definitions: list[tuple[sp.Symbol, sp.Expr]] = field(default_factory=list)
    default_stop_time: float = 10.0
    default_step_size: float = 0.05
    default_h_max: float = 0.0125
    sampler: Sampler | None = None
    integrator: Literal["rk4", "exact"] = "rk4"
    switch_time: sp.Expr | None = None
    tables: list[Table] = field(default_factory=list)
    driven_inputs: tuple[str, ...] = ()

    t = sp.Symbol("t", real=True)

    def __post_init__(self) -> None:
        self.parameters = list(self.parameters) + [s.initial for s in self.states]
        if self.states and self.integrator == "rk4":
            n_sub, h_max = INTEGRATOR_PARAMETERS
            self.parameters += [n_sub, replace(h_max, start=self.default_h_max)]
        self.rhs = sp.Matrix(self.rhs)
        self._validate()

    # ------------------------------------------------------------------ checks
    def _validate(self) -> None:
        if not _IDENTIFIER.match(self.name):
            raise ModelDefinitionError(f"model name {self.name!r} is not a C identifier (it is the FMU's "
                                       "modelIdentifier)")
        for where, text in [("description", self.description)] + [(f"variable {v.name!r}: description", v.description)
                                                                   for v in self.variables]:
            problem = xml_problem(text)
            if problem:
                raise ModelDefinitionError(f"{self.name}: {where} {problem}, which a model description "
                                           "(XML 1.0) cannot carry")
        fmu_names = [v.name for v in self.variables]
        # States are internal; an output may carry a state's name, nothing else may.
        symbol_names = [v.name for v in self.parameters + self.inputs] + [s.variable.name for s in self.states]
        for names in (fmu_names, symbol_names):
            for n in names:
                if not _NAME.match(n):
                    raise ModelDefinitionError(f"{self.name}: invalid variable name {n!r}")
            dup = {n for n in names if names.count(n) > 1}
            if dup:
                raise ModelDefinitionError(f"{self.name}: duplicate variable names {sorted(dup)}")
        unknown = sorted(set(self.driven_inputs) - {v.name for v in self.inputs})
        if unknown:
            raise ModelDefinitionError(f"{self.name}: driven_inputs {unknown} are not inputs of the model")
        for v in self.variables:
            if v.unit not in UNITS:
                raise ModelDefinitionError(f"{self.name}: variable {v.name!r} has unknown unit {v.unit!r}")
        if self.rhs.shape != (len(self.states), 1):
            raise ModelDefinitionError(
                f"{self.name}: rhs has shape {self.rhs.shape}, expected ({len(self.states)}, 1)")
        if self.post_step is not None and sp.Matrix(self.post_step).shape != self.rhs.shape:
            raise ModelDefinitionError(f"{self.name}: post_step must have one entry per state")
        base = set(self.state_symbols + self.input_symbols + self.parameter_symbols + [self.t])
        allowed = base | set(self.previous_symbols) | set(self.held_symbols)
        if self.sampler is not None:
            smp = self.sampler
            for label, pname in (("period", smp.period), ("phase", smp.phase)):
                if pname is not None and pname not in [v.name for v in self.parameters]:
                    raise ModelDefinitionError(f"{self.name}: sampler {label} {pname!r} is no parameter")
            if (smp.module is None) != (smp.function is None):
                raise ModelDefinitionError(f"{self.name}: a sampler needs both module and function, or neither")
            if (smp.c_header is None) != (smp.c_function is None):
                raise ModelDefinitionError(f"{self.name}: a sampler needs both c_header and c_function, or neither")
            if smp.c_function is not None and smp.module is None:
                raise ModelDefinitionError(f"{self.name}: a C sampler routine needs its Python twin (module and "
                                           "function) for pythonfmu FMUs and in-process use")
            if smp.c_header_path is not None and not smp.c_header_path.is_file():
                raise ModelDefinitionError(f"{self.name}: sampler C header {smp.c_header!r} is not in fmus/c/")
            bad = [k for k, v in smp.options.items()
                   if not (k.isidentifier() and isinstance(v, (int, float)) and not isinstance(v, bool))]
            if smp.c_function is not None and bad:
                raise ModelDefinitionError(f"{self.name}: C sampler options must be named numbers, not {bad}")
            if smp.is_expression and len(smp.arguments) != len(smp.held):
                raise ModelDefinitionError(f"{self.name}: an expression sampler needs one argument per held "
                                           f"value ({len(smp.arguments)} for {len(smp.held)})")
            clash = {v.name for v in self.sampler.held} & set(fmu_names + symbol_names)
            if clash:
                raise ModelDefinitionError(f"{self.name}: held values reuse names {sorted(clash)}")
            defined = {sym for sym, _ in self.definitions}  # evaluated at the instant, like the arguments
            for e in self.sampler.arguments:
                extra = sp.sympify(e).free_symbols - base - set(self.held_symbols) - defined
                if extra:
                    raise ModelDefinitionError(
                        f"{self.name}: sampler argument uses undeclared symbols {sorted(map(str, extra))}")
        for sym, e in self.definitions:
            extra = sp.sympify(e).free_symbols - allowed
            if extra:
                raise ModelDefinitionError(
                    f"{self.name}: definition {sym} uses undeclared symbols {sorted(map(str, extra))}")
            if sym in allowed:
                raise ModelDefinitionError(f"{self.name}: definition {sym} redefines a symbol")
            allowed.add(sym)
        post = list(self.post_step) if self.post_step is not None else []
        switch = [self.switch_time] if self.switch_time is not None else []
        smp_args = list(self.sampler.arguments) if self.sampler is not None else []
        for e in list(self.rhs) + [o.expression for o in self.outputs] + post + switch:
            extra = sp.sympify(e).free_symbols - allowed
            if extra:
                raise ModelDefinitionError(
                    f"{self.name}: expression uses undeclared symbols {sorted(map(str, extra))}")
        for e in list(self.rhs) + [o.expression for o in self.outputs] + post + switch + smp_args + [
                d for _, d in self.definitions]:
            for call in sp.sympify(e).atoms(TableLookup):
                k = call.args[0]
                if not (k.is_Integer and 0 <= int(k) < len(self.tables)):
                    raise ModelDefinitionError(f"{self.name}: {call} reads no table of the model "
                                               f"({len(self.tables)} tables)")
        self._validate_integrator()

    def _validate_integrator(self) -> None:
        if self.integrator not in ("rk4", "exact"):
            raise ModelDefinitionError(f"{self.name}: unknown integrator {self.integrator!r}")
        if self.integrator == "rk4":
            if self.switch_time is not None:
                raise ModelDefinitionError(f"{self.name}: switch_time needs integrator='exact'")
            return
        x = set(self.state_symbols)
        for sym, e in self.definitions:
            if self.free_symbols(sym) & (x | {self.t}):
                raise ModelDefinitionError(f"{self.name}: with integrator='exact' the definitions may not "
                                           f"depend on the state or time ({sym} does)")
        if self.t in set().union(*(sp.sympify(e).free_symbols for e in self.rhs)):
            raise ModelDefinitionError(f"{self.name}: with integrator='exact' the right-hand side may not "
                                       "depend on time")
        jac = self.jacobian
        if any(s in x for e in jac for s in sp.sympify(e).free_symbols):
            raise ModelDefinitionError(f"{self.name}: with integrator='exact' the right-hand side must be "
                                       "affine in the state (the substep-start state frozen)")

    @property
    def jacobian(self) -> sp.Matrix:
        """``d rhs / d x`` (the substep-start state and definitions held fixed), row-major."""
        cached = self.__dict__.get("_jacobian")
        if cached is None:
            cached = self.__dict__["_jacobian"] = self.rhs.jacobian(self.state_symbols)
        return cached

    # --------------------------------------------------------------- accessors
    @property
    def variables(self) -> list[Variable]:
        """FMU variables in value-reference order: parameters, inputs, outputs."""
        return list(self.parameters) + list(self.inputs) + [o.variable for o in self.outputs]

    @property
    def state_symbols(self) -> list[sp.Symbol]:
        return [s.symbol for s in self.states]

    @property
    def previous_symbols(self) -> list[sp.Symbol]:
        """Symbols of the state at the start of the integration substep (see :meth:`previous`)."""
        return [self.previous(s.variable.name) for s in self.states]

    @staticmethod
    def previous(state_name: str) -> sp.Symbol:
        """The symbol of state ``state_name`` at the start of the integration substep.

        Parameters
        ----------
        state_name : str
            Name of the state variable (``"omega[1]"``).

        Returns
        -------
        sympy.Symbol
            The real symbol ``previous(<state_name>)``.
        """
        return sp.Symbol(f"previous({state_name})", real=True)

    @property
    def held_symbols(self) -> list[sp.Symbol]:
        """Symbols of the sampler's held values (none without a sampler)."""
        return [v.symbol for v in self.sampler.held] if self.sampler is not None else []

    @property
    def input_symbols(self) -> list[sp.Symbol]:
        return [v.symbol for v in self.inputs]

    @property
    def parameter_symbols(self) -> list[sp.Symbol]:
        return [v.symbol for v in self.parameters]

    def parameter_defaults(self) -> np.ndarray:
        """Default parameter vector (Booleans as 0/1), in parameter order."""
        return np.array([float(v.start) for v in self.parameters])

    def input_defaults(self) -> np.ndarray:
        """Default input vector (start values, Booleans as 0/1), in input order."""
        return np.array([float(v.start) for v in self.inputs])

    def parameter_vector(self, overrides: dict[str, float] | None = None) -> np.ndarray:
        """Parameter vector with named overrides.

        Parameters
        ----------
        overrides : dict of str to float, optional
            Values by parameter name, replacing the defaults (each in its parameter's unit).

        Returns
        -------
        numpy.ndarray, shape (n_parameters,)
            The values in parameter order (Booleans as 0/1).

        Raises
        ------
        KeyError
            If an override names no parameter of this model.
        """
        p = self.parameter_defaults()
        index = {v.name: i for i, v in enumerate(self.parameters)}
        for k, val in (overrides or {}).items():
            if k not in index:
                raise KeyError(f"model {self.name!r} has no parameter {k!r}")
            p[index[k]] = float(val)
        return p

    def initial_state(self, p: np.ndarray) -> np.ndarray:
        """Initial state read from the parameter vector ``p``.

        Parameters
        ----------
        p : numpy.ndarray, shape (n_parameters,)
            Parameter vector (:meth:`parameter_vector`), holding each state's initial-value
            parameter.

        Returns
        -------
        numpy.ndarray, shape (n_states,)
            The initial state, in state order.
        """
        index = {v.name: i for i, v in enumerate(self.parameters)}
        return np.array([p[index[s.initial.name]] for s in self.states])

    def used_definitions(self, exprs: Sequence[sp.Expr],
                         definitions: Sequence[tuple[sp.Symbol, sp.Expr]] | None = None
                         ) -> list[tuple[sp.Symbol, sp.Expr]]:
        """The ``definitions`` that ``exprs`` use, directly or through other definitions.

        Parameters
        ----------
        exprs : sequence of sympy.Expr
            Expressions in the model's symbols.
        definitions : sequence of (sympy.Symbol, sympy.Expr), optional
            The definitions to follow: default the model's own; another form of them (the same
            symbols in the same order, other expressions, as
            :func:`satfmu.fmus.events.sided` gives).

        Returns
        -------
        list of (sympy.Symbol, sympy.Expr)
            Those definitions, in definition order (each after the ones it uses).
        """
        definitions = self.definitions if definitions is None else definitions
        needed: set[sp.Basic] = set().union(*(sp.sympify(e).free_symbols for e in exprs))
        for sym, e in reversed(definitions):
            if sym in needed:
                needed |= sp.sympify(e).free_symbols
        return [(sym, e) for sym, e in definitions if sym in needed]

    def free_symbols(self, expr: sp.Expr) -> set[sp.Symbol]:
        """Free symbols of ``expr`` with ``definitions`` and held values followed to the
        variables they use (a held value is sampled from the inputs of its instant).

        Parameters
        ----------
        expr : sympy.Expr
            An expression in the model's symbols.

        Returns
        -------
        set of sympy.Symbol
            Time, state, previous-state, input and parameter symbols it depends on.
        """
        def expanded(symbols: set[sp.Symbol]) -> set[sp.Symbol]:
            for sym, e in reversed(self.definitions):
                if sym in symbols:
                    symbols = (symbols - {sym}) | sp.sympify(e).free_symbols
            return symbols

        free = expanded(set(sp.sympify(expr).free_symbols))
        held = set(self.held_symbols)
        if free & held:
            free -= held
            for e in self.sampler.arguments:  # type: ignore[union-attr]
                free |= expanded(set(sp.sympify(e).free_symbols)) - held
        return free

    def output_dependencies(self) -> dict[str, list[str]]:
        """For each output, the inputs it depends on directly (feedthrough)."""
        return {o.variable.name: [v.name for v in self.inputs if v.symbol in self.free_symbols(o.expression)]
                for o in self.outputs}

    def initial_output_dependencies(self) -> dict[str, list[str]]:
        """For each output, the inputs and parameters it depends on at initialization."""
        x0 = {s.symbol: s.initial.symbol for s in self.states}
        known = self.parameters + self.inputs
        deps = {}
        for o in self.outputs:
            free = {x0.get(s, s) for s in self.free_symbols(o.expression)}
            deps[o.variable.name] = [v.name for v in known if v.symbol in free]
        return deps

    # --------------------------------------------------------------- numerics
    def lambdify(self, exprs: sp.Matrix | Sequence[sp.Expr]) -> Callable[..., np.ndarray]:
        """Vectorized numpy function ``f(t, x, u, p)`` of expressions in this model's symbols.

        Parameters
        ----------
        exprs : sympy.Matrix or sequence of sympy.Expr
            Expressions in the model's time, state, input and parameter symbols (and
            ``TableLookup`` of its tables).

        Returns
        -------
        callable
            ``f(t, x, u, p)``, returning the expressions' values as a column matrix.

        Raises
        ------
        ModelDefinitionError
            If the model has ``definitions`` (use :func:`satfmu.fmus.codegen.load_python`).
        """
        if self.definitions:
            raise ModelDefinitionError(f"model {self.name!r} has definitions; evaluate it with the "
                                       "generated code (satfmu.fmus.codegen.load_python)")
        args = (self.t, self.state_symbols, self.input_symbols, self.parameter_symbols)
        tables = {"TableLookup": lambda k, t: self.tables[int(k)].evaluate(t)}
        return sp.lambdify(args, sp.Matrix(exprs), modules=[tables, "numpy"], cse=True)

    def sdc_functions(self, sdc: SDCForm | None = None
                      ) -> tuple[Callable[..., np.ndarray], Callable[..., np.ndarray]]:
        """Numpy functions ``A(x, p)`` and ``B(x, p)`` of the SDC form (default: ``sdc``).

        Parameters
        ----------
        sdc : SDCForm, optional
            The form to evaluate; default the model's own ``sdc``.

        Returns
        -------
        A, B : callable
            Functions of the state and parameter vectors.

        Raises
        ------
        ModelDefinitionError
            If no form is given and the model declares none.
        """
        sdc = sdc or self._require_sdc()
        args = (self.state_symbols, self.parameter_symbols)
        return (sp.lambdify(args, sdc.A, modules="numpy", cse=True),
                sp.lambdify(args, sdc.B, modules="numpy", cse=True))

    def sdc_residual_symbolic(self, sdc: SDCForm | None = None) -> sp.Matrix:
        """``A(x) x + B(x) v - f(x, u)`` simplified; zero when the SDC form is exact.

        ``sdc`` checks another factorization of this model than its own.

        Parameters
        ----------
        sdc : SDCForm, optional
            The form to check; default the model's own ``sdc``.

        Returns
        -------
        sympy.Matrix
            The residual (nx x 1), under the form's assumptions.
        """
        sdc = sdc or self._require_sdc()
        subs = {sp.Symbol(k, real=True): v for k, v in sdc.assumptions.items()}
        v = sp.Matrix([sp.Symbol(n, real=True) for n in sdc.inputs])
        x = sp.Matrix(self.state_symbols)
        return sp.simplify(sdc.A * x + sdc.B * v - self.expand(self.rhs.subs(subs), subs))

    def expand(self, expr: sp.Basic, subs: dict | None = None) -> sp.Basic:
        """``expr`` with the ``definitions`` it uses substituted (each after ``subs``).

        Parameters
        ----------
        expr : sympy.Basic
            An expression in the model's symbols.
        subs : dict, optional
            Substitutions (symbol to value) applied to each definition before it replaces its
            symbol.

        Returns
        -------
        sympy.Basic
            The expression with no defined symbol left.
        """
        for sym, e in reversed(self.definitions):
            if sym in expr.free_symbols:
                expr = expr.xreplace({sym: sp.sympify(e).subs(subs or {})})
        return expr

    def sdc_residual_sampled(self, n_points: int = 200, scale: float = 1.0,
                             seed: int = 0, sdc: SDCForm | None = None) -> float:
        """Largest ``|A(x) x + B(x) v - f(x, u)|`` over random points (state, inputs ~ N(0, scale^2)).

        Parameters
        ----------
        n_points : int, optional
            Number of random points. Default 200.
        scale : float, optional
            Standard deviation of every state and input component at the points (in their
            units). Default 1.
        seed : int, optional
            Seed of the random generator. Default 0.
        sdc : SDCForm, optional
            The form to check; default the model's own ``sdc``.

        Returns
        -------
        float
            The largest absolute residual of any component, in the units of the derivatives.
        """
        sdc = sdc or self._require_sdc()
        rng = np.random.default_rng(seed)
        p = self.parameter_vector(sdc.assumptions)
        A, B = self.sdc_functions(sdc)
        from satfmu.fmus.codegen import load_python  # codegen imports this module

        f = load_python(self).derivatives
        in_index = [[v.name for v in self.inputs].index(n) for n in sdc.inputs]
        worst = 0.0
        for _ in range(n_points):
            x = rng.normal(0.0, scale, len(self.states))
            u = rng.normal(0.0, scale, len(self.inputs))
            lhs = np.asarray(A(x, p), float) @ x + np.asarray(B(x, p), float) @ u[in_index]
            fx = f(0.0, list(x), list(x), list(u), list(p))
            worst = max(worst, float(np.max(np.abs(lhs - np.asarray(fx, float)))))
        return worst

    def _require_sdc(self) -> SDCForm:
        if self.sdc is None:
            raise ModelDefinitionError(f"model {self.name!r} declares no SDC form")
        return self.sdc


class Definitions(list):
    """Collects ``Model.definitions``: ``d("name", expr)`` records and returns a new symbol.

    ``d.flag("name", condition)`` defines a 0/1 number for a condition; test it with
    :func:`is_set` in later conditions (conditions on small symbols keep sympy fast).

    Parameters
    ----------
    iterable : iterable of tuple of (sympy.Symbol, sympy.Expr), optional
        Definitions to start with (as ``list`` takes them); normally none.
    """

    def __call__(self, name: str, expr: sp.Expr) -> sp.Symbol:
        sym = sp.Symbol(name, real=True)
        self.append((sym, sp.sympify(expr)))
        return sym

    def flag(self, name: str, condition: sp.Basic) -> sp.Symbol:
        """Record ``name`` as the 0/1 number of ``condition`` and return its symbol.

        Parameters
        ----------
        name : str
            Name of the new symbol.
        condition : sympy.Basic
            A sympy condition (relational or boolean).

        Returns
        -------
        sympy.Symbol
            The flag, 1 where the condition holds, else 0 (test it with :func:`is_set`).
        """
        return self(name, sp.Piecewise((1, condition), (0, True), evaluate=False))

    def vector(self, name: str, values: sp.Matrix) -> sp.Matrix:
        """Record each entry of ``values`` as ``name_0``, ``name_1``, ... and return their symbols.

        Parameters
        ----------
        name : str
            Base name of the new symbols.
        values : sympy.Matrix
            The expressions, n x 1.

        Returns
        -------
        sympy.Matrix
            The symbols, n x 1.
        """
        return sp.Matrix([self(f"{name}_{i}", v) for i, v in enumerate(values)])


def is_set(flag: sp.Expr) -> sp.Basic:
    """The condition "0/1 flag is 1".

    Parameters
    ----------
    flag : sympy.Expr
        A 0/1 flag (:meth:`Definitions.flag`) or a Boolean parameter's symbol.

    Returns
    -------
    sympy.Basic
        ``flag > 1/2``.
    """
    return flag > sp.Rational(1, 2)


def vector(base: str, n: int, unit: str, description: str, start: Sequence[float] | float = 0.0,
           **kwargs: object) -> list[Variable]:
    """``n`` variables ``base[1]`` to ``base[n]`` with a common unit and description.

    ``description`` may contain ``{i}`` for the 1-based index.

    Parameters
    ----------
    base : str
        Name of the vector; the variables are ``base[1]`` to ``base[n]``.
    n : int
        Number of variables.
    unit : str
        Their unit, one of :data:`satfmu.fmus.units.UNITS`.
    description : str
        Their description, a format string that may use ``{i}``.
    start : float or sequence of float, optional
        Start value of all, or one per variable (in ``unit``). Default 0.
    **kwargs
        Further fields of every :class:`Variable` (``type``, ``min``, ``max``).

    Returns
    -------
    list of Variable
    """
    starts = [start] * n if isinstance(start, (int, float, np.number)) else list(start)
    if len(starts) != n:
        raise ModelDefinitionError(f"{base}: {len(starts)} start values for {n} variables")
    return [Variable(f"{base}[{i + 1}]", unit, description.format(i=i + 1), float(starts[i]), **kwargs)  # type: ignore[arg-type]
            for i in range(n)]


def states(base: str, n: int, unit: str, description: str,
           start: Sequence[float] | float = 0.0) -> list[State]:
    """``n`` states ``base[i]`` whose initial values are parameters ``base_0[i]``.

    Parameters
    ----------
    base : str
        Name of the state vector.
    n : int
        Number of states.
    unit : str
        Their unit, one of :data:`satfmu.fmus.units.UNITS` (also the initial values').
    description : str
        Their description (may use ``{i}``); the initial values' is "Initial value of " + it.
    start : float or sequence of float, optional
        Default initial value of all, or one per state (in ``unit``). Default 0.

    Returns
    -------
    list of State
    """
    var = vector(base, n, unit, description)
    init = vector(f"{base}_0", n, unit, "Initial value of " + description, start)
    return [State(v, i) for v, i in zip(var, init)]


def symbols(variables: Sequence[Variable | State]) -> sp.Matrix:
    """Column matrix of the symbols of ``variables``.

    Parameters
    ----------
    variables : sequence of Variable or State
        The variables, in order.

    Returns
    -------
    sympy.Matrix
        Their symbols, ``len(variables)`` x 1.
    """
    return sp.Matrix([v.symbol for v in variables])


def saturate(u: sp.Expr, limit: sp.Expr, enabled: sp.Expr) -> sp.Expr:
    """``clip(u, -limit, limit)`` when the Boolean parameter ``enabled`` is true (> 1/2).

    Parameters
    ----------
    u : sympy.Expr
        The value to clip (a commanded torque, say).
    limit : sympy.Expr
        The limit, in the unit of ``u`` (>= 0).
    enabled : sympy.Expr
        Symbol of the Boolean parameter switching the saturation on.

    Returns
    -------
    sympy.Expr
        A piecewise expression.
    """
    return sp.Piecewise((sp.Max(-limit, sp.Min(limit, u)), enabled > sp.Rational(1, 2)), (u, True))
