"""Design seed 001's mixed H2/H-infinity controller for your own spacecraft and check its H2 bound
through the FMUs.

The spacecraft is the 100/120/80 kg m^2 bus of ``own_spacecraft.py`` (products of inertia
included). Theorem 8 is solved in units balanced for it and its certificate checked in SI
units; the design proves, on ``|sigma| <= 0.45`` and for every rate, an L2 gain from the
disturbance torque to the MRPs below ``GAMMA`` and an H2 cost bound ``lambda`` from the 90 deg
start, with the torque weighed against the 20 N m limit (Bryson's rule, the default). The
controller FMU then flies that start and its H2 cost must stay below lambda. A gamma the
plant cannot reach is refused in seconds, with the gamma it can (try ``--gamma 0.01``).

    python examples/own_spacecraft_h2hinf.py              # 12 SOS programs, about 2 min
    python examples/own_spacecraft_h2hinf.py --quick      # one SOS program, about 20 s
"""
from __future__ import annotations

import argparse

import numpy as np

import satfmu

SPACECRAFT = satfmu.Spacecraft("my_sat", inertia=[[100.0, 2.0, -1.0], [2.0, 120.0, 0.5], [-1.0, 0.5, 80.0]],
                               torque_limit=20.0, description="200 kg class bus, products of inertia from CAD")
GAMMA = 0.7
"""L2-gain bound from the disturbance torque (N m) to the MRPs."""
CONTROLLER = "my_sat_h2hinf"


def design(gamma: float = GAMMA, evaluations: int = 12) -> satfmu.Design:
    """Theorem 8 for SPACECRAFT at ``gamma``: ``evaluations`` SOS programs in the alpha/beta search
    (1: the first point of the search only, which certifies for this spacecraft)."""
    return satfmu.design_h2hinf(gamma, SPACECRAFT, name=CONTROLLER, evaluations=evaluations)


def scenario(design: satfmu.Design) -> satfmu.Scenario:
    """The design's own H2 start flown through the FMUs for 600 s, with the two parts of its H2 cost
    (``Qh = I6``; ``Rh = I3 / torque_limit^2``, the default for a spacecraft with a torque limit)."""
    result = design.result
    torque_scale = float(np.sqrt(result.Rh[0, 0]))  # 1 / torque_limit
    start = {f"sigma_0[{i + 1}]": float(s) for i, s in enumerate(result.x0[3:])}
    return satfmu.Scenario(
        name=f"{CONTROLLER}_h2", stop_time=600.0, step_size=0.05,
        description=f"{SPACECRAFT.name}: the H2 start of {CONTROLLER} (90 deg rest-to-rest)",
        fmus={"plant": satfmu.FmuSpec(model="mrp_satellite", parameters={**SPACECRAFT.parameters(), **start}),
              "controller": satfmu.FmuSpec(model=CONTROLLER)},
        connections=[satfmu.Connection("plant.omega", "controller.omega"),
                     satfmu.Connection("plant.sigma", "controller.sigma"),
                     satfmu.Connection("controller.u", "plant.u")],
        record=["plant.phi", "plant.omega", "plant.sigma", "plant.u"],
        metrics=[satfmu.Metric("H2 cost, states", "integral_square", ["plant.omega", "plant.sigma"]),
                 satfmu.Metric("H2 cost, torque", "integral_square", ["plant.u"], scale=torque_scale),
                 satfmu.Metric("peak torque", "peak", ["plant.u"], unit="N.m", max=SPACECRAFT.torque_limit),
                 satfmu.Metric("angle error at 600 s", "final", ["plant.phi"], unit="deg",
                               max=0.1)])


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="one SOS program instead of 12")
    parser.add_argument("--gamma", type=float, default=GAMMA, help="L2-gain bound (default 0.7)")
    args = parser.parse_args()
    try:
        d = design(args.gamma, 1 if args.quick else 12)
    except satfmu.DesignError as exc:
        print(f"refused: {exc}")
        return 3
    print(d.summary)
    cert = d.artifact["certificate"]
    print(f"certificate: {cert['status']}: lambda = {cert['h2']['lambda']:.4f} on {cert['region']}")
    print("wrote", ", ".join(map(str, d.write())))
    result = satfmu.run(scenario(d))
    for m in result.metrics:
        print(f"  {'ok  ' if m.passed else 'FAIL'} {m.name}: {m.value:.4g} {m.unit}")
    cost = result.metrics[0].value + result.metrics[1].value
    ratio = cost / d.result.lam
    print(f"H2 cost through the FMUs {cost:.4f}, certified bound {d.result.lam:.4f}: ratio {ratio:.3f}")
    return 0 if result.passed and cert["status"] == "certified" and ratio <= 1.0 else 1


if __name__ == "__main__":
    raise SystemExit(main())
