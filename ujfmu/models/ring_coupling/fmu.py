"""RingCoupling FMU: elastic centrifugal ring coupling between radially misaligned shafts (Turla, Iljin)."""

from . import model as rc
from ...fmu.base import SPEED_RANGE, TORQUE_RANGE, PrescribedInputSlave, input_, output, parameter
from ...fmu.torque_driven import TorqueDrivenSlave, driven_ports

#: the paper's Fig. 3 set: steel wire d = 3 mm, R = 0.1 m, e = 3 mm, I2 = 0.05 kg.m^2
_E, _D, _R = rc.DEFAULT_RING


class RingCoupling(PrescribedInputSlave):
    """Elastic centrifugal ring coupling between radially misaligned shafts, Turla and Iljin Eqs. (5)-(22).

    Shaft 1 follows omega_in (angle advanced with the input extrapolated linearly over each step, alpha_in the
    backward difference); shaft 2 (inertia I2) is driven by the ring: the misalignment moment
    M_p = 157 (EI/R^3) e^2 cos(phi1 + phi2) (Eq. 7), the elastic torque -c_s x_e - c_d x_e' with
    x_e = phi2 - phi1 - (phi_out_start - phi_in_start) (Eq. 8), minus tau_load. c_s = c_d = tau_load = 0 is the
    paper's Eq. (9), the pendulum of Eq. (12). M_p derives from the ring's potential and acts on both shafts, so
    tau_in = I1 alpha_in - M_p - c_s x_e - c_d x_e'. Integrated by Krogstad's fourth-order exponential Runge-Kutta
    method with the ring's oscillator exact (model.exponential_steps): an undamped ring keeps its free motion.
    Default c_s = 87 EI/R for the default wire and ring (the paper's "87 EI/R^3" has the wrong units; Eq. 22 needs
    EI/R): set c_s again when changing R, d or E. Signs: speeds > 0 the same way round; tau_in > 0 drives;
    tau_load > 0 opposes shaft 2's positive rotation; transmitted_torque > 0 drives shaft 2.
    """

    MODEL = rc
    VARIABLES = (
        parameter("R", _R, "m", "Radius of the ring (paper R; Fig. 3: 0.1 m)", min=1.0e-4, max=10.0),
        parameter("d", _D, "m", "Diameter of the ring's wire (paper d; Fig. 3: 3 mm)", min=1.0e-6, max=1.0),
        parameter("E", _E, "Pa", "Young's modulus of the wire (steel)", min=1.0, max=1.0e13),
        parameter("e", 0.003, "m", "Radial misalignment of the shafts, < R (paper e; Fig. 3: 3 mm)",
                  min=0.0, max=10.0),
        parameter("I1", 0.0, "kg.m2", "Moment of inertia of shaft 1 (the input shaft) with its half-coupling",
                  min=0.0, max=1.0e6),
        parameter("I2", 0.05, "kg.m2", "Moment of inertia of shaft 2 with its half-coupling (paper I2)",
                  min=1.0e-9, max=1.0e6),
        parameter("c_s", rc.rotational_stiffness(_E, _D, _R), "N.m/rad",
                  "Rotational stiffness of the coupling (default 87 EI/R of the default ring; 0: the paper's "
                  "pendulum, Eq. 9)", min=0.0, max=1.0e9),
        parameter("c_d", 0.0, "N.m.s/rad", "Rotational damping of the coupling (not in the paper)",
                  min=0.0, max=1.0e6),
        parameter("phi_in_start", 0.0, "rad", "Shaft 1 angle at the start time (paper alpha1), from the direction "
                  "of misalignment", min=-1.0e6, max=1.0e6),
        parameter("phi_out_start", 0.0, "rad", "Shaft 2 angle at the start time (paper alpha2)",
                  min=-1.0e6, max=1.0e6),
        parameter("start_at_input_speed", True, None,
                  "True: shaft 2 turns with omega_in until the first step; false: it starts at omega_out_start",
                  type=bool),
        parameter("omega_out_start", 0.0, "rad/s", "Shaft 2 speed at the start when start_at_input_speed is false",
                  min=-1.0e5, max=1.0e5),
        input_("omega_in", 0.0, "rad/s", "Shaft 1 angular speed", **SPEED_RANGE),
        input_("tau_load", 0.0, "N.m", "Load torque on shaft 2 (positive opposes positive rotation)",
               **TORQUE_RANGE),
        output("omega_out", "rad/s", "Shaft 2 angular speed", ("omega_in",)),
        output("phi_out", "rad", "Shaft 2 angle phi2, continuous over revolutions"),
        output("tau_in", "N.m", "Torque demanded from the driver, I1 alpha_in - M_p - c_s x_e - c_d x_e'",
               ("omega_in",)),
        output("x_e", "rad", "Unevenness angle of shaft 2, phi2 - phi1 - (alpha2 - alpha1) (paper Eq. 8)"),
        output("M_p", "N.m", "Misalignment moment of the ring on shaft 2, Eq. (7) (the paper's 'internal moment of "
               "resistance'; positive accelerates shaft 2, and the same moment acts on shaft 1)"),
        output("transmitted_torque", "N.m", "Torque of the coupling on shaft 2, M_p - c_s x_e - c_d x_e'",
               ("omega_in",)),
        output("phi_in", "rad", "Shaft 1 angle phi1, continuous over revolutions"),
        output("alpha_in", "rad/s2", "Shaft 1 angular acceleration estimated from omega_in", ("omega_in",)),
        output("stored_energy", "J", "Kinetic energy of both shafts plus the ring's potential "
               "-157 (EI/R^3) e^2 sin(phi1 + phi2) + c_s x_e^2 / 2", ("omega_in",)),
    )
    DEFAULT_EXPERIMENT = (0.0, 2.0, 1.0e-3)


class RingCouplingTorqueDriven(TorqueDrivenSlave):
    """Torque-driven RingCoupling: driving torque tau_in in, shaft 1 speed omega_in out.

    The same coupling as RingCoupling (Turla, Iljin Eqs. 5-22), with shaft 1 free: its angle and speed are a
    state integrated from (J_drive + I1) alpha_in = tau_in + M_p + c_s x_e + c_d x_e', J_drive the driver's rotor
    inertia lumped on shaft 1 (model.TorqueDriven); shaft 2 as in RingCoupling; tau_in and tau_load held over each
    step (Krogstad's exponential Runge-Kutta method, the rigid rotation and the two-mass oscillator exact:
    model.torque_exponential_steps). Outputs as RingCoupling's;
    tau_input_shaft = tau_in - J_drive*alpha_in is what RingCoupling calls tau_in. start_at_input_speed starts
    shaft 2 at omega_in_start. Offers Model Exchange (FMI 3.0). Wire it to MotorController (tau_motor -> tau_in,
    omega_in -> omega) and a Load (omega_out -> omega, tau -> tau_load). Signs as RingCoupling's.
    """

    MODEL = rc.TorqueDriven
    VARIABLES = driven_ports(RingCoupling)
    DEFAULT_EXPERIMENT = RingCoupling.DEFAULT_EXPERIMENT
