"""Design seed 002's SDRE servo for your own rigid spacecraft and fly a slew through the FMUs.

The spacecraft is the 100/120/80 kg m^2 bus of ``own_spacecraft.py`` (products of inertia, a
20 N m torque limit). The design solves the state-dependent Riccati equation of the MRP
plant's servo over an operating box (a 90 deg rotation, the rates the torque limit can stop),
fits its gain with polynomials in the plant's states, checks the fit independently (fresh
points, frozen closed loops, a simulated slew) and proves, by SOS, the region where the fitted
law drives the attitude to the reference. The servo FMU then flies a 90 deg rest-to-rest slew
on the plant FMU, with the plant's torque saturation on.

    python examples/own_spacecraft_sdre.py            # with the SOS region, about 1 min
    python examples/own_spacecraft_sdre.py --quick    # without it, about 10 s
"""
from __future__ import annotations

import argparse

import satfmu
from satfmu.controllers import mrp_servo_sdc

SPACECRAFT = satfmu.Spacecraft("my_sat", inertia=[[100.0, 2.0, -1.0], [2.0, 120.0, 0.5], [-1.0, 0.5, 80.0]],
                               torque_limit=20.0, description="200 kg class bus, products of inertia from CAD")
CONTROLLER = "my_sat_sdre"
START = satfmu.manoeuvre(90.0, axis=(1.0, -1.0, 1.0))
"""The slew: rest-to-rest by 90 deg about (1, -1, 1), as the plant's sigma_0[i] parameters."""


def design(region: bool = True) -> satfmu.Design:
    """The SDRE servo of SPACECRAFT (the default box and weights), with its SOS region or not."""
    return satfmu.design_sdre(SPACECRAFT, name=CONTROLLER, region=region)


def scenario() -> satfmu.Scenario:
    """The slew through the FMUs for 120 s; the servo's reference sigma_ref stays 0 (the target
    attitude), the plant clips the torque at its 20 N m."""
    return satfmu.Scenario(
        name=f"{CONTROLLER}_slew", stop_time=120.0, step_size=0.05,
        description=f"{SPACECRAFT.name}: 90 deg rest-to-rest under {CONTROLLER}",
        fmus={"plant": satfmu.FmuSpec(model="mrp_satellite", parameters={**SPACECRAFT.parameters(), **START,
                                                                           "saturation_on": True}),
              "controller": satfmu.FmuSpec(model=CONTROLLER)},
        connections=[satfmu.Connection(a, b) for a, b in mrp_servo_sdc.plant_connections()],
        record=["plant.phi", "plant.omega", "controller.u"],
        metrics=[satfmu.Metric("angle error at 120 s", "final", ["plant.phi"], unit="deg",
                               max=0.01),
                 satfmu.Metric("time to 1 deg", "settling_time", ["plant.phi"], unit="deg",
                               tolerance=1.0, max=60.0),
                 # the demand may pass the limit for a moment (measured 21.5 N m): the plant clips it
                 satfmu.Metric("peak torque demanded", "peak", ["controller.u"], unit="N.m")])


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="skip the SOS region (the artifact is then 'sampled')")
    args = parser.parse_args()
    d = design(region=not args.quick)
    print(d.summary)
    print("wrote", ", ".join(map(str, d.write())))
    result = satfmu.run(scenario())
    for m in result.metrics:
        print(f"  {'ok  ' if m.passed else 'FAIL'} {m.name}: {m.value:.4g} {m.unit}")
    expected = "sampled" if args.quick else "certified"
    return 0 if result.passed and d.artifact["certificate"]["status"] == expected else 1


if __name__ == "__main__":
    raise SystemExit(main())
