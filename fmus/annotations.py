"""satfmu's annotation in a model description: the inputs a co-simulation must drive.

A model with ``driven_inputs`` (:class:`satfmu.fmus.model.Model`) lists them in its FMU's
description (:mod:`satfmu.fmus.description`, :mod:`satfmu.fmus.description3` write it);
:func:`driven_inputs` reads the list back from any FMU's description, without the generators.
"""
from __future__ import annotations

from xml.etree.ElementTree import fromstring

ANNOTATION_TOOL = "satfmu"
"""``name`` of the description's ``VendorAnnotations/Tool`` that lists the model's driven inputs
(``driven_inputs`` of :class:`satfmu.fmus.model.Model`): ``<DrivenInputs>`` holding one ``<Input name="..."/>``
each."""


def driven_inputs(description: bytes) -> list[str]:
    """The inputs an FMU says a co-simulation must drive: the ``DrivenInputs/Input`` names of its
    ``VendorAnnotations`` tool :data:`ANNOTATION_TOOL` (FMI 2.0) or its ``Annotations`` annotation
    of that type (FMI 3.0, where they name arrays); empty for an FMU without them.

    Parameters
    ----------
    description : bytes
        The FMU's ``modelDescription.xml``, already checked (:func:`satfmu.fmus.archive.check`).

    Returns
    -------
    list of str
        Variable names, in the description's order.
    """
    root = fromstring(description)
    tools = [t for t in root.findall("VendorAnnotations/Tool") if t.get("name") == ANNOTATION_TOOL]
    tools += [a for a in root.findall("Annotations/Annotation") if a.get("type") == ANNOTATION_TOOL]
    return [str(e.get("name")) for tool in tools for e in tool.findall("DrivenInputs/Input") if e.get("name")]
