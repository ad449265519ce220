"""The model-exchange descriptions of a plant: FMI 2.0 (``<name>_me.fmu``, ``fmus/c/fmi2_me.c``)
and FMI 3.0 (``<name>_me_fmi3.fmu``, ``fmus/c/fmi3_me.c``).

The FMI 2.0 one is the co-simulation description (:func:`satfmu.fmus.description.model_description`: the same
variables, value references, units and output dependencies) with ``<ModelExchange>`` in place of
``<CoSimulation>``, the number of event indicators (:func:`satfmu.fmus.events.event_indicators`)
and, after the co-simulation FMU's variables, the continuous states no output carries (local
variables, value references ``NV + NX + i``) and the state derivatives ``der(<state>)`` (value
references ``NV + i``), listed under ``<Derivatives>`` and ``<InitialUnknowns>``. The FMU states
are not provided: the state at the last event (the mode a frozen law reads) is not part of them.

The FMI 3.0 one (:func:`model_description3_me`) is likewise the FMI 3.0 co-simulation description
(:func:`satfmu.fmus.description3.model_description3`) with ``<ModelExchange>``: each group of states
that is an FMI 3.0 variable (:func:`satfmu.fmus.arrays.state_arrays`) has its derivative array
``der(<name>)`` (value reference ``NA + 1 + g``; ``NA`` the co-simulation FMU's variables), the
groups no output carries a local variable (``NA + 1 + NG + g``), and the event indicators are the
local array ``event_indicators`` (``NA + 1 + 2 NG``), listed under ``<EventIndicator>`` as FMI 3.0
asks.
"""
from __future__ import annotations

from xml.etree.ElementTree import Element, SubElement

from satfmu.fmus.arrays import array_variables, state_arrays
from satfmu.fmus.codegen import event_function, variable_table
from satfmu.fmus.description import NATIVE, capabilities, description_guid, model_description
from satfmu.fmus.description3 import model_description3
from satfmu.fmus.model import Model

ME_SUFFIX = "_me"
"""File-name and modelIdentifier suffix of a model-exchange FMU (``mrp_satellite_me.fmu``)."""
WRAPPER_ME_SOURCE = "fmi2_me.c"
"""The model-exchange wrapper (``fmus/c/fmi2_me.c``), the FMU's one translation unit."""
WRAPPER3_ME_SOURCE = "fmi3_me.c"
"""The FMI 3.0 model-exchange wrapper (``fmus/c/fmi3_me.c``), the FMU's one translation unit."""
INDICATORS_NAME = "event_indicators"
"""The FMI 3.0 name of the event indicators' variable."""


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


def model_description3_me(model: Model, model_identifier: str) -> Element:
    """The FMI 3.0 model-exchange ``fmiModelDescription`` of ``model`` (see the module docstring).

    Parameters
    ----------
    model : Model
        A model with a C form, no sampler, and states that form FMI 3.0 variables.
    model_identifier : str
        The ``modelIdentifier`` (the model's name, :data:`ME_SUFFIX` and
        :data:`satfmu.fmus.description3.FMI3_SUFFIX`).

    Returns
    -------
    xml.etree.ElementTree.Element
        The root element, its ``instantiationToken``
        :func:`satfmu.fmus.description.description_guid` of itself.

    Raises
    ------
    ValueError
        If the states do not form FMI 3.0 variables (:func:`satfmu.fmus.arrays.state_arrays`), or
        a model variable has a name this description gives to another (``time``,
        :data:`INDICATORS_NAME`, ``der(...)``).
    """
    groups = state_arrays(model)
    names = {a.name for a in array_variables(model)}
    taken = {INDICATORS_NAME, *(f"der({g.name})" for g in groups)} & names
    if taken:
        raise ValueError(f"model {model.name!r} has a variable named {sorted(taken)[0]!r}, which its FMI 3.0 "
                         "model-exchange description gives to another variable; rename it")
    root = model_description3(model, model_identifier)
    cosim = root.find("CoSimulation")
    assert cosim is not None
    position = list(root).index(cosim)
    root.remove(cosim)
    root.insert(position, Element("ModelExchange", {
        "modelIdentifier": model_identifier, "needsExecutionTool": "false", "needsCompletedIntegratorStep": "false",
        "canBeInstantiatedOnlyOncePerProcess": "false", "canGetAndSetFMUState": "false",
        "canSerializeFMUState": "false", "providesDirectionalDerivatives": "false"}))
    variables = root.find("ModelVariables")
    structure = root.find("ModelStructure")
    assert variables is not None and structure is not None
    n_a, n_g = len(array_variables(model)), len(groups)

    def array(name: str, vr: int, size: int, is_array: bool, description: str, **extra: str) -> None:
        element = SubElement(variables, "Float64", {
            "name": name, "valueReference": str(vr), "description": description, "causality": "local",
            "variability": "continuous", **extra})
        if is_array:
            SubElement(element, "Dimension", {"start": str(size)})

    state_vr = []
    for g, group in enumerate(groups):
        v = model.states[group.first].variable
        if group.carrier is None:
            array(group.name, n_a + 1 + n_g + g, group.size, group.is_array, v.description, initial="calculated",
                  **({"unit": v.unit} if v.unit != "1" else {}))
        state_vr.append(group.carrier if group.carrier is not None else n_a + 1 + n_g + g)
    for g, group in enumerate(groups):
        v = model.states[group.first].variable
        array(f"der({group.name})", n_a + 1 + g, group.size, group.is_array,
              f"time derivative of {group.name} ({v.unit} per second)", initial="calculated",
              derivative=str(state_vr[g]))
    n_z = len(event_function(model).results)
    if n_z:
        array(INDICATORS_NAME, n_a + 1 + 2 * n_g, n_z, True, "the event indicators (zero crossings: where the "
              "right-hand side or the post-step map switches), with their hysteresis offsets",
              initial="calculated")

    outputs = [u for u in structure if u.tag == "Output"]
    initial = [u for u in structure if u.tag == "InitialUnknown"]
    listed = {int(u.get("valueReference", "0")) for u in initial}
    new_initial = sorted({n_a + 1 + g for g in range(n_g)}
                         | {n_a + 1 + n_g + g for g, group in enumerate(groups) if group.carrier is None}
                         | {vr for vr in state_vr if vr not in listed} - listed)
    structure[:] = (outputs + [Element("ContinuousStateDerivative", {"valueReference": str(n_a + 1 + g)})
                               for g in range(n_g)]
                    + sorted(initial + [Element("InitialUnknown", {"valueReference": str(vr)}) for vr in new_initial],
                             key=lambda u: int(u.get("valueReference", "0")))
                    + ([Element("EventIndicator", {"valueReference": str(n_a + 1 + 2 * n_g)})] if n_z else []))
    root.set("instantiationToken", "")
    root.set("instantiationToken", description_guid(model, root, "instantiationToken"))
    return root
