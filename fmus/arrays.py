"""The FMI 3.0 variables of a model: its vectors as arrays, the rest as scalars.

FMI 2.0 has scalar variables only, so a model's vectors are scalars named ``b_body[1]``,
``b_body[2]``, ... (structured naming). FMI 3.0 has arrays: a run of scalars named
``<base>[1]`` .. ``<base>[n]``, consecutive in value-reference order, of one kind (parameter,
input, output), one type, one unit and one range becomes the array ``<base>`` of ``n``
elements, one value reference, its start values a list. Anything else (a two-index name such as
``J[1,2]``, elements that differ in unit or range, a base name some scalar already has) stays a
scalar. The FMI 3.0 description (:mod:`satfmu.fmus.description3`) and the C wrapper's table of
array variables (``ARRAYS`` in the generated ``model.h``) both come from :func:`array_variables`,
so the value references agree by construction.
"""
from __future__ import annotations

import os
import re
from dataclasses import dataclass

from satfmu.fmus.model import Model, Variable

_ELEMENT = re.compile(r"^(?P<base>[A-Za-z_][A-Za-z0-9_]*)\[(?P<index>[1-9][0-9]*)\]$")


@dataclass(frozen=True)
class ArrayVariable:
    """One FMI 3.0 variable: an array of FMI 2.0 scalars, or one scalar.

    Attributes
    ----------
    name : str
        The FMI 3.0 name: the base name of an array (``"b_body"``), a scalar's own name.
    first : int
        The index of its first element in :func:`satfmu.fmus.codegen.variable_table` (its FMI 2.0
        value reference).
    size : int
        The number of elements (1 for a scalar).
    is_array : bool
        Whether it is an array (with a ``<Dimension>``); a one-element array is one.
    description : str
        The array's description, from its elements' (:func:`array_description`).
    """

    name: str
    first: int
    size: int
    is_array: bool
    description: str


def array_description(descriptions: list[str]) -> str:
    """One description for an array from its elements' ones.

    Element descriptions that differ only in the element number (``"... body axis 1 (...)"``,
    ``"... body axis 2 (...)"``) give ``"... body axis 1..n (...)"``; others are joined with
    ``"; "``.

    Parameters
    ----------
    descriptions : list of str
        The elements' descriptions, in element order.

    Returns
    -------
    str
        The array's description.
    """
    if len(set(descriptions)) == 1:
        return descriptions[0]
    prefix = os.path.commonprefix(descriptions)
    suffix = os.path.commonprefix([d[len(prefix):][::-1] for d in descriptions])[::-1]
    middles = [d[len(prefix):len(d) - len(suffix)] for d in descriptions]
    numbers = [str(i + 1) for i in range(len(descriptions))]
    if middles == numbers:
        return f"{prefix}1..{len(descriptions)}{suffix}"
    return "; ".join(descriptions)


def _element(v: Variable) -> tuple[str, int] | None:
    m = _ELEMENT.match(v.name)
    return (m.group("base"), int(m.group("index"))) if m else None


def _kinds(model: Model) -> list[int]:
    """The kind of each FMI 2.0 variable (0 parameter, 1 input, 2 output: the order of
    :func:`satfmu.fmus.codegen.variable_table`)."""
    return [0] * len(model.parameters) + [1] * len(model.inputs) + [2] * len(model.outputs)


def _same_kind(kinds: list[int], variables: list[Variable], i: int, j: int) -> bool:
    a, b = variables[i], variables[j]
    return kinds[i] == kinds[j] and a.type == b.type and a.unit == b.unit and a.min == b.min and a.max == b.max


def array_variables(model: Model) -> list[ArrayVariable]:
    """The model's FMI 3.0 variables in value-reference order (the i-th has value reference i).

    Parameters
    ----------
    model : Model
        The model; its FMI 2.0 variables are :func:`satfmu.fmus.codegen.variable_table`.

    Returns
    -------
    list of ArrayVariable
        Arrays for the runs ``<base>[1]`` .. ``<base>[n]`` (see the module docstring), scalars
        for the rest; together they cover every FMI 2.0 variable once, in order.
    """
    variables = model.variables
    kinds = _kinds(model)
    taken = {v.name for v in variables}
    out: list[ArrayVariable] = []
    i = 0
    while i < len(variables):
        head = _element(variables[i])
        j = i + 1
        if head is not None and head[1] == 1 and head[0] not in taken:
            while (j < len(variables) and _element(variables[j]) == (head[0], j - i + 1)
                   and _same_kind(kinds, variables, i, j)):
                j += 1
            # an array only if no later scalar continues the numbering elsewhere
            if not any(_element(v) is not None and _element(v)[0] == head[0]  # type: ignore[index]
                       for v in variables[:i] + variables[j:]):
                out.append(ArrayVariable(head[0], i, j - i, True,
                                         array_description([v.description for v in variables[i:j]])))
                taken.add(head[0])
                i = j
                continue
            j = i + 1
        out.append(ArrayVariable(variables[i].name, i, 1, False, variables[i].description))
        i = j
    return out


@dataclass(frozen=True)
class StateArray:
    """A group of a model's continuous states that is one FMI 3.0 variable (an array or a scalar).

    Attributes
    ----------
    name : str
        The FMI 3.0 name of the states' variable (``"sigma"`` for ``sigma[1..3]``).
    first : int
        The index of its first state in ``model.states``.
    size : int
        The number of states.
    is_array : bool
        Whether the variable is an array.
    carrier : int or None
        The FMI 3.0 value reference of the model variable that carries these states (an output of
        the same name and size), or None when no variable does (the model-exchange description then
        lists them as a local variable).
    """

    name: str
    first: int
    size: int
    is_array: bool
    carrier: int | None


def state_arrays(model: Model) -> list[StateArray]:
    """The model's continuous states as FMI 3.0 variables, in state order (the continuous-state
    vector of its model-exchange FMU).

    A run of states named ``<base>[1]`` .. ``<base>[n]`` is one array, any other state a scalar;
    each is the FMI 3.0 variable of that name (:func:`array_variables`) when the model has one,
    which must then hold exactly those states.

    Parameters
    ----------
    model : Model
        The model.

    Returns
    -------
    list of StateArray
        The groups, covering ``model.states`` once, in order.

    Raises
    ------
    ValueError
        If a group's name is an FMI 3.0 variable of other elements (``omega`` of 3 elements, the
        states ``omega[1]`` and ``omega[2]`` only): its derivative could not be that variable's.
    """
    arrays = {a.name: (k + 1, a) for k, a in enumerate(array_variables(model))}
    names = [s.variable.name for s in model.states]
    out: list[StateArray] = []
    i = 0
    while i < len(names):
        head = _element(model.states[i].variable)
        j = i + 1
        if head is not None and head[1] == 1:
            while j < len(names) and _element(model.states[j].variable) == (head[0], j - i + 1):
                j += 1
        name = head[0] if head is not None and head[1] == 1 else names[i]
        is_array = head is not None and head[1] == 1
        carrier = arrays.get(name)
        if carrier is not None:
            vr, a = carrier
            elements = [model.variables[a.first + k].name for k in range(a.size)]
            if elements != names[i:j] or a.is_array != is_array:
                raise ValueError(f"model {model.name!r}: the states {', '.join(names[i:j])} do not form its FMI 3.0 "
                                 f"variable {name!r} ({', '.join(elements)}); name the states after whole vectors "
                                 "to give it a model-exchange FMI 3.0 FMU")
        out.append(StateArray(name, i, j - i, is_array, carrier[0] if carrier is not None else None))
        i = j
    return out
