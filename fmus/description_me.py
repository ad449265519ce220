"""The FMI 2.0 model-exchange description of a plant (``<name>_me.fmu``, ``fmus/c/fmi2_me.c``).

It is the co-simulation description (:func:`satfmu.fmus.description.model_description`: the same
variables, value references, units and output dependencies) with ``<ModelExchange>`` in place of
``<CoSimulation>``, the number of event indicators (:func:`satfmu.fmus.events.event_indicators`)
and, after the co-simulation FMU's variables, the continuous states no output carries (local
variables, value references ``NV + NX + i``) and the state derivatives ``der(<state>)`` (value
references ``NV + i``), listed under ``<Derivatives>`` and ``<InitialUnknowns>``. The FMU states
are not provided: the state at the last event (the mode a frozen law reads) is not part of them.
"""
from __future__ import annotations

from xml.etree.ElementTree import Element, SubElement

from satfmu.fmus.codegen import event_function, variable_table
from satfmu.fmus.description import NATIVE, capabilities, description_guid, model_description
from satfmu.fmus.model import Model

ME_SUFFIX = "_me"
"""File-name and modelIdentifier suffix of a model-exchange FMU (``mrp_satellite_me.fmu``)."""
WRAPPER_ME_SOURCE = "fmi2_me.c"
"""The model-exchange wrapper (``fmus/c/fmi2_me.c``), the FMU's one translation unit."""


def model_description_me(model: Model) -> Element:
    """The FMI 2.0 model-exchange ``fmiModelDescription`` of ``model`` (see the module docstring).

    Parameters
    ----------
    model : Model
        A model with a C form.

    Returns
    -------
    xml.etree.ElementTree.Element
        The root element, its ``guid`` :func:`satfmu.fmus.description.description_guid` of itself.
    """
    root = model_description(model, capabilities(model, NATIVE))
    identifier = model.name + ME_SUFFIX
    cosim = root.find("CoSimulation")
    assert cosim is not None
    position = list(root).index(cosim)
    root.remove(cosim)
    me = Element("ModelExchange", {
        "modelIdentifier": identifier, "needsExecutionTool": "false", "completedIntegratorStepNotNeeded": "true",
        "canBeInstantiatedOnlyOncePerProcess": "false", "canNotUseMemoryManagementFunctions": "true",
        "canGetAndSetFMUstate": "false", "canSerializeFMUstate": "false", "providesDirectionalDerivative": "false"})
    SubElement(SubElement(me, "SourceFiles"), "File", {"name": WRAPPER_ME_SOURCE})
    root.insert(position, me)
    root.set("numberOfEventIndicators", str(len(event_function(model).results)))

    variables = root.find("ModelVariables")
    structure = root.find("ModelStructure")
    assert variables is not None and structure is not None
    n_v, n_x = len(variable_table(model)), len(model.states)
    index = {sv.get("name"): i + 1 for i, sv in enumerate(variables)}
    for i, state in enumerate(model.states):
        v = state.variable
        if v.name in index:
            continue
        sv = SubElement(variables, "ScalarVariable", {
            "name": v.name, "valueReference": str(n_v + n_x + i), "description": v.description,
            "causality": "local", "variability": "continuous", "initial": "calculated"})
        SubElement(sv, "Real", {"unit": v.unit} if v.unit != "1" else {})
        index[v.name] = len(index) + 1
    derivative_index = []
    for i, state in enumerate(model.states):
        v = state.variable
        sv = SubElement(variables, "ScalarVariable", {
            "name": f"der({v.name})", "valueReference": str(n_v + i),
            "description": f"time derivative of {v.name} ({v.unit} per second)",
            "causality": "local", "variability": "continuous", "initial": "calculated"})
        SubElement(sv, "Real", {"derivative": str(index[v.name])})
        index[f"der({v.name})"] = len(index) + 1
        derivative_index.append(index[f"der({v.name})"])

    initial = structure.find("InitialUnknowns")
    if initial is not None:
        structure.remove(initial)
    else:
        initial = Element("InitialUnknowns")
    if model.states:
        derivatives = SubElement(structure, "Derivatives")
        for k in derivative_index:
            SubElement(derivatives, "Unknown", {"index": str(k)})
    listed = {int(u.get("index", "0")) for u in initial}
    wanted = sorted({index[s.variable.name] for s in model.states} - listed | set(derivative_index))
    for k in wanted:
        SubElement(initial, "Unknown", {"index": str(k)})
    initial[:] = sorted(initial, key=lambda u: int(u.get("index", "0")))
    if len(initial):
        structure.append(initial)
    root.set("guid", "")
    root.set("guid", description_guid(model, root))
    return root
