"""Torque-driven variants of the drivetrain FMUs: driving torque in, input-shaft speed out.

A speed-driven FMU (omega_in in, tau_in out) demands a torque with inertia terms J*alpha, alpha estimated from
the speed history; coupled explicitly to a driver lighter than the inertia it reflects, that loop diverges at any
step (docs/cosimulation.md, "Which wiring is stable in which kind of host"). A torque-driven variant instead
integrates its input shaft, with the driver's rotor inertia J_drive lumped on it, as a state: the host passes
the driving torque tau_in (held over a step) and reads back omega_in, a state with no direct feedthrough. What
remains for the host's explicit loop is the driver's controller (torque from the sampled speed) and the load
(torque from the output speed), both ordinary step-size conditions.

The equations are derivatives of a state (``torque_driven_rates`` of the model), integrated over each step with
classical RK4 (ujfmu.fmu.rk4.integrate_time), so a Model Exchange export can hand them to the host's solver.
"""

import math

from ..models.protocol import Drive
from . import rk4
from .base import SPEED_RANGE, TORQUE_RANGE, UjfmuSlave, input_, output, parameter


#: the input-shaft ports of the speed-driven originals, declared anew below with the other causality
_INPUT_SHAFT = ("omega_in", "tau_in", "phi_in", "alpha_in")


def driven_ports(speed_driven: type) -> tuple:
    """The VARIABLES of the torque-driven variant of speed_driven (a UjfmuSlave class): its parameters, then
    J_drive and omega_in_start, the inputs tau_in and tau_load, the input shaft's outputs, then its other outputs
    as it declares them, with the direct feedthrough of this causality: an output that depends on tau_load in
    speed_driven uses the acceleration and depends on tau_in and tau_load here; every other is a function of the
    state (omega_in is a state)."""
    declared = speed_driven.VARIABLES
    others = tuple(output(v.name, v.unit, v.description, ("tau_in", "tau_load") if "tau_load" in v.depends_on else ())
                   for v in declared if v.causality == "output" and v.name not in _INPUT_SHAFT)
    return tuple(v for v in declared if v.causality == "parameter") + (
        parameter("J_drive", 1.0e-3, "kg.m2",
                  "Driver's rotor inertia lumped on the input shaft (e.g. the motor's J_rotor); tau_in acts on it",
                  min=0.0, max=1.0e3),
        parameter("omega_in_start", 0.0, "rad/s", "Input shaft speed at the start time", **SPEED_RANGE),
        input_("tau_in", 0.0, "N.m",
               "Driving torque on the input shaft and the lumped rotor J_drive (e.g. the motor's air-gap torque)",
               **TORQUE_RANGE),
        next(v for v in declared if v.name == "tau_load"),
        output("omega_in", "rad/s", "Input shaft angular speed (a state: no direct feedthrough)"),
        output("phi_in", "rad", "Input shaft angle, continuous over revolutions"),
        output("alpha_in", "rad/s2", "Input shaft angular acceleration from the equations of motion",
               ("tau_in", "tau_load")),
        output("tau_input_shaft", "N.m",
               "Torque the lumped rotor passes into the input shaft, tau_in - J_drive*alpha_in (what the "
               "speed-driven variant's tau_in output is)", ("tau_in", "tau_load")),
    ) + others


class TorqueDrivenSlave(UjfmuSlave):
    """Base of the torque-driven FMUs. The model state is one tuple of floats ``_state`` whose first two entries
    are the input shaft's angle and speed and the rest the speed-driven model's State (STATE); subclasses set MODEL
    (the speed-driven model's module, whose ``outputs`` give every output but the input shaft's) and implement
    ``derive()`` (the DERIVED attributes, ``_p`` the model's Parameters), ``initial_state()``, ``rates(state)``
    (its time derivative at the current inputs) and ``rate_bound(omega_max)`` (an upper bound of its fastest rate,
    for the substeps)."""

    MODEL = None

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        if cls.__dict__.get("MODEL") is not None:
            cls.PHYSICS = cls.MODEL

    def initialize(self, start_time):
        self._state = self.initial_state()

    def advance(self, t, h):
        omega, alpha = self.rates(self._state)[:2]
        reach = abs(omega) + abs(alpha) * h
        if not reach <= SPEED_RANGE["max"]:
            raise ValueError(f"tau_in = {self.tau_in!r} N.m and tau_load = {self.tau_load!r} N.m: the input shaft "
                             f"would reach {reach:.6g} rad/s within the step (omega_in = {omega!r} rad/s, alpha_in = "
                             f"{alpha!r} rad/s2), outside its allowed range [{SPEED_RANGE['min']:.10g}, "
                             f"{SPEED_RANGE['max']:.10g}] rad/s: reduce the torques or the step, or check J_drive")
        n = rk4.substeps(self.rate_bound(reach), h)
        state = tuple(rk4.integrate_time(lambda s, y: self.rates(y), self._state, h, n))
        if not all(math.isfinite(x) for x in state):
            raise ValueError(f"the state became non-finite over the step ({state!r})")
        self.check_state(state)
        self._state = state

    def check_state(self, state):
        """Raise ValueError if state (after a step) is outside the model's validity."""

    def compute_outputs(self):
        """The input shaft's outputs from the state and the equations of motion, the others from the model's
        outputs at that motion (its tau_in is tau_input_shaft here)."""
        y = self._state
        self.phi_in, self.omega_in = y[0], y[1]
        self.alpha_in = self.rates(y)[1]
        model = self.MODEL
        out = model.outputs(self._p, 0.0, model.State(*y[2:]), Drive(y[0], y[1], self.alpha_in, self.tau_load))
        self.tau_input_shaft = out.pop("tau_in")
        for name, value in out.items():
            setattr(self, name, value)
