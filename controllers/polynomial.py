"""Controller "polynomial state feedback": u = sat(p(x)), p a polynomial map from an artifact.

The law's symbolic model is built from a validated :class:`satfmu.controllers.artifact.ControllerArtifact`;
the native and pythonfmu controller FMUs, and the in-process reference, are generated
from that model. Inputs are the measured states (named as in the artifact, so they
connect by name to the plant's outputs); outputs are the commands; parameters
``saturation_on`` and ``u_max`` clip every command to +-u_max inside the FMU.
"""
from __future__ import annotations

from pathlib import Path

import sympy as sp

from satfmu.controllers.artifact import KIND, ControllerArtifact, Term, load
from satfmu.fmus.errors import ArtifactError
from satfmu.fmus.model import Model, Output, Variable, saturate

ARTIFACTS = Path(__file__).resolve().parent / "artifacts"
DEFAULT_U_MAX = 5.0
"""``u_max`` of a controller FMU whose artifact records no torque limit: seed 000's 5 N m."""


def build(artifact: ControllerArtifact) -> Model:
    """Symbolic model of the controller described by ``artifact``.

    Parameters
    ----------
    artifact : ControllerArtifact
        The validated polynomial state feedback: its ``states`` become the model's inputs, its
        ``outputs`` the model's outputs, its ``terms`` the law.

    Returns
    -------
    Model
        The law ``u = sat(p(x))``, with the parameters ``saturation_on`` and ``u_max`` (in the
        unit of the first output; default the torque limit of the plant the design was made for,
        ``provenance.design_plant.limits.u_max``, else :data:`DEFAULT_U_MAX`).
    """
    inputs = [Variable(s["name"], s["unit"], f"Measured plant state {s['name']}") for s in artifact.states]
    sat_on = Variable("saturation_on", "1", "Clip every command to +-u_max", 0, "Boolean")
    limit = artifact.provenance.get("design_plant", {}).get("limits", {}).get("u_max", DEFAULT_U_MAX)
    u_max = Variable("u_max", artifact.outputs[0]["unit"], "Command limit per output (when saturation_on)",
                     float(limit), min=0.0)
    x = [v.symbol for v in inputs]
    outputs = []
    for out, terms in zip(artifact.outputs, artifact.terms):
        poly = sympy_polynomial(terms, x)
        var = Variable(out["name"], out["unit"], out.get("description", f"Command {out['name']}"))
        outputs.append(Output(var, saturate(poly, u_max.symbol, sat_on.symbol)))
    return Model(name=artifact.name, description=artifact.description, states=[], inputs=inputs,
                 driven_inputs=tuple(v.name for v in inputs),
                 parameters=[sat_on, u_max], outputs=outputs)


def sympy_polynomial(terms: list[Term], variables: list[sp.Symbol]) -> sp.Expr:
    """``sum c prod v_j^e_j`` with every coefficient at full double precision.

    Parameters
    ----------
    terms : list of Term
        The polynomial's monomials.
    variables : list of sympy.Symbol
        One symbol per variable, in the order of each term's exponents ``e``.

    Returns
    -------
    sympy.Expr
        The polynomial (0 for no terms).
    """
    return sp.Add(*[sp.Float(t.c, 17) * sp.Mul(*[v ** e for v, e in zip(variables, t.e)]) for t in terms])


def shipped_artifacts() -> list[Path]:
    """The controller artifacts shipped with satfmu (one controller FMU each)."""
    return sorted(ARTIFACTS.glob("*.json"))


def load_model(path: str | Path) -> Model:
    """Load, validate and build the controller model of an artifact file.

    Parameters
    ----------
    path : str or Path
        The artifact's JSON file, of kind ``polynomial_state_feedback``.

    Returns
    -------
    Model
        The controller's model (:func:`build`).

    Raises
    ------
    ArtifactError
        If the file is not a valid artifact, or is one of another kind than ``polynomial_state_feedback``.
    """
    artifact = load(path)
    if not isinstance(artifact, ControllerArtifact):
        raise ArtifactError(f"{path}: not a {KIND!r} artifact (a {type(artifact).__name__}), no polynomial law")
    return build(artifact)
