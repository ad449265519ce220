"""Design seed 000's nonlinear H-infinity controller for your own spacecraft and fly it.

The spacecraft has a full inertia tensor (products of inertia included). The design is the
two-step iteration of the seed 000 paper (state feedback by SOS, then the closed loop's L2
gain, repeat), judged on a 90 deg rest-to-rest manoeuvre within a 20 N m torque budget. The
design is saved in your satfmu folder (``satfmu.user_artifacts()``), its controller FMU is
built on demand, and the manoeuvre runs through the FMUs. The published seed 000 controller
on the same plant is then flagged: it was designed for another inertia.

    python examples/own_spacecraft.py            # about 35 s on one core

``test_own_spacecraft.py`` next to this file is the pytest gate of this design.
"""
from __future__ import annotations

import warnings

import satfmu

SPACECRAFT = satfmu.Spacecraft("my_sat", inertia=[[100.0, 2.0, -1.0], [2.0, 120.0, 0.5], [-1.0, 0.5, 80.0]],
                               torque_limit=20.0, description="200 kg class bus, products of inertia from CAD")
START = satfmu.manoeuvre(90.0, axis=(1.0, -1.0, 1.0))
"""The manoeuvre: rest-to-rest by 90 deg about (1, -1, 1), as the plant's sigma_0[i] parameters."""
CONTROLLER = "my_sat_hinf"
TORQUE_BUDGET = 20.0  # N m


def design() -> satfmu.Design:
    """The seed 000 design for SPACECRAFT: both steps (Theorem 1, then the certified L2 gain and
    the manoeuvre) at one certified decay rate, 0.02 1/s, to keep the example short; leave
    ``decay_rates`` out for the iteration over the default schedule of ten rates (a few minutes)."""
    return satfmu.design_hinf(SPACECRAFT, name=CONTROLLER, start=START, torque_budget=TORQUE_BUDGET,
                              decay_rates=(0.02,), n_samples=5_000)


def scenario(controller: str = CONTROLLER) -> satfmu.Scenario:
    """The 90 deg manoeuvre of SPACECRAFT under ``controller`` through the FMUs, 120 s."""
    return satfmu.Scenario(
        name=f"my_sat_90deg_{controller}", stop_time=120.0, step_size=0.05,
        description=f"{SPACECRAFT.name}: 90 deg rest-to-rest under {controller}",
        fmus={"plant": satfmu.FmuSpec(model="mrp_satellite", parameters={**SPACECRAFT.parameters(), **START}),
              "controller": satfmu.FmuSpec(model=controller)},
        connections=[satfmu.Connection("plant.omega", "controller.omega"),
                     satfmu.Connection("plant.sigma", "controller.sigma"),
                     satfmu.Connection("controller.u", "plant.u")],
        record=["plant.phi", "plant.omega", "controller.u"],
        metrics=[satfmu.Metric("angle error at 120 s", "final", ["plant.phi"], unit="deg",
                               max=0.1),
                 satfmu.Metric("peak torque", "peak", ["controller.u"], unit="N.m", max=TORQUE_BUDGET),
                 satfmu.Metric("time to 1 deg", "settling_time", ["plant.phi"], unit="deg",
                               tolerance=1.0, max=90.0)])


def main() -> int:
    d = design()
    print(d.summary)
    cert = d.artifact["certificate"]
    print(f"certificate: {cert['status']}: {cert['proved']}; L2 gain <= {cert['l2_gain']['c']:.4f} "
          f"on {cert['l2_gain']['region']}")
    print("wrote", ", ".join(map(str, d.write())))
    result = satfmu.run(scenario())
    for m in result.metrics:
        print(f"  {'ok  ' if m.passed else 'FAIL'} {m.name}: {m.value:.4g} {m.unit}")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", satfmu.DesignMismatchWarning)
        published = satfmu.run(scenario("mrp_hinf_published"))
    print(f"published seed 000 controller on {SPACECRAFT.name}: "
          f"{'passes' if published.passed else 'fails'}; warning: {caught[0].message if caught else 'none'}")
    return 0 if result.passed and cert["status"] == "certified" and caught else 1


if __name__ == "__main__":
    raise SystemExit(main())
