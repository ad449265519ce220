"""FMI 2.0 modelDescription.xml of a :class:`satfmu.fmus.model.Model`, for both backends.

The native FMU and the pythonfmu FMU of one model share this description (only the GUID, the
modelIdentifier, the capability flags and the native FMU's SourceFiles differ), so their
variables, value references, units and ModelStructure are identical by construction.

Identity (``docs/fmus-in-your-tool.md``, "GUID, modelName and version"):

* ``guid`` identifies the description: a name-based UUID (``uuid.uuid5`` in
  :data:`GUID_NAMESPACE`) of the model digest (:func:`satfmu.fmus.digest.model_digest`: the equations,
  which the description does not show) and the SHA-256 of the description itself with an empty
  ``guid``. The two FMUs of one model therefore have different GUIDs; two builds of the same
  sources the same one; any change of the model or of the description another.
* ``modelName`` is the model's name, the same for both FMUs: FMI 2.0 defines it as the name of
  the model in the environment that generated the description, and both FMUs export the same
  satfmu model (the modelIdentifier, the file name and the GUID tell the backends apart).
* ``version`` is :func:`model_version`: the satfmu version, ``+``, the first 16 hex digits of
  the model digest.
"""
from __future__ import annotations

import copy
import uuid
from dataclasses import dataclass
from xml.etree.ElementTree import Element, SubElement, indent, tostring

from satfmu.fmus import __version__
from satfmu.fmus.annotations import ANNOTATION_TOOL
from satfmu.fmus.codegen import KIND_INPUT, KIND_PARAMETER, variable_table
from satfmu.fmus.digest import model_digest, sha256
from satfmu.fmus.model import Model, Variable
from satfmu.fmus.units import UNITS

NATIVE, PYTHON = "native", "python"
"""The two backends: the native C FMU and the pythonfmu FMU."""
PYTHON_SUFFIX = "_py"
"""Suffix of a pythonfmu FMU's modelIdentifier (and file name) after the model's name."""
WRAPPER_SOURCE = "fmi2_cosim.c"
"""The native FMU's one source file (``<SourceFiles>``), the generic wrapper ``fmus/c/fmi2_cosim.c``."""
GUID_NAMESPACE = uuid.uuid5(uuid.NAMESPACE_URL, "https://satfmu/modelDescription/guid")
"""Namespace of the name-based GUIDs (:func:`description_guid`); fixed, so GUIDs are reproducible."""
VERSION_DIGEST_DIGITS = 16
"""Hex digits of the model digest in the ``version`` attribute (:func:`model_version`)."""

LOG_CATEGORIES = {
    "logStatusWarning": "Messages with status fmi2Warning",
    "logStatusDiscard": "Messages with status fmi2Discard",
    "logStatusError": "Messages with status fmi2Error (bad input, wrong call order, ...)",
    "logStatusFatal": "Messages with status fmi2Fatal",
    "logAll": "All messages",
}


@dataclass(frozen=True)
class Capabilities:
    """CoSimulation attributes that differ between the backends.

    Attributes
    ----------
    model_identifier : str
        The ``modelIdentifier``: the model's name (native) or the name and :data:`PYTHON_SUFFIX`
        (pythonfmu); also the FMU's file name and its binaries' name.
    needs_execution_tool : bool, optional
        ``needsExecutionTool``: True for a pythonfmu FMU (it needs a Python interpreter).
        Default False.
    can_get_and_set_fmu_state : bool, optional
        ``canGetAndSetFMUstate``. Default True.
    can_serialize_fmu_state : bool, optional
        ``canSerializeFMUstate``. Default True.
    generation_tool : str, optional
        ``generationTool`` of the description. Default ``"satfmu <version>"``.
    source_files : tuple of str, optional
        The files ``<SourceFiles>`` lists (a native FMU's wrapper); none for a pythonfmu FMU.
    """

    model_identifier: str
    needs_execution_tool: bool = False
    can_get_and_set_fmu_state: bool = True
    can_serialize_fmu_state: bool = True
    generation_tool: str = f"satfmu {__version__}"
    source_files: tuple[str, ...] = ()
    """The files ``<SourceFiles>`` lists (a native FMU's wrapper); none for a pythonfmu FMU."""


def capabilities(model: Model, backend: str) -> Capabilities:
    """The CoSimulation attributes of ``model``'s FMU on ``backend``.

    Parameters
    ----------
    model : Model
    backend : {"native", "python"}

    Returns
    -------
    Capabilities
        Native: modelIdentifier ``<name>``, the wrapper as its source file; pythonfmu:
        ``<name>_py``, needsExecutionTool (a Python interpreter).

    Raises
    ------
    ValueError
        For another backend.
    """
    if backend == NATIVE:
        return Capabilities(model.name, source_files=(WRAPPER_SOURCE,))
    if backend == PYTHON:
        return Capabilities(model.name + PYTHON_SUFFIX, needs_execution_tool=True)
    raise ValueError(f"unknown backend {backend!r} (expected {NATIVE!r} or {PYTHON!r})")


def model_version(model: Model) -> str:
    """The ``version`` attribute of ``model``'s FMUs: ``<satfmu version>+<model digest>``, the
    digest cut to :data:`VERSION_DIGEST_DIGITS` hex digits (e.g. ``0.1.0+3f2a9c1b04de7755``).

    The same for both backends; it changes with the satfmu release and with the model (its
    equations, variables, defaults, tables, sampler), so two FMUs of one version were built
    from the same model by the same satfmu.

    Parameters
    ----------
    model : Model
        The model of the FMU.

    Returns
    -------
    str
        The version text.
    """
    return f"{__version__}+{model_digest(model)[:VERSION_DIGEST_DIGITS]}"


def description_guid(model: Model, root: Element, attribute: str = "guid") -> str:
    """The GUID of the model description ``root`` of ``model`` (its ``attribute`` ignored).

    A name-based UUID (version 5, in :data:`GUID_NAMESPACE`) of the model digest and the SHA-256
    of the description's XML with an empty ``guid``: it identifies the description (the two
    backends' descriptions differ, so do their GUIDs) and the equations behind it (which the
    description does not show), and is the same for every build of the same sources.

    Parameters
    ----------
    model : Model
    root : Element
        An ``fmiModelDescription`` element of ``model`` (not changed).
    attribute : str, optional
        The attribute that holds it: ``"guid"`` (FMI 2.0, the default) or ``"instantiationToken"``
        (FMI 3.0).

    Returns
    -------
    str
        ``{xxxxxxxx-xxxx-5xxx-yxxx-xxxxxxxxxxxx}``.
    """
    blank = Element(root.tag, {**root.attrib, attribute: ""})
    blank.extend(list(root))
    name = f"satfmu model {model_digest(model)} description {sha256(tostring(blank, 'UTF-8'))}"
    return "{" + str(uuid.uuid5(GUID_NAMESPACE, name)) + "}"


def fmu_guid(model: Model, backend: str) -> str:
    """The GUID of ``model``'s FMU on ``backend`` (:func:`description_guid` of its description).

    Cached on the model object (never changed after construction): the description is built
    once per model and backend.

    Parameters
    ----------
    model : Model
        The model of the FMU.
    backend : {"native", "python"}
        The FMU's backend: the native C FMU or the pythonfmu FMU.

    Returns
    -------
    str
        ``{xxxxxxxx-xxxx-5xxx-yxxx-xxxxxxxxxxxx}``.
    """
    cache = model.__dict__.setdefault("_fmu_guids", {})
    if backend not in cache:
        cache[backend] = model_description(model, capabilities(model, backend)).get("guid")
    return cache[backend]


def xml_value(value: float | int | bool, vtype: str) -> str:
    """``value`` as the XML text of an FMI/SSP attribute of type ``vtype`` (Real, Integer,
    Boolean); Reals as the shortest text that reads back as the same double.

    Parameters
    ----------
    value : float or int or bool
        The value, in the variable's unit.
    vtype : {"Real", "Integer", "Boolean"}
        The FMI type of the attribute.

    Returns
    -------
    str
        ``"true"``/``"false"``, an integer, or ``repr`` of the float.
    """
    if vtype == "Boolean":
        return "true" if value else "false"
    if vtype == "Integer":
        return str(int(value))
    return repr(float(value))


def model_description(model: Model, caps: Capabilities) -> Element:
    """The modelDescription element tree, its ``guid`` :func:`description_guid` of itself.

    Parameters
    ----------
    model : Model
        The model: its variables, units, default experiment and output dependencies.
    caps : Capabilities
        The backend's CoSimulation attributes (:func:`capabilities`).

    Returns
    -------
    xml.etree.ElementTree.Element
        The ``fmiModelDescription`` root element.
    """
    root = Element("fmiModelDescription", {
        "fmiVersion": "2.0", "modelName": model.name, "guid": "",
        "description": model.description, "version": model_version(model), "generationTool": caps.generation_tool,
        "variableNamingConvention": "structured", "numberOfEventIndicators": "0"})
    cosim = SubElement(root, "CoSimulation", {
        "modelIdentifier": caps.model_identifier,
        "needsExecutionTool": str(caps.needs_execution_tool).lower(),
        "canHandleVariableCommunicationStepSize": "true",
        "canInterpolateInputs": "false",
        "canBeInstantiatedOnlyOncePerProcess": "false",
        "canNotUseMemoryManagementFunctions": "true",
        "canGetAndSetFMUstate": str(caps.can_get_and_set_fmu_state).lower(),
        "canSerializeFMUstate": str(caps.can_serialize_fmu_state).lower(),
    })
    if caps.source_files:
        files = SubElement(cosim, "SourceFiles")
        for name in caps.source_files:
            SubElement(files, "File", {"name": name})
    unit_definitions(root, {v.unit for v in model.variables if v.type == "Real"})
    cats = SubElement(root, "LogCategories")
    for name, desc in LOG_CATEGORIES.items():
        SubElement(cats, "Category", {"name": name, "description": desc})
    SubElement(root, "DefaultExperiment", {
        "startTime": "0.0", "stopTime": repr(float(model.default_stop_time)),
        "stepSize": repr(float(model.default_step_size))})

    if model.driven_inputs:
        tool = SubElement(SubElement(root, "VendorAnnotations"), "Tool", {"name": ANNOTATION_TOOL})
        listed = SubElement(tool, "DrivenInputs")  # the schema allows one element in a Tool
        for name in model.driven_inputs:
            SubElement(listed, "Input", {"name": name})
    mvars = SubElement(root, "ModelVariables")
    variables = model.variables
    for row, v in zip(variable_table(model), variables):
        attrs = {"name": v.name, "valueReference": str(row["vr"]), "description": v.description}
        roles, typed = variable_attributes(v, row["kind"])
        sv = SubElement(mvars, "ScalarVariable", {**attrs, **roles})
        SubElement(sv, v.type, typed)

    index = {v.name: i + 1 for i, v in enumerate(variables)}
    structure = SubElement(root, "ModelStructure")
    if model.outputs:
        outs = SubElement(structure, "Outputs")
        for name, deps in model.output_dependencies().items():
            _unknown(outs, index[name], [index[d] for d in deps])
        init = SubElement(structure, "InitialUnknowns")
        for name, deps in model.initial_output_dependencies().items():
            _unknown(init, index[name], [index[d] for d in deps])
    root.set("guid", description_guid(model, root))
    return root


def unit_definitions(root: Element, units: set[str]) -> None:
    """Append ``<UnitDefinitions>`` of ``units`` (sorted; each with its SI base unit exponents,
    :data:`satfmu.fmus.units.UNITS`) to ``root``: the same element in FMI 2.0 and FMI 3.0.

    Parameters
    ----------
    root : Element
        The ``fmiModelDescription`` element.
    units : set of str
        The unit names the description uses.
    """
    element = SubElement(root, "UnitDefinitions")
    for name in sorted(units):
        unit = SubElement(element, "Unit", {"name": name})
        base = UNITS[name]
        if base is not None:
            SubElement(unit, "BaseUnit", {k: repr(e) if isinstance(e, float) else str(e) for k, e in base.items()})


def variable_attributes(v: Variable, kind: int) -> tuple[dict[str, str], dict[str, str]]:
    """The attributes of an FMU variable of ``kind`` (a parameter, input or output) that FMI 2.0
    and FMI 3.0 share.

    Parameters
    ----------
    v : Variable
        The model variable.
    kind : int
        ``KIND_PARAMETER``, ``KIND_INPUT`` or ``KIND_OUTPUT`` of :mod:`satfmu.fmus.codegen`.

    Returns
    -------
    roles : dict of str to str
        ``causality``, ``variability`` and (parameters, outputs) ``initial``.
    typed : dict of str to str
        ``start`` (parameters and inputs), ``unit`` (Real), ``min`` and ``max`` (Real and
        Integer, when set): the type element's attributes in FMI 2.0, the variable's own in FMI 3.0.
    """
    typed: dict[str, str] = {}
    if kind == KIND_PARAMETER:
        roles = {"causality": "parameter", "variability": "fixed", "initial": "exact"}
        typed["start"] = xml_value(v.start, v.type)
    elif kind == KIND_INPUT:
        roles = {"causality": "input", "variability": "continuous" if v.type == "Real" else "discrete"}
        typed["start"] = xml_value(v.start, v.type)
    else:
        roles = {"causality": "output", "variability": "continuous" if v.type == "Real" else "discrete",
                 "initial": "calculated"}
    if v.type == "Real":
        typed["unit"] = v.unit
    if v.type in ("Real", "Integer"):
        if v.min is not None:
            typed["min"] = xml_value(v.min, v.type)
        if v.max is not None:
            typed["max"] = xml_value(v.max, v.type)
    return roles, typed


def _unknown(parent: Element, index: int, deps: list[int]) -> None:
    attrs = {"index": str(index), "dependencies": " ".join(map(str, sorted(deps)))}
    if deps:
        attrs["dependenciesKind"] = " ".join(["dependent"] * len(deps))
    SubElement(parent, "Unknown", attrs)


def to_xml_bytes(root: Element) -> bytes:
    """Indented UTF-8 XML document. ElementTree writes a line break, tab or carriage return in
    an attribute as a character reference, so a description keeps its lines (a literal line
    break in an attribute would read back as a space).

    Parameters
    ----------
    root : xml.etree.ElementTree.Element
        The ``fmiModelDescription`` element (:func:`model_description`); not changed (a copy
        is indented).

    Returns
    -------
    bytes
        The ``modelDescription.xml`` file's content, with its XML declaration.
    """
    root = copy.deepcopy(root)
    indent(root, "  ")
    return b'<?xml version="1.0" encoding="UTF-8"?>\n' + tostring(root, "unicode").encode() + b"\n"



