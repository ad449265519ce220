"""Design seed 003's periodic magnetorquer gains for your own cubesat, and fly them beside B-dot.

The cubesat is a 3U (0.01/0.05/0.05 kg m^2, principal axes) with 0.2 A m^2 magnetorquers. The
design is Theorem 2 of the seed 003 paper on the cubesat's linear rate model, sampled every
15 min over a 90 min orbit of the seed's Fourier field fit, with the seed's multiplicative noises
scaled to your inertia. It is certified on that linear model (the LMIs re-checked in numpy, mean-
square stable); the example then shows where it holds on the nonlinear plant (attitude,
gyroscopic term, field in body axes, dipole clipped at the limit):

- from 1e-3 rad/s (rate damping after detumbling) the periodic gains bring ``|w|`` down more
  than 10x in two orbits, where B-dot does not (its equilibrium spins at about twice the orbit
  rate);
- from a tumbling 0.05 rad/s they do not (a 15 min hold is about 40 rad of rotation, far outside
  the linear model), and B-dot does.

So fly B-dot to detumble and hand over to the periodic gains below a few 1e-3 rad/s.

    python examples/own_cubesat_periodic.py          # about 20 s on one core

The design is saved in your satfmu folder (``satfmu.user_artifacts()``) and its controller FMU
is built on demand.
"""
from __future__ import annotations

import satfmu
from satfmu.controllers.magnetic import bdot_gain

SPACECRAFT = satfmu.Spacecraft("my_3u", inertia=[[0.01, 0.0, 0.0], [0.0, 0.05, 0.0], [0.0, 0.0, 0.05]],
                               dipole_limit=0.2, description="3U cubesat, 0.2 A m^2 magnetorquers")
CONTROLLER = "my_3u_periodic"
ORBITS_S = 10_800.0
"""Two orbits of the seed's 90 min field, s."""
DIRECTION = (0.05, -0.04, 0.03)
"""Direction of the initial rate (seed 003's substitute tumbling rate), rad/s."""
REGIMES = {"rate damping": (1e-3, "periodic"), "detumbling": (0.05, "bdot")}
"""Regime -> (initial rate |w(0)|, rad/s; the law expected to reduce it 10x in two orbits)."""
REDUCTION = 0.1
"""Expected: ``|w|`` after two orbits at most this fraction of ``|w(0)|``."""
LAWS = {"periodic": CONTROLLER, "bdot": "cubesat_bdot"}
"""Law -> controller model."""


def design() -> satfmu.Design:
    """Seed 003's Theorem 2 for SPACECRAFT at 1.05 gamma_min (about 1 s)."""
    return satfmu.design_cubesat_periodic(plant=SPACECRAFT, name=CONTROLLER)


def scenario(rate: float, expected: str) -> satfmu.Scenario:
    """Both laws, each on its own copy of the nonlinear plant (dipole clipped at the limit), two
    orbits from ``|w(0)| = rate`` (rad/s) along :data:`DIRECTION`; the law ``expected`` must bring
    ``|w|`` down to :data:`REDUCTION` of it, the other is reported."""
    norm = sum(c * c for c in DIRECTION) ** 0.5
    plant = {"I_x": 0.01, "I_y": 0.05, "I_z": 0.05, "saturation_on": True, "m_max": SPACECRAFT.dipole_limit,
             **{f"omega_0[{i + 1}]": rate * c / norm for i, c in enumerate(DIRECTION)}}
    fmus, connections, metrics = {}, [], []
    for law, model in LAWS.items():
        params = {"bdot_gain": bdot_gain(j_min=0.01)} if law == "bdot" else {}
        fmus[f"{law}_plant"] = satfmu.FmuSpec(model="magnetorquer_cubesat", parameters=plant)
        fmus[law] = satfmu.FmuSpec(model=model, parameters=params)
        measured = "b_body" if law == "bdot" else "omega"
        connections += [satfmu.Connection(f"{law}_plant.{measured}", f"{law}.{measured}"),
                        satfmu.Connection(f"{law}.m", f"{law}_plant.m")]
        metrics += [satfmu.Metric(f"{law}: |w(2 orbits)| / |w(0)|", "final", [f"{law}_plant.rate_norm"],
                                  scale=1.0 / rate, unit="1", max=REDUCTION if law == expected else None),
                    satfmu.Metric(f"{law}: peak dipole", "peak", [f"{law}.m"], unit="A m^2")]
    return satfmu.Scenario(
        name=f"my_3u_from_{rate:g}", stop_time=ORBITS_S, step_size=1.0,
        description=f"{SPACECRAFT.name}: periodic LMI gains and B-dot from |w(0)| = {rate:g} rad/s",
        fmus=fmus, connections=connections, record=[f"{law}_plant.rate_norm" for law in LAWS], metrics=metrics)


def main() -> int:
    d = design()
    print(d.summary)
    print("wrote", ", ".join(map(str, d.write())))
    print("certificate:", d.artifact["certificate"]["status"])
    passed = d.artifact["certificate"]["status"] == "certified"
    for regime, (rate, expected) in REGIMES.items():
        result = satfmu.run(scenario(rate, expected))
        print(f"{regime}, |w(0)| = {rate:g} rad/s:")
        for m in result.metrics:
            print(f"  {'ok  ' if m.passed else 'FAIL'} {m.name}: {m.value:.4g} {m.unit}")
        passed = passed and result.passed
    return 0 if passed else 1


if __name__ == "__main__":
    raise SystemExit(main())
