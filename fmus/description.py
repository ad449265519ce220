"""FMI 2.0 modelDescription.xml of a :class:`fmus.model.Model`, for both backends.

The native FMU and the pythonfmu FMU of one model share this description (only
the modelIdentifier and capability flags differ), so their variables, value
references, units and ModelStructure are identical by construction.
"""
from __future__ import annotations

from dataclasses import dataclass
from xml.dom import minidom
from xml.etree.ElementTree import Element, SubElement, tostring

from fmus import __version__
from fmus.codegen import KIND_INPUT, KIND_PARAMETER, model_guid, variable_table
from fmus.model import UNITS, Model

LOG_CATEGORIES = {
    "logStatusWarning": "Messages with status fmi2Warning",
    "logStatusDiscard": "Messages with status fmi2Discard",
    "logStatusError": "Messages with status fmi2Error (bad input, wrong call order, ...)",
    "logStatusFatal": "Messages with status fmi2Fatal",
    "logAll": "All messages",
}


@dataclass(frozen=True)
class Capabilities:
    """CoSimulation attributes that differ between the backends."""

    model_identifier: str
    needs_execution_tool: bool = False
    can_get_and_set_fmu_state: bool = True
    can_serialize_fmu_state: bool = True
    generation_tool: str = f"satfmu {__version__}"


def xml_value(value: float | int | bool, vtype: str) -> str:
    """``value`` as the XML text of an FMI/SSP attribute of type ``vtype`` (Real, Integer,
    Boolean); Reals as the shortest text that reads back as the same double."""
    if vtype == "Boolean":
        return "true" if value else "false"
    if vtype == "Integer":
        return str(int(value))
    return repr(float(value))


def model_description(model: Model, caps: Capabilities) -> Element:
    """The modelDescription element tree."""
    root = Element("fmiModelDescription", {
        "fmiVersion": "2.0", "modelName": model.name, "guid": model_guid(model),
        "description": model.description, "generationTool": caps.generation_tool,
        "variableNamingConvention": "structured", "numberOfEventIndicators": "0"})
    SubElement(root, "CoSimulation", {
        "modelIdentifier": caps.model_identifier,
        "needsExecutionTool": str(caps.needs_execution_tool).lower(),
        "canHandleVariableCommunicationStepSize": "true",
        "canInterpolateInputs": "false",
        "canBeInstantiatedOnlyOncePerProcess": "false",
        "canNotUseMemoryManagementFunctions": "true",
        "canGetAndSetFMUstate": str(caps.can_get_and_set_fmu_state).lower(),
        "canSerializeFMUstate": str(caps.can_serialize_fmu_state).lower(),
    })
    units = SubElement(root, "UnitDefinitions")
    used = sorted({v.unit for v in model.variables if v.type == "Real"})
    for name in used:
        unit = SubElement(units, "Unit", {"name": name})
        SubElement(unit, "BaseUnit", {k: str(e) for k, e in UNITS[name].items()})
    cats = SubElement(root, "LogCategories")
    for name, desc in LOG_CATEGORIES.items():
        SubElement(cats, "Category", {"name": name, "description": desc})
    SubElement(root, "DefaultExperiment", {
        "startTime": "0.0", "stopTime": repr(float(model.default_stop_time)),
        "stepSize": repr(float(model.default_step_size))})

    mvars = SubElement(root, "ModelVariables")
    variables = model.variables
    for row, v in zip(variable_table(model), variables):
        attrs = {"name": v.name, "valueReference": str(row["vr"]), "description": v.description}
        typed: dict[str, str] = {}
        if row["kind"] == KIND_PARAMETER:
            attrs.update(causality="parameter", variability="fixed", initial="exact")
            typed["start"] = xml_value(v.start, v.type)
        elif row["kind"] == KIND_INPUT:
            attrs.update(causality="input", variability="continuous" if v.type == "Real" else "discrete")
            typed["start"] = xml_value(v.start, v.type)
        else:
            attrs.update(causality="output", variability="continuous" if v.type == "Real" else "discrete",
                         initial="calculated")
        if v.type == "Real":
            typed["unit"] = v.unit
        if v.type in ("Real", "Integer"):
            if v.min is not None:
                typed["min"] = xml_value(v.min, v.type)
            if v.max is not None:
                typed["max"] = xml_value(v.max, v.type)
        sv = SubElement(mvars, "ScalarVariable", attrs)
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
    return root


def _unknown(parent: Element, index: int, deps: list[int]) -> None:
    attrs = {"index": str(index), "dependencies": " ".join(map(str, sorted(deps)))}
    if deps:
        attrs["dependenciesKind"] = " ".join(["dependent"] * len(deps))
    SubElement(parent, "Unknown", attrs)


def to_xml_bytes(root: Element) -> bytes:
    """Pretty-printed UTF-8 XML document."""
    return minidom.parseString(tostring(root, "UTF-8")).toprettyxml(indent="  ", encoding="UTF-8")



