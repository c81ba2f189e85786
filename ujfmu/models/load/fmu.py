"""Load FMU: speed-dependent resisting torque."""

from . import model as load
from ...fmu.base import SPEED_RANGE, ModelSlave, _new_inputs, input_, output, parameter


class Load(ModelSlave):
    """Resisting torque tau = T(t)*s(omega) + c1*omega + c2*omega*|omega|_s + T_active
    + T_h*cos(order_h*phi + phase_h) (ujfmu.models.load.model), T(t) = T0 changed by T_change from t_change on, at
    once or over ramp_time (a load step or ramp); phi the driven shaft's angle (an input: connect its phi_out), for
    a periodic torque (blade rate, firing order).

    s and |.|_s are a smooth sign and absolute value with regularisation speed omega_smooth, so the law is smooth
    and odd through omega = 0: constant (Coulomb-like) torque T0, viscous c1, fan/propeller c2 (Brutti et al.:
    M_u = c*omega^2, c = 0.017 N.m.s^2); T_active keeps its sign in either direction (a gradient, a weight).
    Stateless: tau follows omega and phi directly (direct feedthrough).
    Signs: tau > 0 opposes positive rotation; connect it to the tau_load input of the machine that drives it.
    """

    MODEL = load
    VARIABLES = (
        parameter("T0", 0.3, "N.m", "Constant resisting torque magnitude (Feng et al.: T0 = 0.3 N.m)",
                  min=-1.0e6, max=1.0e6),
        parameter("c1", 0.0, "N.m.s/rad", "Viscous coefficient", min=-1.0e6, max=1.0e6),
        parameter("c2", 0.0, "N.m.s2/rad2", "Quadratic (fan) coefficient", min=-1.0e6, max=1.0e6),
        parameter("omega_smooth", 0.1, "rad/s", "Regularisation speed of the smooth sign and absolute value",
                  min=1.0e-9, max=1.0e6),
        parameter("T_change", 0.0, "N.m", "Change of T0 from t_change on (a load step or ramp; 0: none)",
                  min=-1.0e6, max=1.0e6),
        parameter("t_change", 0.0, "s", "Time the change of T0 starts", min=-1.0e9, max=1.0e9),
        parameter("ramp_time", 0.0, "s", "Duration of the change of T0: 0 a step at t_change, else linear over it",
                  min=0.0, max=1.0e9),
        parameter("T_h", 0.0, "N.m", "Amplitude of the torque periodic in the shaft's angle, T_h cos(order_h phi + "
                  "phase_h) (0: none; it needs phi connected)", min=-1.0e6, max=1.0e6),
        parameter("order_h", 1.0, "1", "Periods of the periodic torque per revolution of the shaft (a propeller's "
                  "blade count, an engine's firing order)", min=0.0, max=1.0e3),
        parameter("phase_h", 0.0, "rad", "Phase of the periodic torque at phi = 0", min=-1.0e6, max=1.0e6),
        parameter("T_active", 0.0, "N.m", "Torque of one sign whatever the direction of rotation (a gradient, a "
                  "hoisted weight): positive resists positive rotation and drives negative rotation; unlike T0 it "
                  "does not reverse with the speed", min=-1.0e6, max=1.0e6),
        input_("omega", 0.0, "rad/s", "Speed of the driven shaft", **SPEED_RANGE),
        input_("phi", 0.0, "rad", "Angle of the driven shaft (connect the machine's phi_out; used by T_h only)",
               min=-1.0e12, max=1.0e12, used_if="T_h"),
        output("tau", "N.m", "Resisting torque (positive opposes positive rotation)", ("omega", "phi")),
    )
    DEFAULT_EXPERIMENT = (0.0, 1.0, 1.0e-3)

    def model_inputs(self):
        return _new_inputs(load.Inputs, (self.omega, self.phi))
