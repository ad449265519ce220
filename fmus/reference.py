"""In-process reference simulations of a plant + state-feedback controller loop.

Both run the SAME sampled-data loop as the co-simulation master: the controller
output is computed from the plant state at each communication point and held over
the step. They evaluate the same generated code as the FMUs
(:func:`satfmu.fmus.codegen.load_python`), so they check the FMU machinery (wrapper,
master, integrator), not a second copy of the dynamics.

- :func:`closed_loop_solve_ivp`: scipy's adaptive RK45/DOP853 at tight tolerances, the
  reference an FMU run is compared with;
- :func:`closed_loop_rk4`: the fixed-step RK4 of the pythonfmu slave, in a plain loop
  (the in-process baseline of ``bench/cosim_speed.py``).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
from scipy.integrate import solve_ivp

from satfmu.fmus import codegen
from satfmu.fmus.model import Model
from satfmu.fmus.pyslave import rk4_step, substep_count


@dataclass
class LoopResult:
    """Trajectory at the communication points: time (s), plant states, controller outputs.

    Attributes
    ----------
    t : numpy.ndarray, shape (n + 1,)
        Communication times, s.
    x : numpy.ndarray, shape (n + 1, nx)
        Plant states at those times, in the plant's state order and units.
    u : numpy.ndarray, shape (n + 1, ny)
        Controller outputs computed at those times (each held over the following step).
    """

    t: np.ndarray
    x: np.ndarray
    u: np.ndarray


Exogenous = Callable[[float], dict[str, float]]
"""Plant inputs not driven by the controller (e.g. disturbance torques) as a function of the
communication time; each value is held over the step, as the master holds its profiles."""


class _Loop:
    def __init__(self, plant: Model, controller: Model, plant_params: dict | None,
                 controller_params: dict | None, command_inputs: list[str],
                 exogenous: Exogenous | None = None) -> None:
        self.plant, self.ctrl = codegen.load_python(plant), codegen.load_python(controller)
        self.pp = plant.parameter_vector(plant_params).tolist()
        self.cp = controller.parameter_vector(controller_params).tolist()
        self.x0 = plant.initial_state(np.array(self.pp))
        names = [v.name for v in plant.inputs]
        self.names = names
        self.u_index = [names.index(n) for n in command_inputs]
        self.nu = len(names)
        self.exogenous = exogenous
        state_names = [s.variable.name for s in plant.states]
        self.meas_index = [state_names.index(v.name) for v in controller.inputs]

    def command(self, x: "np.ndarray | list[float]", t: float = 0.0) -> tuple[list[float], list[float]]:
        y = self.ctrl.outputs(t, [], [float(x[i]) for i in self.meas_index], self.cp)
        u = [0.0] * self.nu
        if self.exogenous is not None:
            for name, v in self.exogenous(t).items():
                if name not in self.names:
                    raise ValueError(f"exogenous input {name!r} is not a plant input ({self.names})")
                u[self.names.index(name)] = float(v)
        for i, v in zip(self.u_index, y):
            u[i] = v
        return u, y


def closed_loop_solve_ivp(plant: Model, controller: Model, stop_time: float, step_size: float,
                          plant_params: dict | None = None, controller_params: dict | None = None,
                          command_inputs: list[str] | None = None, rtol: float = 1e-10,
                          atol: float = 1e-12, method: str = "DOP853",
                          exogenous: Exogenous | None = None, substeps: int = 1) -> LoopResult:
    """Sampled-data closed loop integrated by scipy between communication points.

    ``command_inputs`` names the plant inputs that receive the controller outputs
    (default: the plant inputs named like the controller outputs); ``exogenous`` gives
    other plant inputs (held over each step); the rest are 0. Each communication step is
    cut into ``substeps`` equal intervals: the plant's substep-start state (a friction
    mode, say) is frozen over each and its post-step map applied at its end, as the FMUs
    do with as many RK4 substeps. Pass the FMU's substep count to compare a plant whose
    post-step map or frozen mode acts during the run.

    Parameters
    ----------
    plant : Model
        The plant; its states are the loop's state.
    controller : Model
        A static state-feedback law: its inputs are plant states of the same names, its outputs
        are evaluated at each communication point and held over the step.
    stop_time : float
        End of the run, s (the run starts at 0).
    step_size : float
        Communication step, s.
    plant_params : dict of str to float, optional
        Plant parameter overrides by name (the initial state comes from the parameters).
    controller_params : dict of str to float, optional
        Controller parameter overrides by name.
    command_inputs : list of str, optional
        The plant inputs that receive the controller outputs, in the outputs' order; default the
        plant inputs named like the controller outputs.
    rtol, atol : float, optional
        Relative and absolute tolerances of ``scipy.integrate.solve_ivp``. Defaults 1e-10 and
        1e-12.
    method : str, optional
        The ``solve_ivp`` method (``"DOP853"``, ``"RK45"``, ...). Default ``"DOP853"``.
    exogenous : callable, optional
        ``exogenous(t)`` gives other plant inputs (e.g. disturbance torques) at the communication
        time ``t`` (s), as a dict by input name, held over the step; the remaining inputs are 0.
    substeps : int, optional
        Intervals per communication step, each integrated separately with its own frozen
        substep-start state and post-step map. Default 1.

    Returns
    -------
    LoopResult
        Time, plant states and controller outputs at the ``n + 1`` communication points,
        ``n = round(stop_time / step_size)``.

    Raises
    ------
    RuntimeError
        If ``solve_ivp`` fails on an interval.
    """
    loop = _Loop(plant, controller, plant_params, controller_params,
                 command_inputs or [o.variable.name for o in controller.outputs], exogenous)
    n = int(round(stop_time / step_size))
    t = step_size * np.arange(n + 1)
    xs, us = [loop.x0], []
    x = loop.x0
    for k in range(n):
        u, y = loop.command(x, float(t[k]))
        us.append(y)
        edges = np.linspace(t[k], t[k + 1], substeps + 1)
        for a, b in zip(edges[:-1], edges[1:]):
            start = x.tolist()
            sol = solve_ivp(lambda tt, xx: loop.plant.derivatives(tt, xx, start, u, loop.pp), (a, b), x,
                            method=method, rtol=rtol, atol=atol)
            if not sol.success:
                raise RuntimeError(f"solve_ivp failed at t = {a} s: {sol.message}")
            x = np.array(loop.plant.post_step(b, sol.y[:, -1], start, u, loop.pp))
        xs.append(x)
    us.append(loop.command(x, float(t[-1]))[1])
    return LoopResult(t, np.array(xs), np.array(us))


def closed_loop_rk4(plant: Model, controller: Model, stop_time: float, step_size: float,
                    plant_params: dict | None = None, controller_params: dict | None = None,
                    command_inputs: list[str] | None = None, exogenous: Exogenous | None = None) -> LoopResult:
    """The same loop with the FMUs' fixed-step RK4 (substeps from n_substeps and h_max).

    Parameters
    ----------
    plant : Model
        The plant; its states are the loop's state.
    controller : Model
        A static state-feedback law: its inputs are plant states of the same names, its outputs
        are evaluated at each communication point and held over the step.
    stop_time : float
        End of the run, s (the run starts at 0).
    step_size : float
        Communication step, s.
    plant_params : dict of str to float, optional
        Plant parameter overrides by name (the initial state and ``n_substeps``, ``h_max``
        come from them).
    controller_params : dict of str to float, optional
        Controller parameter overrides by name.
    command_inputs : list of str, optional
        The plant inputs that receive the controller outputs, in the outputs' order; default the
        plant inputs named like the controller outputs.
    exogenous : callable, optional
        ``exogenous(t)`` gives other plant inputs (e.g. disturbance torques) at the communication
        time ``t`` (s), as a dict by input name, held over the step; the remaining inputs are 0.

    Returns
    -------
    LoopResult
        Time, plant states and controller outputs at the ``n + 1`` communication points,
        ``n = round(stop_time / step_size)``.
    """
    loop = _Loop(plant, controller, plant_params, controller_params,
                 command_inputs or [o.variable.name for o in controller.outputs], exogenous)
    names = [v.name for v in plant.parameters]
    n_sub = substep_count(step_size, loop.pp[names.index("n_substeps")], loop.pp[names.index("h_max")])
    n = int(round(stop_time / step_size))
    t = step_size * np.arange(n + 1)
    x = loop.x0.tolist()
    xs, us = [x], []
    for k in range(n):
        u, y = loop.command(x, float(t[k]))
        us.append(y)
        x = rk4_step(loop.plant, float(t[k]), x, u, loop.pp, step_size, n_sub)
        xs.append(x)
    us.append(loop.command(x, float(t[-1]))[1])
    return LoopResult(t, np.array(xs), np.array(us))
