"""Fixed-step co-simulation master for FMI 2.0 and FMI 3.0 co-simulation FMUs, built on fmpy.

The master loads N FMUs, connects outputs to inputs by name (``"plant.omega[1]"``,
or a base name such as ``"plant.omega"`` that expands to every index), feeds
profiles to inputs, and steps all FMUs at one communication step:

1. instantiate, set parameters, ``fmi2SetupExperiment``, enter initialization mode;
2. apply profile values at t0 and propagate outputs to inputs in feedthrough order,
   variable by variable (an output that depends directly on an input is copied after
   the connection feeding that input; a cycle of such variables is an algebraic loop
   and is refused);
3. exit initialization mode, record t0;
4. for each step: ``fmi2DoStep`` on every FMU, then profiles and propagation at the
   new time, then record.

Inputs are therefore held constant over each communication step (zero-order hold).

``exchange_order="jacobi"`` instead reads every connected output first and then sets every
input after each step, as libcosim and ecos do: a direct-feedthrough output (a static
controller) then passes on a value computed from the inputs of the previous communication
point, a delay of one step. The default order has no such delay; the Jacobi order reproduces
another engine's run (:mod:`satfmu.sims.interop.verify`). The recorded value of such an output is the one
computed from the new inputs, in either order.
Value references and ctypes buffers are prepared once; each step makes one
``fmi2GetReal``/``fmi2SetReal`` call per FMU and direction.

An FMI 3.0 FMU takes part as its FMI 2.0 scalars (:mod:`satfmu.sims.cosim.instances`: the
array ``sigma`` is ``sigma[1]`` .. ``sigma[3]``, set whole); its periodic input clocks (a
sampled controller's) are driven in Event Mode. At a communication point that is one of its
clock instants the master enters its Event Mode before it sets any input there, activates the
clocks just before it first reads one of its outputs (after the inputs in feedthrough order,
after every read in Jacobi order) and leaves Event Mode before it records the point; a step
containing an instant is split there. The samples are then those of its FMI 2.0 twin in the
same wiring, bit for bit. A co-simulation with an FMI 3.0 FMU steps in the Python loop.
"""
from __future__ import annotations

import ctypes
import math
import shutil
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

import numpy as np
from fmpy.fmi1 import FMICallException
from threadpoolctl import ThreadpoolController

from satfmu.fmus.declared import did_you_mean
from satfmu.fmus.profiles import Profile
from satfmu.sims.cosim import fmi_host
from satfmu.sims.cosim.instances import Fmi3Instance, Instance, open_instance
from satfmu.fmus.errors import FmuCallError, MasterError, UnknownVariableError, WiringError


ONE_THREAD = 1
"""BLAS and OpenMP threads of the host process while FMUs step. Measured on 2 cores
(``satfmu run vscmg_seed`` with its online SDRE controllers as pythonfmu FMUs, which solve a
7-state Riccati equation per 0.01 s sample through the host's numpy/scipy): 10.1-11.5 s CPU with OpenBLAS's
default threads, 6.0-6.3 s with one, the same wall time."""


def start_value(comp: "Component", name: str, value: Any) -> tuple[Any, float | int | bool]:
    """The variable ``name`` of ``comp`` and ``value`` checked against its causality (parameter
    or input) and type (Real, Integer, Boolean), converted to that type.

    Parameters
    ----------
    comp : Component
        The FMU instance.
    name : str
        Name of the variable in the FMU (``"J[1,1]"``, ``"saturation_on"``).
    value : float, int or bool
        The value to set, in the variable's declared unit: a number for a Real, an int for an
        Integer, a bool for a Boolean.

    Returns
    -------
    variable : fmpy.model_description.ScalarVariable
        The variable.
    value : float, int or bool
        ``value`` converted to the variable's type.

    Raises
    ------
    UnknownVariableError, WiringError
    """
    var = comp.variable(name)
    if var.causality not in ("parameter", "input"):
        raise WiringError(f"{comp.name}.{name} is a {var.causality}; only parameters and inputs can be set")
    if var.type == "Real":
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise WiringError(f"{comp.name}.{name} is Real; got {value!r}")
        return var, float(value)
    if var.type == "Integer":
        if isinstance(value, bool) or not isinstance(value, int):
            raise WiringError(f"{comp.name}.{name} is Integer; got {value!r}")
        return var, value
    if var.type == "Boolean":
        if not isinstance(value, bool):
            raise WiringError(f"{comp.name}.{name} is Boolean; got {value!r} (use true/false)")
        return var, value
    raise WiringError(f"{comp.name}.{name}: type {var.type} is not supported")


ENGINES = ("auto", "compiled", "python")
"""Who runs the step loop (:meth:`CoSimulation.run`)."""


def recorded_steps(n_steps: int, record_every: int) -> np.ndarray:
    """The communication points recorded when every ``record_every``-th is: 0, m, 2m, ... and the
    last, ``n_steps`` (the compiled loop's rule, ``sims/cosim/c/cosim_loop.c``).

    Parameters
    ----------
    n_steps : int
        Number of communication steps of the run (points 0 ... ``n_steps``).
    record_every : int
        Record every ``record_every``-th point (>= 1).

    Returns
    -------
    numpy.ndarray
        The indices of the recorded points, increasing.
    """
    steps = np.arange(0, n_steps + 1, record_every)
    return steps if steps[-1] == n_steps else np.append(steps, n_steps)


def _rows_through(point: int, n_steps: int, record_every: int) -> int:
    """How many of the recorded points (:func:`recorded_steps`) are at or before ``point``."""
    return point // record_every + 1 + int(point == n_steps and n_steps % record_every != 0)


class _Points:
    """Times and profile values at the communication points ``first .. last`` of a run: all of
    them, or (streamed) those of one block of steps at a time, so that a run holds no array as
    long as itself.

    Parameters
    ----------
    start_time, step_size : float
        s.
    profiles : dict of str to list of Profile
        Per FMU instance, the profiles driving its inputs (in the order of its value references).
    """

    def __init__(self, start_time: float, step_size: float, profiles: dict[str, list[Any]]) -> None:
        self.start_time, self.step_size, self.profiles = start_time, step_size, profiles
        self.first = -1
        self.times = np.zeros(0)
        self.values: dict[str, np.ndarray] = {}
        """Per instance, (points, its profiles), C-contiguous."""

    def hold(self, first: int, last: int) -> "_Points":
        """Compute the points ``first .. last`` (each profile sampled elementwise in time: the same
        values whatever the block)."""
        self.first = first
        self.times = communication_times(self.start_time, self.step_size, last, first)
        self.values = {c: np.ascontiguousarray(np.stack([p.sample(self.times) for p in profs], axis=1))
                       for c, profs in self.profiles.items()}
        return self

    def time(self, k: int) -> float:
        """``t_k``, s (``k`` among the points held)."""
        return float(self.times[k - self.first])


def _structured(dtype: list[tuple[str, str]], times: np.ndarray, data: np.ndarray) -> np.ndarray:
    """Recorded rows as the master returns them: ``time`` then one field per column of ``data``."""
    out = np.zeros(len(times), dtype=dtype)
    out["time"] = times
    for i, (name, _) in enumerate(dtype[1:]):
        out[name] = data[:len(times), i]
    return out


def communication_times(start_time: float, step_size: float, n_steps: int, first: int = 0) -> np.ndarray:
    """``t_k = t0 + k h``, k = 0..n_steps, s: when t0 and h are whole nanoseconds, the correctly
    rounded ``(t0_ns + k h_ns) / 1e9``, the times libcosim passes to the FMUs (it counts integer
    nanoseconds), so a time-dependent FMU sees the same times in both engines; otherwise
    ``t0 + h k`` in floating point.

    Parameters
    ----------
    start_time : float
        ``t0``, s.
    step_size : float
        Communication step ``h``, s.
    n_steps : int
        Number of steps.
    first : int, optional
        The first point returned (default 0: every point).

    Returns
    -------
    numpy.ndarray
        The times ``t_first .. t_n_steps``, s, shape (n_steps + 1 - first,).
    """
    return times_at(start_time, step_size, np.arange(first, n_steps + 1, dtype=np.int64))


def times_at(start_time: float, step_size: float, k: np.ndarray) -> np.ndarray:
    """``t_k`` at the points ``k`` as :func:`communication_times` gives them (the same numbers).

    Parameters
    ----------
    start_time : float
        ``t0``, s.
    step_size : float
        Communication step ``h``, s.
    k : numpy.ndarray of int
        The points.

    Returns
    -------
    numpy.ndarray
        The times, s, shape of ``k``.
    """
    ns = [start_time * 1e9, step_size * 1e9]
    if all(abs(v - round(v)) <= 1e-6 * max(1.0, abs(v)) for v in ns):
        return (round(ns[0]) + round(ns[1]) * k) / 1e9
    return start_time + step_size * k


@dataclass
class Component:
    """One FMU instance in the co-simulation.

    Attributes
    ----------
    name : str
        Instance name (the ``instance`` of ``"instance.variable"``).
    path : Path
        The FMU file.
    model_description : fmpy.model_description.ModelDescription
        Its model description, as fmpy reads it (an FMI 3.0 one as FMI 2.0 scalars:
        :func:`satfmu.sims.cosim.instances.scalar_description`).
    unzip_dir : str
        Folder the FMU is extracted into (removed by :meth:`CoSimulation.close`).
    instance : satfmu.sims.cosim.instances.Instance
        The FMU's library and instance.
    variables : dict of str to fmpy.model_description.ScalarVariable
        Every model variable, by name.
    log : list of str, optional
        The messages the FMU logged since its last instantiation or reset.
    fatal : bool, optional
        Set when the FMU returned fmi2Fatal: FMI then allows no further call, not even a free.
    instantiated : bool, optional
        An instance exists (between a run and the next with ``reuse_instances``).
    """

    name: str
    path: Path
    model_description: Any
    unzip_dir: str
    instance: Instance
    variables: dict[str, Any]
    log: list[str] = field(default_factory=list)
    fatal: bool = False
    """Set when the FMU returned fmi2Fatal: FMI then allows no further call, not even a free."""
    instantiated: bool = False
    """An instance exists (between a run and the next with ``reuse_instances``)."""

    @property
    def slave(self) -> Any:
        """fmpy's handle of the FMU (``FMU2Slave`` or ``FMU3Slave``)."""
        return self.instance.slave

    def variable(self, name: str) -> Any:
        """The model variable ``name`` (fmpy's ``ScalarVariable``).

        Parameters
        ----------
        name : str
            Name of the variable in the FMU (``"omega[1]"``).

        Raises
        ------
        UnknownVariableError
            If the FMU has no such variable (listing its base names and the closest one).
        """
        try:
            return self.variables[name]
        except KeyError:
            bases = sorted({n.split("[")[0] for n in self.variables})
            raise UnknownVariableError(
                f"FMU instance {self.name!r} ({self.path.name}) has no variable {name!r}; "
                f"its variables are {', '.join(bases)}{did_you_mean(name.split('[')[0], bases)}") from None

    def expand(self, name: str) -> list[str]:
        """``name`` itself, or every ``name[i]`` if ``name`` is a base name.

        Parameters
        ----------
        name : str
            A variable name (``"omega[1]"``) or a base name (``"omega"``).

        Returns
        -------
        list of str
            The variable names, indices in increasing order.

        Raises
        ------
        UnknownVariableError
            If ``name`` is neither a variable nor a base name of one.
        """
        if name in self.variables:
            return [name]
        indexed = [n for n in self.variables if n.startswith(name + "[")]
        if not indexed:
            self.variable(name)  # raises with the list of variables
        return sorted(indexed, key=lambda n: int(n[len(name) + 1:-1]) if n[len(name) + 1:-1].isdigit() else 0)

    def feedthrough(self) -> dict[str, set[str]]:
        """For each output, the inputs it depends on directly (all inputs if undeclared)."""
        inputs = {n for n, v in self.variables.items() if v.causality == "input"}
        out = {}
        for u in self.model_description.outputs:
            deps = u.dependencies
            out[u.variable.name] = inputs if deps is None else {d.name for d in deps if d.name in inputs}
        return out


@dataclass
class _Transfer:
    """Values copied from one FMU's outputs to another FMU's inputs each step."""

    src: Component
    dst: Component
    src_vr: Any
    dst_vr: Any
    buf: Any
    n: int


class CoSimulation:
    """A set of FMUs, their connections and profiles, run at a fixed communication step.

    Parameters
    ----------
    fmus : dict of str to path
        Instance name -> FMU file.
    reuse_instances : bool
        Keep the FMU instances after a run and ``fmi2Reset`` them for the next one, instead of
        a new ``fmi2Instantiate`` per run (a campaign's many short runs; the results are the
        same, as FMI 2.0 requires of a reset). :meth:`close` frees them.

    Raises
    ------
    FileNotFoundError
        If an FMU file does not exist.
    """

    def __init__(self, fmus: Mapping[str, str | Path], reuse_instances: bool = False) -> None:
        self.reuse_instances = reuse_instances
        self._pools: ThreadpoolController | None = None
        self._loop: Any = None  # the compiled loop's library, False if unavailable, None until asked
        self._ran: str | None = None  # the loop of the last run
        self._resolved: dict[str, tuple[Component, list[str]]] = {}  # resolve()'s answers
        self._plan: tuple[tuple[tuple[str, str], ...], list[_Transfer]] | None = None  # connections, transfers
        self.components: dict[str, Component] = {}
        self.connections: list[tuple[str, str]] = []
        self.profiles: list[tuple[str, Profile]] = []
        self.mismatches: list[str] = []
        """Design mismatches of its controllers, as found by :func:`satfmu.sims.scenario.wiring.design_mismatches`."""
        self._callbacks = fmi_host.Callbacks(self._receive)
        for name, path in fmus.items():
            path = Path(path)
            if not path.is_file():
                raise FileNotFoundError(f"FMU for instance {name!r} not found: {path}")
            try:
                md, unzip = fmi_host.open_fmu(path)
            except fmi_host.UnreadableFmuError as exc:
                raise MasterError(f"FMU for instance {name!r}: {exc}") from None
            try:
                instance = open_instance(md, unzip, name)
            except MasterError:
                shutil.rmtree(unzip, ignore_errors=True)
                raise
            view = instance.description
            self.components[name] = Component(name, path, view, unzip, instance,
                                              {v.name: v for v in view.modelVariables})

    # ------------------------------------------------------------------ setup
    def _receive(self, message: fmi_host.Message) -> None:
        """Logger sink: each message goes to the log of the component it names."""
        comp = self.components.get(message.instance)
        if comp is not None:
            comp.log.append(message.line())

    @property
    def loop(self) -> str | None:
        """The loop its runs step in: ``"compiled"`` (:mod:`satfmu.sims.cosim.compiled_loop`) or
        ``"python"`` (no C compiler, or an FMI 3.0 FMU), None before its first run."""
        return self._ran

    @property
    def fmi3(self) -> bool:
        """Whether one of its FMUs is an FMI 3.0 one (it then steps in the Python loop)."""
        return any(isinstance(c.instance, Fmi3Instance) for c in self.components.values())

    def resolve(self, qualified: str) -> tuple[Component, list[str]]:
        """Split ``"instance.variable"`` and expand base names.

        Parameters
        ----------
        qualified : str
            ``"instance.variable"``, the variable a full name or a base name (``"plant.omega"``).

        Returns
        -------
        component : Component
            The instance.
        names : list of str
            The variable names (:meth:`Component.expand`).

        Raises
        ------
        UnknownVariableError
        """
        if qualified in self._resolved:
            return self._resolved[qualified]
        if "." not in qualified:
            raise UnknownVariableError(f"{qualified!r} is not of the form 'instance.variable'")
        inst, var = qualified.split(".", 1)
        if inst not in self.components:
            raise UnknownVariableError(
                f"{qualified!r}: no FMU instance {inst!r} (instances: {', '.join(self.components)})")
        comp = self.components[inst]
        self._resolved[qualified] = comp, comp.expand(var)
        return self._resolved[qualified]

    def unit(self, qualified: str) -> str:
        """Declared unit of one variable (``"1"`` if none).

        Parameters
        ----------
        qualified : str
            ``"instance.variable"``; for a base name, the unit of its first index.

        Raises
        ------
        UnknownVariableError
        """
        comp, names = self.resolve(qualified)
        var = comp.variable(names[0])
        return getattr(var, "unit", None) or getattr(getattr(var, "declaredType", None), "unit", None) or "1"

    def connect(self, source: str, target: str) -> None:
        """Connect outputs to inputs; base names connect index by index.

        Parameters
        ----------
        source : str
            The Real output(s), ``"instance.variable"`` or a base name.
        target : str
            The Real input(s) it drives, as many as ``source`` names.

        Raises
        ------
        UnknownVariableError, WiringError
            An unknown variable, a count mismatch, a source that is not an output, a target
            that is not an input, or a variable that is not Real.
        """
        sc, sv = self.resolve(source)
        dc, dv = self.resolve(target)
        if len(sv) != len(dv):
            raise WiringError(f"{source} has {len(sv)} variables, {target} has {len(dv)}")
        for s, d in zip(sv, dv):
            vs, vd = sc.variable(s), dc.variable(d)
            if vs.causality != "output":
                raise WiringError(f"{sc.name}.{s} is a {vs.causality}, not an output")
            if vd.causality != "input":
                raise WiringError(f"{dc.name}.{d} is a {vd.causality}, not an input")
            if vs.type != "Real" or vd.type != "Real":
                raise WiringError(f"{sc.name}.{s} -> {dc.name}.{d}: only Real connections are supported")
            self.connections.append((f"{sc.name}.{s}", f"{dc.name}.{d}"))

    def add_profile(self, target: str, profile: Profile) -> None:
        """Feed ``profile`` to the input(s) ``target``.

        Parameters
        ----------
        target : str
            The Real input(s), ``"instance.variable"`` or a base name (each index gets the
            profile).
        profile : satfmu.fmus.profiles.Profile
            The signal, sampled at each communication point and held over the step, in the
            input's unit.

        Raises
        ------
        UnknownVariableError, WiringError
            An unknown variable, or a target that is not a Real input.
        """
        comp, names = self.resolve(target)
        for n in names:
            if comp.variable(n).causality != "input" or comp.variable(n).type != "Real":
                raise WiringError(f"profile target {comp.name}.{n} is not a Real input")
            self.profiles.append((f"{comp.name}.{n}", profile))

    def check_wiring(self) -> None:
        """Check the wiring without running: no input driven twice, no algebraic loop.

        Raises
        ------
        WiringError
            Naming the input and its two drivers, or the connections of the loop.
        """
        self._check_drivers()
        self._levels()

    def _check_drivers(self) -> None:
        driven: dict[str, str] = {}
        for src, dst in self.connections + [(f"profile {p.kind}", t) for t, p in self.profiles]:
            if dst in driven:
                raise WiringError(f"input {dst} is driven twice (by {driven[dst]} and by {src})")
            driven[dst] = src

    def _levels(self) -> dict[tuple[str, str], int]:
        """Each connection's propagation level, from variable-level feedthrough.

        A connection ``a.y -> b.u`` must be copied after every connection into an input of
        ``a`` that ``y`` depends on directly.  The level is the longest such chain (0 for a
        connection from an output without feedthrough).  Only a cycle through variables is
        an algebraic loop: a plant whose saturation output depends on ``T`` may feed a
        controller whose ``T`` depends on the plant's state outputs.
        """
        into: dict[str, list[tuple[str, str]]] = defaultdict(list)  # qualified input -> connections
        for src, dst in self.connections:
            into[dst].append((src, dst))
        feed = {c.name: c.feedthrough() for c in self.components.values()}
        level: dict[tuple[str, str], int] = {}
        active: list[tuple[str, str]] = []

        def visit(conn: tuple[str, str]) -> int:
            if conn in level:
                return level[conn]
            if conn in active:
                loop = active[active.index(conn):] + [conn]
                raise WiringError("algebraic loop through direct feedthrough: "
                                  + " -> ".join(f"{s} => {d}" for s, d in loop))
            active.append(conn)
            comp, var = conn[0].split(".", 1)
            deps = feed[comp].get(var, set())
            level[conn] = 1 + max((visit(c) for u in sorted(deps) for c in into[f"{comp}.{u}"]), default=-1)
            active.pop()
            return level[conn]
        for conn in self.connections:
            visit(conn)
        return level

    # ------------------------------------------------------------------ calls
    def _call(self, comp: Component, fn: str, *args: Any) -> Any:
        try:
            return getattr(comp.instance, fn)(*args)
        except FMICallException as exc:
            self._raise(comp, exc)

    def _raise(self, comp: Component, exc: FMICallException) -> None:
        """Raise the :class:`FmuCallError` of a failed call (its status and the FMU's last log lines)."""
        comp.fatal |= exc.status == fmi_host.FATAL
        tail = "; ".join(comp.log[-5:]) or "no log message"
        raise FmuCallError(f"{comp.name} ({comp.path.name}): {exc} -- FMU log: {tail}") from None

    def _set_parameters(self, comp: Component, values: dict[str, Any]) -> None:
        for name, value in values.items():
            var, value = start_value(comp, name, value)
            self._call(comp, "set_values", var.type, [var.valueReference], [value])

    def _transfers(self) -> list[_Transfer]:
        """Connections batched per (level, source FMU, target FMU), in level order (made once per
        set of connections)."""
        key = tuple(self.connections)
        if self._plan is None or self._plan[0] != key:
            self._plan = key, self._batched_transfers()
        return self._plan[1]

    def _batched_transfers(self) -> list[_Transfer]:
        level = self._levels()
        groups: dict[tuple[int, str, str], list[tuple[int, int]]] = defaultdict(list)
        for src, dst in self.connections:
            sc, sv = src.split(".", 1)
            dc, dv = dst.split(".", 1)
            groups[(level[(src, dst)], sc, dc)].append((self.components[sc].variable(sv).valueReference,
                                                        self.components[dc].variable(dv).valueReference))
        out = []
        for (_, sc, dc), pairs in sorted(groups.items()):
            n = len(pairs)
            vr_t = ctypes.c_uint * n
            out.append(_Transfer(self.components[sc], self.components[dc], vr_t(*[p[0] for p in pairs]),
                                 vr_t(*[p[1] for p in pairs]), (ctypes.c_double * n)(), n))
        return out

    # ------------------------------------------------------------------ run
    def run(self, stop_time: float, step_size: float, start_time: float = 0.0,
            parameters: dict[str, dict[str, Any]] | None = None,
            record: Sequence[str] = (), exchange_order: str = "feedthrough", *,
            engine: str = "auto", record_every: int = 1,
            sink: Callable[[np.ndarray], None] | None = None) -> np.ndarray:
        """Run the co-simulation and return the recorded variables.

        Parameters
        ----------
        stop_time, step_size, start_time : float
            s. ``(stop_time - start_time) / step_size`` must be an integer (to 1e-9).
        parameters : dict
            Instance name -> {variable name: value} set before initialization.
        record : sequence of str
            Qualified names (base names expand) to record.
        exchange_order : {"feedthrough", "jacobi"}
            Propagation order after each step: in feedthrough order (default), or every
            output read before any input is set (see the module docstring). Initialization
            propagates in feedthrough order either way (as libcosim's does).
        engine : {"auto", "compiled", "python"}
            Who runs the step loop: the compiled loop (:mod:`satfmu.sims.cosim.compiled_loop`), the
            Python loop, or the compiled one when a C compiler is there and every FMU is an
            FMI 2.0 one (default). Both make the same calls with the same values: the results
            are identical.
        record_every : int
            Record every ``record_every``-th communication point, from the first, and the last
            one (>= 1; the default records every point). Memory: 8 bytes per recorded
            variable and row.
        sink : callable, optional
            Stream the recording: ``sink(rows)`` receives the recorded rows in order, a block at
            a time (a structured array like the one returned, at most
            ``compiled_loop.BLOCK // record_every + 1`` rows; the first holds the initial point
            alone), as the run goes; it may keep them. The run then holds one block of rows,
            and the communication times and the profiles' values of one block of steps: its
            memory does not grow with its length. Default: every row kept and returned.

        Returns
        -------
        numpy.ndarray
            Structured array with field ``time`` and one float field per recorded variable (no
            rows with ``sink``: what it received).

        Raises
        ------
        ValueError, UnknownVariableError, WiringError, FmuCallError
        """
        for label, x in (("start_time", start_time), ("stop_time", stop_time), ("step_size", step_size)):
            if isinstance(x, bool) or not isinstance(x, (int, float)) or not math.isfinite(x):
                raise ValueError(f"{label} must be a finite number, got {x!r}")
        if step_size <= 0:
            raise ValueError(f"step_size must be > 0 s, got {step_size}")
        if exchange_order not in ("feedthrough", "jacobi"):
            raise ValueError(f"exchange_order must be 'feedthrough' or 'jacobi', got {exchange_order!r}")
        if engine not in ENGINES:
            raise ValueError(f"engine must be one of {', '.join(ENGINES)}, got {engine!r}")
        if isinstance(record_every, bool) or not isinstance(record_every, (int, np.integer)) or record_every < 1:
            raise ValueError(f"record_every must be an integer >= 1, got {record_every!r}")
        if stop_time <= start_time:
            raise ValueError(f"stop_time {stop_time} must exceed start_time {start_time}")
        n_float = (stop_time - start_time) / step_size
        n_steps = int(round(n_float))
        if abs(n_float - n_steps) > 1e-9 * max(1.0, n_float):
            raise ValueError(f"(stop_time - start_time) / step_size = {n_float} is not an integer")
        dead = [c.name for c in self.components.values() if c.fatal]
        if dead:
            raise MasterError(f"FMU instance(s) {dead} returned fmi2Fatal in an earlier run and cannot be "
                              "used again; create a new CoSimulation")
        lib = None
        if engine == "compiled" and self.fmi3:
            raise MasterError("the compiled loop runs FMI 2.0 FMUs only; with an FMI 3.0 FMU use engine='python' "
                              "or 'auto'")
        if engine != "python" and not self.fmi3:
            if self._loop is None:
                from satfmu.sims.cosim import compiled_loop

                self._loop = compiled_loop.library() or False
            lib = self._loop or None
            if lib is None and engine == "compiled":
                raise MasterError("the compiled loop is not available (no C compiler, or SATFMU_PYTHON_LOOP is "
                                  "set); use engine='python' or 'auto'")
        parameters = parameters or {}
        for inst in parameters:
            if inst not in self.components:
                raise UnknownVariableError(f"parameters given for unknown FMU instance {inst!r}")
        self._check_drivers()
        transfers = self._transfers()
        rec_names: list[str] = []
        for r in record:
            comp, names = self.resolve(r)
            rec_names += [f"{comp.name}.{n}" for n in names]
        rec_groups: dict[str, list[tuple[int, int]]] = defaultdict(list)
        for col, q in enumerate(rec_names):
            c, v = q.split(".", 1)
            var = self.components[c].variable(v)
            if var.type != "Real":
                raise WiringError(f"only Real variables can be recorded; {q} is {var.type}")
            rec_groups[c].append((var.valueReference, col))
        rec_bufs = {c: ((ctypes.c_uint * len(g))(*[p[0] for p in g]), (ctypes.c_double * len(g))(),
                        np.array([p[1] for p in g])) for c, g in rec_groups.items()}

        prof_groups: dict[str, list[tuple[int, Any]]] = defaultdict(list)
        for target, prof in self.profiles:
            c, v = target.split(".", 1)
            prof_groups[c].append((self.components[c].variable(v).valueReference, prof))
        prof_bufs = {c: ((ctypes.c_uint * len(g))(*[p[0] for p in g]), (ctypes.c_double * len(g))())
                     for c, g in prof_groups.items()}
        m = int(record_every)
        n_rows = _rows_through(n_steps, n_steps, m)
        from satfmu.sims.cosim.compiled_loop import BLOCK

        # kept: every point held at once; streamed: those of one block of steps at a time
        points = _Points(start_time, step_size, {c: [p for _, p in g] for c, g in prof_groups.items()})
        points.hold(0, n_steps if sink is None else min(BLOCK, n_steps))
        dtype = [("time", "f8")] + [(n, "f8") for n in rec_names]
        # streamed: the rows of one block of steps (row0: the first of them), handed to the sink
        data = np.zeros((n_rows if sink is None else min(n_rows, BLOCK // m + 2), len(rec_names)))
        row0 = 0

        def flush(r0: int, r1: int) -> None:
            assert sink is not None
            steps = np.minimum(np.arange(r0, r1, dtype=np.int64) * m, n_steps)
            sink(_structured(dtype, times_at(start_time, step_size, steps), data[:r1 - r0]))
        comps = list(self.components.values())
        limits = None
        clocked = [(c, c.instance) for c in comps if isinstance(c.instance, Fmi3Instance) and c.instance.clocked]
        first_read: dict[str, int] = {}  # instance -> index of the first transfer reading its outputs
        for i, tr in enumerate(transfers):
            first_read.setdefault(tr.src.name, i)
        try:
            for comp in comps:
                self._start(comp)
                self._set_parameters(comp, parameters.get(comp.name, {}))
                self._call(comp, "initialize", start_time, stop_time)
            # one BLAS/OpenMP thread while the FMUs run: their work (and the master's) is many small
            # solves, for which a thread pool costs CPU and gives nothing (ONE_THREAD); set after
            # instantiation, which loads the libraries of pythonfmu FMUs (scipy's own OpenBLAS)
            limits = self._thread_pools().limit(limits=ONE_THREAD)

            def set_profiles(k: int) -> None:
                for c, (vr, buf) in prof_bufs.items():
                    buf[:] = points.values[c][k - points.first]
                    self._call(self.components[c], "set_reals", vr, buf)

            def exchange(k: int, jacobi: bool) -> None:
                """Profiles and connections at t_k; in Jacobi order a profile counts as an output
                (a signal generator's), so it is set with the inputs, after every read. The clocks
                of FMI 3.0 FMUs that tick at t_k are driven around it (the module docstring)."""
                due = [c for c, inst in clocked if inst.instant_at(points.time(k))] if k > 0 else []
                waiting = {c.name for c in due}
                for comp in due if not jacobi else ():
                    self._call(comp, "enter_event")
                if not jacobi:
                    set_profiles(k)
                for i, tr in enumerate(transfers):
                    if not jacobi and tr.src.name in waiting and first_read[tr.src.name] == i:
                        self._call(tr.src, "activate")
                        waiting.discard(tr.src.name)
                    self._call(tr.src, "get_reals", tr.src_vr, tr.buf)
                    if not jacobi:
                        self._call(tr.dst, "set_reals", tr.dst_vr, tr.buf)
                for comp in due if jacobi else ():
                    self._call(comp, "enter_event")
                if jacobi:
                    set_profiles(k)
                for tr in transfers if jacobi else ():
                    self._call(tr.dst, "set_reals", tr.dst_vr, tr.buf)
                for comp in due:
                    if comp.name in waiting:
                        self._call(comp, "activate")
                    self._call(comp, "leave_event")

            def sample(row: int) -> None:
                for c, (vr, buf, cols) in rec_bufs.items():
                    self._call(self.components[c], "get_reals", vr, buf)
                    data[row - row0, cols] = buf[:]

            exchange(0, False)
            for comp in comps:
                self._call(comp, "exit_initialization")
            sample(0)
            if sink is not None:
                flush(0, 1)
            jacobi = exchange_order == "jacobi"
            self._ran = "compiled" if lib is not None else "python"
            if lib is not None:
                self._compiled_steps(lib, comps, transfers, prof_bufs, rec_bufs, points, n_steps, step_size, jacobi,
                                     m, data, None if sink is None else flush)
            else:
                row = 1
                for begin in range(0, n_steps, BLOCK):  # the compiled loop's blocks
                    end = min(begin + BLOCK, n_steps)
                    if sink is not None:
                        row0 = row
                        points.hold(begin, end)
                    for k in range(begin, end):
                        for comp in comps:
                            self._call(comp, "step", points.time(k), step_size)
                        exchange(k + 1, jacobi)
                        if (k + 1) % m == 0 or k + 1 == n_steps:  # the recorded points (recorded_steps)
                            sample(row)
                            row += 1
                    if sink is not None:
                        flush(row0, row)
            for comp in comps:
                self._call(comp, "terminate")
        finally:
            if limits is not None:
                limits.restore_original_limits()
            if not self.reuse_instances:
                self._free_instances()
        if sink is not None:
            return np.zeros(0, dtype=dtype)
        return _structured(dtype, times_at(start_time, step_size, recorded_steps(n_steps, m)), data)

    def _start(self, comp: Component) -> None:
        """Bring an FMU instance to the instantiated state: ``fmi2Instantiate`` the first time;
        with ``reuse_instances`` and an instance left by an earlier run, ``fmi2Reset`` (which
        gives every variable its default value, as a new instance has), or a new instance if
        the reset fails."""
        comp.log.clear()
        if comp.instantiated:
            try:
                self._call(comp, "reset")
                return
            except FmuCallError:
                if comp.fatal:
                    raise
                comp.instance.free()
                comp.instantiated = False
                comp.log.clear()
        comp.instance.instantiate(self._callbacks)
        comp.instantiated = True

    def _thread_pools(self) -> ThreadpoolController:
        """The host's BLAS/OpenMP pools, found once (a scan of the loaded libraries costs ~2 ms) after
        the first instantiation, which loads the libraries of pythonfmu FMUs."""
        if self._pools is None:
            self._pools = ThreadpoolController()
        return self._pools

    def _free_instances(self) -> None:
        """Free every instance (the libraries stay loaded so the same set can run again)."""
        for comp in self.components.values():
            if comp.instantiated and not comp.fatal:  # after fmi2Fatal the instance is abandoned, as FMI 2.0 requires
                comp.instance.free()
            comp.instantiated = False

    def _compiled_steps(self, lib: Any, comps: list[Component], transfers: list[_Transfer],
                        prof_bufs: dict[str, Any], rec_bufs: dict[str, Any], points: _Points, n_steps: int,
                        step_size: float, jacobi: bool, record_every: int, data: np.ndarray,
                        flush: Callable[[int, int], None] | None = None) -> None:
        """The step loop in C (:mod:`satfmu.sims.cosim.compiled_loop`); a failed call raises as :meth:`_call` does.
        ``flush``: streamed, the block callback (:meth:`StepPlan.run`), the points held a block at a time."""
        from satfmu.sims.cosim.compiled_loop import StepPlan

        index = {c.name: i for i, c in enumerate(comps)}
        order = list(prof_bufs)

        def block(first: int, last: int) -> tuple[int, np.ndarray, list[np.ndarray]]:
            if flush is not None:  # kept: every point is held already
                points.hold(first, last)
            return points.first, points.times, [points.values[c] for c in order]

        plan = StepPlan(
            slaves=[c.slave for c in comps],
            transfers=[(index[t.src.name], index[t.dst.name], t.src_vr, t.dst_vr, t.buf) for t in transfers],
            profiles=[(index[c], *prof_bufs[c]) for c in order],
            records=[(index[c], vr, buf, cols) for c, (vr, buf, cols) in rec_bufs.items()],
            n_steps=n_steps, step_size=step_size, jacobi=jacobi, record_every=record_every, data=data)
        rows = None if flush is None else (lambda point: _rows_through(point, n_steps, record_every))
        failure = plan.run(lib, block, flush, rows)
        if failure is not None:
            self._raise(comps[failure.fmu], FMICallException(function=failure.function, status=failure.status))

    def held_signals(self) -> set[str]:
        """Qualified variables whose value is held over each step (inputs and connected outputs)."""
        held = {dst for _, dst in self.connections} | {src for src, _ in self.connections}
        held |= {t for t, _ in self.profiles}
        return held

    def input_signals(self) -> set[str]:
        """Qualified FMU inputs the master sets (connection targets and profiles): piecewise
        constant over each step."""
        return {dst for _, dst in self.connections} | {t for t, _ in self.profiles}

    def close(self) -> None:
        """Free the instances, unload the FMU libraries and remove the extracted FMU folders."""
        self._free_instances()
        for comp in self.components.values():
            if not comp.fatal:  # an abandoned instance may still reference its library
                comp.instance.unload()
            shutil.rmtree(comp.unzip_dir, ignore_errors=True)

    def __enter__(self) -> "CoSimulation":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
