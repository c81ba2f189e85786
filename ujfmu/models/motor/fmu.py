"""Motor FMU: rotor inertia with a PI speed controller and torque limit, or an ideal speed source."""

from . import model as motor
from ...fmu.base import SPEED_RANGE, TORQUE_RANGE, ModelSlave, _new_inputs, input_, output, parameter

_SPEED = SPEED_RANGE


class Motor(ModelSlave):
    """Drive motor following a speed profile (ujfmu.models.motor.model).

    PI mode (ideal_speed_source = false): J_rotor*domega/dt = tau_motor - tau_load with
    tau_motor = clamp(Kp*e + Ki*integral(e), -tau_max, tau_max), e = omega_ref - omega, conditional-integration
    anti-windup. Integrated over each communication step with tau_load held: exactly (a matrix exponential) while
    the torque stays within its limit and no profile corner falls inside the step, else classical RK4 with
    substeps chosen from the closed loop's fastest pole. Starts at omega = omega_ref(start), integral
    tau_initial / Ki (0 by default: the drive starts from zero torque).
    Ideal mode (ideal_speed_source = true): omega = omega_ref(t), phi = its integral, and
    tau_motor = J_rotor*alpha_ref + tau_load is the torque a perfect drive would deliver (a step has no impulse).

    Profiles: 0 constant omega_set; 1 ramp from rest at t = 0 s at accel up to omega_set (Feng's start-up: 30 rad/s^2);
    2 step from omega_initial to omega_set at t_step; 3 from omega_initial to omega_set at accel (up or down) from
    t_step (a braking or a speed change at a finite rate).
    Signs: omega, phi, tau_motor > 0 in the sense of positive rotation; tau_load > 0 opposes positive rotation.
    """

    MODEL = motor
    VARIABLES = (
        parameter("J_rotor", 1.0e-3, "kg.m2", "Rotor moment of inertia", min=1.0e-9, max=1.0e6),
        parameter("Kp", 0.2, "N.m.s/rad", "PI speed controller proportional gain", min=0.0, max=1.0e6),
        parameter("Ki", 10.0, "N.m/rad", "PI speed controller integral gain", min=0.0, max=1.0e8),
        parameter("tau_max", 5.0, "N.m", "Torque limit of the drive (symmetric)", min=0.0, max=1.0e6),
        parameter("profile", 1, "1", "Speed profile: 0 constant, 1 ramp from rest at t = 0 s (the time axis, not "
                  "the start time), 2 step at t_step, 3 ramp from omega_initial to omega_set at accel from t_step "
                  "(up or down)", min=0, max=3, type=int),
        parameter("omega_set", 150.0, "rad/s", "Final (constant, ramp end, step target) speed", **_SPEED),
        parameter("accel", 30.0, "rad/s2", "Ramp acceleration, magnitude (Feng et al.: 30 rad/s^2)", min=1.0e-6,
                  max=1.0e7),
        parameter("t_step", 0.0, "s", "Time of the speed step (profile 2), or of the ramp's start (profile 3)",
                  min=-1.0e9, max=1.0e9),
        parameter("omega_initial", 0.0, "rad/s", "Speed before the step or ramp (profiles 2 and 3)", **_SPEED),
        parameter("ideal_speed_source", False, None, "True: follow the profile exactly (ideal speed source)",
                  type=bool),
        input_("tau_load", 0.0, "N.m", "Reaction torque of the driven machine (positive opposes positive rotation)",
               **TORQUE_RANGE),
        output("omega", "rad/s", "Rotor speed"),
        output("phi", "rad", "Rotor angle, continuous over revolutions"),
        output("tau_motor", "N.m", "Drive torque on the rotor", ("tau_load",)),
        output("omega_ref", "rad/s", "Reference speed of the profile"),
        # declared after the ports, which keep their value references of the FMUs before it
        parameter("tau_initial", 0.0, "N.m", "PI mode: drive torque at the start (the integral starts at "
                  "tau_initial / Ki), e.g. the load's torque for a run that starts in equilibrium at its speed",
                  neutral=0.0, **TORQUE_RANGE),
    )
    DEFAULT_EXPERIMENT = (0.0, 6.0, 1.0e-3)

    def model_inputs(self):
        return _new_inputs(motor.Inputs, (self.tau_load,))


class MotorController(ModelSlave):
    """Motor drive without its rotor, for the torque-driven joints: measured speed in, drive torque out.

    The Motor's PI speed controller, torque limit and speed profiles (ujfmu.models.motor.model.Controller):
    tau_motor = clamp(Kp*e + Ki*I, -tau_max, tau_max), e = omega_ref(t) - omega, conditional-integration
    anti-windup, with omega the speed the host passes in (held over a step: a sampled speed controller). The
    rotor inertia belongs to the driven model: set the torque-driven joint's J_drive to the motor's J_rotor and
    connect tau_motor -> tau_in, omega_in -> omega. The integral starts at tau_initial / Ki (0 by default).
    Signs as Motor's: tau_motor > 0 drives in the sense of positive rotation.
    """

    MODEL = motor.Controller
    VARIABLES = tuple(v for v in Motor.VARIABLES if v.causality == "parameter"
                      and v.name not in ("J_rotor", "ideal_speed_source", "tau_initial")) + (
        input_("omega", 0.0, "rad/s", "Measured rotor speed (the torque-driven joint's omega_in)", **_SPEED),
        output("tau_motor", "N.m", "Drive torque on the rotor", ("omega",)),
        output("omega_ref", "rad/s", "Reference speed of the profile"),
    ) + tuple(v for v in Motor.VARIABLES if v.name == "tau_initial")
    DEFAULT_EXPERIMENT = Motor.DEFAULT_EXPERIMENT

    def model_inputs(self):
        return _new_inputs(motor.Controller.Inputs, (self.omega,))
