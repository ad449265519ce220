"""FMI 3.0 modelDescription.xml of a :class:`satfmu.fmus.model.Model` (the native FMI 3.0 FMU).

The same model, units, defaults and default experiment as its FMI 2.0 description
(:mod:`satfmu.fmus.description`), in FMI 3.0's terms:

* value reference 0 is the independent variable ``time`` (s); then the model's variables in
  FMI 2.0 order, its vectors as arrays (:func:`satfmu.fmus.arrays.array_variables`: ``b_body``
  with ``<Dimension start="3"/>`` for ``b_body[1..3]``); Real is ``Float64``, Integer ``Int32``;
* a sampled model (one with a ``sampler``, :class:`satfmu.fmus.model.Sampler`) has an input ``Clock``,
  ``sample_clock``, periodic with ``intervalVariability="fixed"`` and no ``intervalDecimal``: the
  importer reads its period and shift with ``fmi3GetIntervalDecimal`` and ``fmi3GetShiftDecimal``
  in Initialization Mode, since they follow the fixed parameters (the period, the phase);
* ``instantiationToken`` is :func:`satfmu.fmus.description.description_guid` of this description
  (another token than the FMI 2.0 FMU's GUID, which identifies another description); the
  ``modelIdentifier`` and the file name are the model's name and :data:`FMI3_SUFFIX`;
* the source files are listed in ``sources/buildDescription.xml`` (:func:`build_description`),
  as FMI 3.0 asks, not in the model description.
"""
from __future__ import annotations

from xml.etree.ElementTree import Element, SubElement

from satfmu.fmus.arrays import ArrayVariable, array_variables
from satfmu.fmus.codegen import variable_table
from satfmu.fmus.annotations import ANNOTATION_TOOL
from satfmu.fmus.description import (LOG_CATEGORIES, description_guid, model_version,
                                     unit_definitions, variable_attributes, xml_value)
from satfmu.fmus.model import Model
from satfmu.fmus import __version__

FMI3_SUFFIX = "_fmi3"
"""Suffix of an FMI 3.0 FMU's modelIdentifier (and file name) after the model's name: its binary
is then never mistaken for the FMI 2.0 one (a host that loads both by module name)."""
WRAPPER3_SOURCE = "fmi3.c"
"""The FMI 3.0 FMU's one source file, the wrapper ``fmus/c/fmi3.c``."""
CLOCK_NAME = "sample_clock"
"""The name of a sampled model's clock."""
TIME_NAME = "time"
"""The name of the independent variable (value reference 0)."""
TYPE_NAMES = {"Real": "Float64", "Integer": "Int32", "Boolean": "Boolean"}
"""FMI 3.0 type of each FMI 2.0 base type."""


def clock_reference(model: Model) -> int | None:
    """The value reference of ``model``'s sample clock in its FMI 3.0 FMU, or None without one.

    Parameters
    ----------
    model : Model
        The model.

    Returns
    -------
    int or None
        ``1 + len(array_variables(model))`` for a sampled model (the C wrapper's ``CLOCK_VR``).
    """
    return 1 + len(array_variables(model)) if model.sampler is not None else None


def _variable(parent: Element, model: Model, a: ArrayVariable, vr: int, rows: list[dict]) -> None:
    """The FMI 3.0 variable ``a`` (its elements' shared attributes, their start values as a list)."""
    v = model.variables[a.first]
    roles, typed = variable_attributes(v, rows[a.first]["kind"])
    if "start" in typed:
        typed["start"] = " ".join(xml_value(model.variables[a.first + j].start, v.type) for j in range(a.size))
    attrs = {"name": a.name, "valueReference": str(vr), "description": a.description, **roles, **typed}
    element = SubElement(parent, TYPE_NAMES[v.type], attrs)
    if a.is_array:
        SubElement(element, "Dimension", {"start": str(a.size)})


GENERATION_TOOL = f"satfmu {__version__}"
"""``generationTool`` of the descriptions satfmu writes."""


def model_description3(model: Model, model_identifier: str, generation_tool: str = GENERATION_TOOL) -> Element:
    """The FMI 3.0 modelDescription element tree, its ``instantiationToken`` computed from itself.

    Parameters
    ----------
    model : Model
        The model: its variables, units, default experiment, sampler and output dependencies.
    model_identifier : str
        The ``modelIdentifier`` (the model's name and :data:`FMI3_SUFFIX`).
    generation_tool : str, optional
        ``generationTool``. Default :data:`GENERATION_TOOL`.

    Returns
    -------
    xml.etree.ElementTree.Element
        The ``fmiModelDescription`` root element.

    Raises
    ------
    ValueError
        If a model variable is named :data:`TIME_NAME` or :data:`CLOCK_NAME` (the names FMI 3.0
        variables of this description take).
    """
    clashes = {TIME_NAME, CLOCK_NAME} & {v.name for v in model.variables}
    if clashes:
        raise ValueError(f"model {model.name!r} has a variable named {sorted(clashes)[0]!r}, which its FMI 3.0 "
                         "description gives to another variable; rename it")
    arrays = array_variables(model)
    rows = variable_table(model)
    sampled = model.sampler is not None
    root = Element("fmiModelDescription", {
        "fmiVersion": "3.0", "modelName": model.name, "instantiationToken": "",
        "description": model.description, "version": model_version(model), "generationTool": generation_tool,
        "variableNamingConvention": "structured"})
    SubElement(root, "CoSimulation", {
        "modelIdentifier": model_identifier,
        "canBeInstantiatedOnlyOncePerProcess": "false",
        "canGetAndSetFMUState": "true",
        "canSerializeFMUState": "true",
        "canHandleVariableCommunicationStepSize": "true",
        "hasEventMode": "true",
        "mightReturnEarlyFromDoStep": str(sampled).lower(),
    })
    unit_definitions(root, {v.unit for v in model.variables if v.type == "Real"} | {"s"})  # s: time
    cats = SubElement(root, "LogCategories")
    for name, desc in LOG_CATEGORIES.items():
        SubElement(cats, "Category", {"name": name, "description": desc.replace("fmi2", "fmi3")})
    SubElement(root, "DefaultExperiment", {
        "startTime": "0.0", "stopTime": repr(float(model.default_stop_time)),
        "stepSize": repr(float(model.default_step_size))})
    vr_of = {}  # FMI 2.0 variable index -> FMI 3.0 value reference
    for k, a in enumerate(arrays):
        for j in range(a.size):
            vr_of[a.first + j] = k + 1
    mvars = SubElement(root, "ModelVariables")
    SubElement(mvars, "Float64", {"name": TIME_NAME, "valueReference": "0", "causality": "independent",
                                  "variability": "continuous", "description": "Simulation time", "unit": "s"})
    for k, a in enumerate(arrays):
        _variable(mvars, model, a, k + 1, rows)
    if sampled:
        SubElement(mvars, "Clock", {"name": CLOCK_NAME, "valueReference": str(clock_reference(model)),
                                    "causality": "input", "variability": "discrete", "intervalVariability": "fixed",
                                    "description": "The sampler's instants (period and phase from the parameters); "
                                                   "activated by the importer in Event Mode"})
    structure = SubElement(root, "ModelStructure")
    index = {v.name: i for i, v in enumerate(model.variables)}
    for tag, deps_of in (("Output", model.output_dependencies()), ("InitialUnknown",
                                                                   model.initial_output_dependencies())):
        seen: set[int] = set()
        for name, deps in deps_of.items():
            vr = vr_of[index[name]]
            if vr in seen:
                continue
            seen.add(vr)
            members = [n for n in deps_of if vr_of[index[n]] == vr]
            refs = sorted({vr_of[index[d]] for n in members for d in deps_of[n]})
            attrs = {"valueReference": str(vr), "dependencies": " ".join(map(str, refs))}
            if refs:
                attrs["dependenciesKind"] = " ".join(["dependent"] * len(refs))
            SubElement(structure, tag, attrs)
    if model.driven_inputs:  # FMI 3.0's Annotations, last (FMI 2.0: VendorAnnotations/Tool)
        note = SubElement(SubElement(root, "Annotations"), "Annotation", {"type": ANNOTATION_TOOL})
        listed = SubElement(note, "DrivenInputs")
        for name in dict.fromkeys(arrays[vr_of[index[n]] - 1].name for n in model.driven_inputs):
            SubElement(listed, "Input", {"name": name})
    root.set("instantiationToken", description_guid(model, root, "instantiationToken"))
    return root


def build_description(model_identifier: str, source: str = WRAPPER3_SOURCE) -> Element:
    """``sources/buildDescription.xml`` of an FMI 3.0 FMU: its one source file, C99.

    Parameters
    ----------
    model_identifier : str
        The FMU's ``modelIdentifier``.
    source : str, optional
        The source file: the co-simulation wrapper (default :data:`WRAPPER3_SOURCE`) or the
        model-exchange one (:data:`satfmu.fmus.description_me.WRAPPER3_ME_SOURCE`).

    Returns
    -------
    xml.etree.ElementTree.Element
        The ``fmiBuildDescription`` root element.
    """
    root = Element("fmiBuildDescription", {"fmiVersion": "3.0"})
    config = SubElement(root, "BuildConfiguration", {"modelIdentifier": model_identifier})
    files = SubElement(config, "SourceFileSet", {"language": "C99"})
    SubElement(files, "SourceFile", {"name": source})
    return root
