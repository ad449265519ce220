"""The environment's torques on a spacecraft, from its own attitude and the orbit model's outputs.

The plant takes the environment in inertial axes (the outputs of
:mod:`satfmu.fmus.environment.orbit`: position ``r``, air-relative velocity ``v_air``, the unit
vector to the Sun ``sun`` and its distance, ``sunlit``, the field ``b``, the ``density``) and turns
it into body axes with its attitude ``C`` (inertial to body). In body axes, with ``r_k`` each
facet's centre of pressure, ``n_k`` its outward normal and ``A_k`` its area:

- gravity gradient: ``3 mu / |r|^5 (r x J r)``, ``J`` the whole spacecraft's inertia;
- aerodynamic drag, flat plates in free molecular flow: ``F_k = -1/2 rho Cd_k A_k |v|^2
  max(0, n_k . v_hat) v_hat``, torque ``sum r_k x F_k``;
- solar radiation pressure: with ``cos = n_k . s`` (``s`` towards the Sun) and the pressure
  ``P = P_1AU (1 AU / d)^2 sunlit``, for ``cos > 0``: ``F_k = -P A_k cos ((1 - rho_s) s + 2 (rho_s cos +
  rho_d / 3) n_k)`` (specular ``rho_s``, diffuse ``rho_d``, the rest absorbed; Montenbruck and
  Gill), torque ``sum r_k x F_k``;
- residual dipole: ``m x b``.

Each torque is switched by a Boolean parameter (off by default: a plant without the orbit FMU
connected is today's plant) and is an output.
"""
from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from satfmu.fmus.environment.constants import ASTRONOMICAL_UNIT, EQUATORIAL_RADIUS, MU_EARTH
from satfmu.fmus.model import Output, Variable, symbols, vector
from satfmu.fmus.plants.spacecraft import Spacecraft

SOLAR_PRESSURE = 4.56e-6
"""Solar radiation pressure at 1 AU, N/m^2 (1361 W/m^2 / c)."""
TORQUES = ("gravity_gradient", "drag", "srp", "dipole")
"""The environment torques, by the name of their switch (``<name>_on``) and output (``tau_<name>``)."""


@dataclass
class EnvironmentTorques:
    """The plant's environment inputs, parameters, torque outputs and the total torque.

    Attributes
    ----------
    inputs : list of Variable
        ``r[1..3]`` (m), ``v_air[1..3]`` (m/s), ``sun[1..3]``, ``sun_distance`` (m), ``sunlit``,
        ``b[1..3]`` (T), ``density`` (kg/m^3), inertial axes.
    parameters : list of Variable
        The switches, the facets' ``facet_area[k]``, ``facet_normal[j,k]``, ``facet_cp[j,k]``,
        ``drag_coefficient[k]``, ``specular[k]``, ``diffuse[k]``, ``m_res[1..3]`` and ``solar_pressure``.
    outputs : list of Output
        ``tau_<name>[1..3]`` per torque, body axes, N m.
    definitions : list of (sympy.Symbol, sympy.Expr)
        The switched torques, evaluated once (the outputs and ``total`` read their symbols).
    total : sympy.Matrix
        The sum of the switched-on torques, body axes (3 x 1), N m.
    """

    inputs: list[Variable]
    parameters: list[Variable]
    outputs: list[Output]
    definitions: list[tuple[sp.Symbol, sp.Expr]]
    total: sp.Matrix


def build(spacecraft: Spacecraft, C: sp.Matrix, J: sp.Matrix) -> EnvironmentTorques:
    """The environment torques of ``spacecraft`` at the attitude ``C``.

    Parameters
    ----------
    spacecraft : Spacecraft
        Its facets (their number fixes the model's) and residual dipole give the defaults.
    C : sympy.Matrix
        The attitude, inertial to body (3 x 3), in the plant's symbols (best: symbols of definitions,
        so that the torques' expressions stay small).
    J : sympy.Matrix
        The whole spacecraft's inertia (3 x 3), kg m^2, in the plant's symbols.

    Returns
    -------
    EnvironmentTorques
        Inputs, parameters, outputs and total torque to add to the plant.
    """
    facets = spacecraft.facets
    nf = len(facets)
    r_in = vector("r", 3, "m", "Position, inertial axis {i} (from the orbit model)",
                  [EQUATORIAL_RADIUS + 500e3, 0.0, 0.0])
    v_in = vector("v_air", 3, "m/s", "Velocity relative to the atmosphere, inertial axis {i}")
    s_in = vector("sun", 3, "1", "Unit vector to the Sun, inertial axis {i}", [1.0, 0.0, 0.0])
    d_in = Variable("sun_distance", "m", "Distance to the Sun", ASTRONOMICAL_UNIT)
    lit_in = Variable("sunlit", "1", "Fraction of the solar disc seen (0 umbra, 1 lit)", 1.0)
    b_in = vector("b", 3, "T", "Geomagnetic field, inertial axis {i}")
    rho_in = Variable("density", "kg/m3", "Atmospheric density", 0.0)
    switches = {name: Variable(f"{name}_on", "1", f"Apply the {what} torque", 0, "Boolean")
                for name, what in zip(TORQUES, ("gravity gradient", "aerodynamic drag", "solar radiation pressure",
                                                "residual dipole"))}
    area = vector("facet_area", nf, "m2", "Area of facet {i}", [f.area for f in facets], min=1e-12)
    normal = [Variable(f"facet_normal[{j + 1},{k + 1}]", "1", f"Outward normal of facet {k + 1}, body component "
                       f"{j + 1} (normalized in the model)", facets[k].normal[j]) for k in range(nf) for j in range(3)]
    cp = [Variable(f"facet_cp[{j + 1},{k + 1}]", "m", f"Centre of pressure of facet {k + 1} from the centre of "
                   f"mass, body component {j + 1}", facets[k].centre_of_pressure[j])
          for k in range(nf) for j in range(3)]
    cd = vector("drag_coefficient", nf, "1", "Drag coefficient of facet {i}", [f.drag_coefficient for f in facets],
                min=0.0)
    spec = vector("specular", nf, "1", "Specular reflectivity of facet {i}", [f.specular for f in facets],
                  min=0.0, max=1.0)
    diff = vector("diffuse", nf, "1", "Diffuse reflectivity of facet {i}", [f.diffuse for f in facets],
                  min=0.0, max=1.0)
    m_res = vector("m_res", 3, "A.m2", "Residual magnetic dipole, body axis {i}", list(spacecraft.residual_dipole))
    p_sun = Variable("solar_pressure", "N/m2", "Solar radiation pressure at 1 AU", SOLAR_PRESSURE, min=0.0)

    definitions: list[tuple[sp.Symbol, sp.Expr]] = []

    def define(name: str, value: sp.Matrix | sp.Expr) -> sp.Matrix | sp.Symbol:
        """Evaluate ``value`` once, as named definitions (a vector entry by entry)."""
        if isinstance(value, sp.MatrixBase):
            syms = sp.Matrix([sp.Symbol(f"d_{name}_{j}", real=True) for j in range(value.shape[0])])
            definitions.extend(zip(syms, value))
            return syms
        sym = sp.Symbol(f"d_{name}", real=True)
        definitions.append((sym, value))
        return sym

    r_b = define("r_body", C * symbols(r_in))
    radius = define("radius", sp.sqrt((r_b.T * r_b)[0]))
    gg = 3 * MU_EARTH / radius**5 * r_b.cross(J * r_b)

    v_b = define("v_body", C * symbols(v_in))
    speed = define("speed", sp.sqrt((v_b.T * v_b)[0]))
    v_hat = define("v_hat", v_b / sp.Max(speed, sp.Float(1e-300)))  # no flow: any direction, the force is 0
    s_b = define("sun_body", C * symbols(s_in))
    s_hat = define("s_hat", s_b / sp.sqrt((s_b.T * s_b)[0]))
    pressure = define("pressure", p_sun.symbol * (ASTRONOMICAL_UNIT / d_in.symbol) ** 2 * lit_in.symbol)
    dynamic = define("dynamic_pressure", rho_in.symbol / 2 * speed**2)
    drag, srp = sp.zeros(3, 1), sp.zeros(3, 1)
    for k in range(nf):
        raw = sp.Matrix([sp.Symbol(f"facet_normal[{j + 1},{k + 1}]", real=True) for j in range(3)])
        n = define(f"normal_{k}", raw / sp.sqrt((raw.T * raw)[0]))
        arm = sp.Matrix([sp.Symbol(f"facet_cp[{j + 1},{k + 1}]", real=True) for j in range(3)])
        a_k = area[k].symbol
        f_drag = define(f"f_drag_{k}", -dynamic * cd[k].symbol * a_k * sp.Max(0, (n.T * v_hat)[0]) * v_hat)
        cos = define(f"cos_sun_{k}", (n.T * s_hat)[0])
        f_srp = define(f"f_srp_{k}", -pressure * a_k * sp.Max(0, cos) * ((1 - spec[k].symbol) * s_hat
                                                                         + 2 * (spec[k].symbol * cos
                                                                                + diff[k].symbol / 3) * n))
        drag += arm.cross(f_drag)
        srp += arm.cross(f_srp)
    dipole = symbols(m_res).cross(define("b_body", C * symbols(b_in)))
    torques = dict(zip(TORQUES, (gg, drag, srp, dipole)))
    outputs, total = [], sp.zeros(3, 1)
    for name, what in zip(TORQUES, ("Gravity-gradient", "Aerodynamic", "Solar radiation pressure", "Residual dipole")):
        for j in range(3):
            sym = sp.Symbol(f"d_tau_{name}_{j}", real=True)
            definitions.append((sym, sp.Piecewise((torques[name][j], switches[name].symbol > sp.Rational(1, 2)),
                                                  (0, True))))
            outputs.append(Output(Variable(f"tau_{name}[{j + 1}]", "N.m", f"{what} torque about body axis {j + 1}"),
                                  sym))
            total[j] += sym
    return EnvironmentTorques(
        inputs=r_in + v_in + s_in + [d_in, lit_in] + b_in + [rho_in],
        parameters=list(switches.values()) + area + normal + cp + cd + spec + diff + m_res + [p_sun],
        outputs=outputs, definitions=definitions, total=total)
