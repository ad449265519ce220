"""The FMU under test: its backend and the variables the cases abuse, from ``modelDescription.xml``."""
from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from satfmu.fmus import archive


NATIVE, PYTHONFMU = "native", "pythonfmu"
"""The two backends of the project's FMUs: C model code (``fmus/c/fmi2_cosim.c``), or a pythonfmu
slave behind satfmu's C layer (``fmus/pyslave.py``)."""
BACKENDS = (NATIVE, PYTHONFMU)
PYTHONFMU_MARKER = "resources/slavemodule.txt"
"""File every pythonfmu FMU carries (read by pythonfmu's fmi2Instantiate): tells the backends apart."""


@dataclass(frozen=True)
class Var:
    """One scalar variable of ``modelDescription.xml``.

    Attributes
    ----------
    name, type, causality, variability : str
    vr : int
        Value reference.
    start : float or None
        Declared start value (in the variable's unit).
    min, max : float or None
        Declared range (in the variable's unit), None when not declared.
    unit : str
        Declared unit ("" when none).
    """

    name: str
    vr: int
    type: str
    causality: str
    variability: str
    start: float | None
    min: float | None
    max: float | None
    unit: str = ""


SAMPLE_PERIODS = ("control_period", "sample_period")
"""Names of the sample-period parameters of the project's sampled FMUs (satfmu.fmus.model.Sampler.period:
controllers/magnetic.py, controllers/servo.py); the huge-step cases also run at its declared minimum."""
TIME_ORIGINS = {"step_time": 1.0, "start": 1.0, "stop": 1.0, "orbit_time_0": -1.0, "epoch_time": 1.0,
                "sample_phase": -1.0}
"""Parameters that place an FMU's time-dependent behaviour on the time axis, with the sign of their
shift when the experiment starts t0 later (a step or ramp time moves by +t0; the orbit time at
t = 0 of the cubesat plant and of the periodic schedules by -t0, so the orbit time at the start is
kept; the orbit model's epoch time by +t0; a sensor's sample phase by -t0, so its instants and its
noise counter are the same): the start-time cases run the same experiment at t0 = 0 and at a large t0."""
TIME_OUTPUTS = ("sample_time",)
"""Outputs that are instants on the time axis (a sensor's measurement time): the start-time cases
compare them less t0."""


@dataclass(frozen=True)
class Target:
    """An FMU under test and the variables the cases use (None: no such variable, case n/a).

    Attributes
    ----------
    path : Path
    name : str
        File name without ``.fmu``.
    backend : str
        :data:`NATIVE` or :data:`PYTHONFMU`.
    guid, model_identifier : str
    step : float
        Default communication step size in s (``DefaultExperiment stepSize``; 0.01 s if absent).
    can_state, can_serialize : bool
        Declared ``canGetAndSetFMUstate`` and ``canSerializeFMUstate``.
    inputs, outputs : tuple of Var
        The Real inputs and outputs.
    parameter : Var or None
        The first Real parameter.
    fixed : Var or None
        The first parameter that is not tunable.
    below, above : Var or None
        The first parameter with a finite declared minimum (maximum).
    non_real : Var or None
        The first Integer or Boolean parameter.
    parameters : tuple of Var
        Every parameter.
    period : Var or None
        The sample-period parameter (:data:`SAMPLE_PERIODS`).
    """

    path: Path
    name: str
    backend: str
    guid: str
    model_identifier: str
    step: float
    can_state: bool
    can_serialize: bool
    inputs: tuple[Var, ...]
    outputs: tuple[Var, ...]
    parameter: Var | None
    fixed: Var | None
    below: Var | None
    above: Var | None
    non_real: Var | None
    parameters: tuple[Var, ...] = ()
    period: Var | None = None

    @property
    def input(self) -> Var | None:
        """The Real input the input cases abuse (the first one)."""
        return self.inputs[0] if self.inputs else None


def _number(text: str | None) -> float | None:
    return None if text is None else float(text)


def _var(v: Any) -> Var:
    return Var(v.name, int(v.valueReference), v.type, v.causality, v.variability or "",
               _number(v.start) if v.type in ("Real", "Integer") else None, _number(v.min), _number(v.max),
               v.unit or "")


def _first(variables: Sequence[Var], pred: Callable[[Var], bool]) -> Var | None:
    return next((v for v in variables if pred(v)), None)


def backend_of(path: Path) -> str:
    """:data:`PYTHONFMU` if the FMU carries pythonfmu's slave module file, else :data:`NATIVE`.

    Parameters
    ----------
    path : Path
        The FMU file (its archive is checked and listed).
    """
    return PYTHONFMU if PYTHONFMU_MARKER in archive.check(path).names else NATIVE


def describe(path: Path) -> Target:
    """Read ``path``'s model description and choose the variables of the cases.

    Parameters
    ----------
    path : Path
        The FMU file.

    Returns
    -------
    Target
    """
    md = archive.read_description(path)
    variables = [_var(v) for v in md.modelVariables]
    params = [v for v in variables if v.causality == "parameter"]
    real_params = [v for v in params if v.type == "Real"]
    exp = md.defaultExperiment
    step = float(exp.stepSize) if exp is not None and exp.stepSize is not None else 0.01
    cs = md.coSimulation
    return Target(
        path=path, name=path.stem, backend=backend_of(path), guid=md.guid, model_identifier=cs.modelIdentifier,
        step=step, can_state=bool(cs.canGetAndSetFMUstate), can_serialize=bool(cs.canSerializeFMUstate),
        inputs=tuple(v for v in variables if v.causality == "input" and v.type == "Real"),
        outputs=tuple(v for v in variables if v.causality == "output" and v.type == "Real"),
        parameter=real_params[0] if real_params else None,
        fixed=_first(params, lambda v: v.variability != "tunable"),
        below=_first(params, lambda v: v.type in ("Real", "Integer") and v.min is not None and math.isfinite(v.min)),
        above=_first(params, lambda v: v.type in ("Real", "Integer") and v.max is not None and math.isfinite(v.max)),
        non_real=_first(params, lambda v: v.type in ("Integer", "Boolean")),
        parameters=tuple(params), period=_first(real_params, lambda v: v.name in SAMPLE_PERIODS))


def other_interface(path: Path) -> str | None:
    """Why the cases cannot drive the FMU file ``path`` (they are FMI 2.0 co-simulation calls), or
    None: ``"an FMI 3.0 FMU"``, ``"a model-exchange FMU"``. An unreadable file gives None (its cases
    then fail, saying why).

    Parameters
    ----------
    path : Path
        The FMU file.
    """
    try:
        md = archive.read_description(path)
    except (OSError, archive.UnsafeFmuError):
        return None
    if md.fmiVersion != "2.0":
        return f"an FMI {md.fmiVersion} FMU"
    return None if md.coSimulation is not None else "a model-exchange FMU"


def discover(fmu_dir: Path, names: Sequence[str] | None = None) -> list[Path]:
    """The FMUs to test: every FMI 2.0 co-simulation ``*.fmu`` in ``fmu_dir`` (not the FMI 3.0 and
    model-exchange ones: the cases are FMI 2.0 co-simulation calls), or those named (with or without
    ``.fmu``).

    Parameters
    ----------
    fmu_dir : Path
        Folder of the FMUs.
    names : sequence of str, optional
        FMU names in ``fmu_dir`` (default: every FMI 2.0 co-simulation ``*.fmu`` there, sorted).

    Raises
    ------
    FileNotFoundError
        A named FMU is not in ``fmu_dir``.
    ValueError
        A named FMU is an FMI 3.0 or a model-exchange FMU.
    """
    if names is None:
        return sorted(p for p in fmu_dir.glob("*.fmu") if other_interface(p) is None)
    paths = [fmu_dir / (n if n.endswith(".fmu") else n + ".fmu") for n in names]
    missing = [str(p) for p in paths if not p.is_file()]
    if missing:
        raise FileNotFoundError(f"no such FMU: {', '.join(missing)}")
    others = [f"{p.name} is {other_interface(p)}" for p in paths if other_interface(p) is not None]
    if others:
        raise ValueError(f"the robustness cases drive FMI 2.0 co-simulation FMUs; {'; '.join(others)}")
    return paths

