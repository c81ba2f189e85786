"""Torque-driven variants of the drivetrain FMUs: driving torque in, input-shaft speed out.

A speed-driven FMU (omega_in in, tau_in out) demands a torque with inertia terms J*alpha, alpha estimated from
the speed history; coupled explicitly to a driver lighter than the inertia it reflects, that loop diverges at any
step (docs/cosimulation.md, "Which wiring is stable in which kind of host"). A torque-driven variant instead
integrates its input shaft, with the driver's rotor inertia J_drive lumped on it, as a state: the host passes
the driving torque tau_in (held over a step) and reads back omega_in, a state with no direct feedthrough. What
remains for the host's explicit loop is the driver's controller (torque from the sampled speed) and the load
(torque from the output speed), both ordinary step-size conditions.

The equations are the ``TorqueDriven`` protocol of the model module (derivatives of a state, its
``torque_driven_rates``), integrated over each step by the shared ModelSlave with classical RK4 (or the protocol's
own ``integrate`` or ``integrate_with_history`` where it has one), so a Model Exchange export can hand them to the
host's solver.
"""

from ..models.protocol import Torques
from .base import SPEED_RANGE, TORQUE_RANGE, ModelSlave, _new_inputs, input_, output, parameter


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
                  min=0.0, max=1.0e6),
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


class TorqueDrivenSlave(ModelSlave):
    """Base of the torque-driven FMUs: a ModelSlave over a torque-driven model (the ``TorqueDriven`` protocol of a
    model module), whose inputs are ``Torques(tau_in, tau_load)`` held over a step and whose state starts with the
    input shaft's angle and speed. A step whose input shaft would leave the speed range is refused."""

    #: a torque-driven model's ``load_outputs`` covers both torques (its other outputs are functions of the state)
    LOAD_INPUTS = ("tau_in", "tau_load")
    #: the model's ``integrate_from(p, t, h, y, u, k1)`` where it has one (the protocol's option for a step that
    #: starts from the rates k1 at its start)
    _step_from = None

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        model = cls.__dict__.get("MODEL")
        if model is not None and hasattr(model, "integrate_from"):
            cls._step_from = staticmethod(model.integrate_from)

    def model_inputs(self):
        return _new_inputs(Torques, (self.tau_in, self.tau_load))

    def integrate(self, t, h, y, u):
        """The RK4 substeps, the input speed over the step bounded from the rates at its start (:meth:`speed_reach`),
        which are the first stage's; or the model's own ``integrate_from`` from those rates; or its own
        ``integrate_with_history`` or ``integrate`` (ModelSlave's) after the same bound (with
        ``input_acceleration(p, y, u)``), and where the bound passes the range, refused only if the input shaft
        does leave it by the step's end: the bound extrapolates the acceleration now over the step, which a light
        input shaft swinging on the model's own stiffness reverses within it (J_drive of 1e-7 kg.m^2 on the
        default ring: 1.2e6 rad/s extrapolated, 238 rad/s reached)."""
        if self._step_from is not None:
            k1 = self.MODEL.derivatives(self._p, t, y, u)
            self.speed_reach(h, k1[0], k1[1])
            return tuple(self._step_from(self._p, t, h, y, u, k1))
        if self._own_step is not None or self._history_step is not None:
            try:
                self.speed_reach(h, y[1], self.MODEL.input_acceleration(self._p, y, u))
            except ValueError as refused:
                history = getattr(self, "_history", None)   # a refused step leaves the multistep history as it was
                try:
                    stepped = super().integrate(t, h, y, u)
                except (ValueError, ArithmeticError):
                    stepped = None
                if stepped is not None and abs(stepped[1]) <= SPEED_RANGE["max"]:   # NaN fails too
                    return stepped
                if history is not None:
                    self._history = history
                raise refused from None
            return super().integrate(t, h, y, u)
        k1 = self.MODEL.derivatives(self._p, t, y, u)
        return self._rk4(self.MODEL.derivatives, self._p, t, u, y, h,
                         self.substeps(h, y, u, self.speed_reach(h, k1[0], k1[1])), k1)

    def speed_reach(self, h, omega, alpha):
        """|omega_in| + |alpha_in| h from the input shaft's speed omega and acceleration alpha (ValueError if it
        exceeds the speed range); a step of h that aliases the model's order at omega is said once
        (``say_aliasing``)."""
        reach = abs(omega) + abs(alpha) * h
        if h * abs(omega) >= self._aliasing_reach and not self._aliasing_said:
            self.say_aliasing(h, omega)
        if not reach <= SPEED_RANGE["max"]:
            raise ValueError(f"tau_in = {self.tau_in!r} N.m and tau_load = {self.tau_load!r} N.m: the input shaft "
                             f"would reach {reach:.6g} rad/s within the step at its acceleration now (omega_in = "
                             f"{omega!r} rad/s, alpha_in = {alpha!r} rad/s2, from these torques and the model's own on "
                             f"the input shaft), outside its allowed range [{SPEED_RANGE['min']:.10g}, "
                             f"{SPEED_RANGE['max']:.10g}] rad/s: reduce the torques or the step, or check J_drive (a "
                             f"very light input shaft swings fast under the model's own torques, which this bound "
                             f"extrapolates over the step)")
        return reach
