"""Drive one satfmu FMU from plain fmpy, as any FMI 2.0 host would.

    python examples/plain_fmpy.py

satfmu builds the MRP satellite plant FMU (or reuses it); fmpy then simulates it alone
with a constant torque about x from rest, for your spacecraft's inertia. About a principal
axis the rate grows linearly, omega_x(t) = u t / I_x: the script compares the FMU with it.
"""
from __future__ import annotations

import numpy as np
from fmpy import simulate_fmu

import satfmu

U_X = 0.5  # N m
STOP = 10.0  # s


def main() -> int:
    fmu = next(p for p in satfmu.build(["mrp_satellite"], backends=("native",)))
    spacecraft = satfmu.Spacecraft("principal", inertia=[100.0, 120.0, 80.0])
    torque = np.array([(0.0, U_X), (STOP, U_X)], dtype=[("time", float), ("u[1]", float)])
    res = simulate_fmu(str(fmu), stop_time=STOP, output_interval=0.5, start_values=spacecraft.parameters(),
                       input=torque, output=["omega[1]", "omega[2]", "phi"])
    expected = U_X * res["time"] / spacecraft.inertia[0][0]
    error = float(np.max(np.abs(res["omega[1]"] - expected)))
    print(f"{fmu.name} in fmpy: omega_x({STOP:g} s) = {res['omega[1]'][-1]:.9f} rad/s, u t / I_x = {expected[-1]:.9f}; "
          f"largest difference {error:.2e} rad/s; omega_y stays {np.max(np.abs(res['omega[2]'])):.1e}")
    return 0 if error < 1e-12 else 1


if __name__ == "__main__":
    raise SystemExit(main())
