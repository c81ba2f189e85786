"""DoubleCardanDriveline FMU: two Cardan joints and an intermediate shaft (Brutti et al.; Omar, Rahim, Rejab)."""

import math

from . import model as dc
from ...fmu.base import SPEED_RANGE, TORQUE_RANGE, PrescribedInputSlave, input_, output, parameter
from ...fmu.torque_driven import TorqueDrivenSlave, driven_ports

_ANGLE = dict(min=-dc.MAX_ANGLE, max=dc.MAX_ANGLE)
_PHASE = dict(min=-2.0 * math.pi, max=2.0 * math.pi)
_INERTIA = dict(min=0.0, max=1.0e6)


class DoubleCardanDriveline(PrescribedInputSlave):
    """Input shaft, Cardan joint 1, intermediate shaft, Cardan joint 2, output shaft with the driven load.

    The input shaft follows omega_in (angle advanced with the input extrapolated linearly over each step, its
    acceleration alpha_in the second-order (BDF2) slope of omega_in at t_k, so that neither tau_in nor the
    extrapolated angle lags by half a step). Two modes (README.md):
    - rigid_intermediate_shaft = true (Brutti et al., section 4): one degree of freedom; the output follows the
      joints' kinematics and tau_in = J_eq alpha1 + J_eq' omega1^2/2 + (dphi4/dphi1) tau_load from the kinetic
      energy J_eq(phi1) omega1^2/2 of every inertia (input shaft, crosses, intermediate shaft, output and load).
    - false (Omar et al., Eqs. 3-19 re-derived): a torsional spring-damper k_theta, c_theta = xi_theta k_theta in
      the intermediate shaft and a suspended mass m_s on a lateral support k_phi, c_phi = xi_phi k_phi at lever
      L_c give two degrees of freedom, the output angle and the dynamic misalignment phi that adds to both joint
      angles; integrated by an exponential Adams predictor-corrector in twist coordinates about the input's rigid
      rotation (model.multistep_step: the straight-joint torsional and lateral oscillators exactly, the rest
      through its last six values; its history part of the FMU state), one evaluation of the equations per 1 ms
      step besides the outputs' up to about 110 rad/s on Omar's driveline; started and restarted (the step length
      changed, the inputs jumping) by Dormand and Prince's fifth-order formula (model.flexible_step).
      The intermediate shaft's inertia is lumped half at each end. The driveline starts untwisted, phi = 0, with
      the output at the kinematic speed of omega_in as it is at the first step.
    Layout: yoke_phase = joint_plane_angle and beta1 = beta2 (Z) or beta1 = -beta2 (W) is constant velocity.
    Signs: speeds > 0 the same way round; tau_in > 0 drives, tau_load > 0 opposes the output's positive rotation;
    twist = phi2 - phi3 > 0 and shaft_torque > 0 while transmitting positive torque.
    """

    MODEL = dc
    ACCELERATION_ORDER = 2
    VARIABLES = (
        parameter("beta1", math.radians(15.0), "rad",
                  "Static angle of joint 1 between input and intermediate shaft (Omar beta0 = 15 deg)", **_ANGLE),
        parameter("beta2", math.radians(15.0), "rad",
                  "Static angle of joint 2 between intermediate and output shaft; same sign as beta1: Z layout, "
                  "opposite: W layout", **_ANGLE),
        parameter("yoke_phase", 0.0, "rad",
                  "Angle of the intermediate shaft's joint-2 yoke from its joint-1 yoke, positive in the shafts' "
                  "positive sense of rotation (0: in phase)", **_PHASE),
        parameter("joint_plane_angle", 0.0, "rad",
                  "Angle from joint 1's plane to joint 2's plane about the intermediate shaft, positive in its "
                  "positive sense of rotation (0: W or Z)", **_PHASE),
        parameter("I_input", 0.0, "kg.m2", "Input shaft moment of inertia (Brutti I_1x)", **_INERTIA),
        parameter("I_cross_pin", 0.0, "kg.m2", "Each cross's moment of inertia about a pin axis (Brutti I_2y, I_2z)",
                  **_INERTIA),
        parameter("I_cross_normal", 0.0, "kg.m2",
                  "Each cross's moment of inertia about the normal of its pins (Brutti I_2x)", **_INERTIA),
        parameter("I_intermediate", 0.0, "kg.m2",
                  "Intermediate shaft polar moment of inertia (Brutti I_3x; Omar: massless)", **_INERTIA),
        parameter("J_load", 0.0045, "kg.m2",
                  "Output shaft plus driven load moment of inertia (Omar J_load; Brutti I_5x)", **_INERTIA),
        parameter("k_theta", dc.OMAR_K_THETA, "N.m/rad", "Torsional stiffness of the intermediate shaft (Omar k_theta)",
                  min=1.0e-6, max=1.0e9),
        parameter("xi_theta", 0.002, "s", "Torsional damping coefficient, c_theta = xi_theta*k_theta (Omar)",
                  min=0.0, max=1.0e3),
        parameter("m_s", 4.09, "kg", "Suspended mass at the intermediate shaft (Omar m_s)", min=1.0e-6, max=1.0e6),
        parameter("k_phi", 26331.0, "N/m", "Lateral stiffness of the support (Omar k_phi)", min=1.0e-6, max=1.0e12),
        parameter("xi_phi", 0.002, "s", "Lateral damping coefficient, c_phi = xi_phi*k_phi (Omar)",
                  min=0.0, max=1.0e3),
        parameter("L_c", 0.325, "m", "Length of the intermediate shaft, lever of the suspended mass (Omar L_c)",
                  min=1.0e-6, max=1.0e3),
        parameter("rigid_intermediate_shaft", False, None,
                  "True: rigid intermediate shaft, no support motion (Brutti's rigid-body analysis)", type=bool),
        parameter("phi_in_start", 0.0, "rad", "Input shaft angle phi1 at the start time (0: yoke in joint 1's plane)",
                  min=-1.0e6, max=1.0e6),
        input_("omega_in", 0.0, "rad/s", "Input shaft angular speed omega1", **SPEED_RANGE),
        input_("tau_load", 0.0, "N.m", "Load torque on the output shaft (positive opposes positive rotation)",
               **TORQUE_RANGE),
        output("omega_out", "rad/s", "Output shaft angular speed omega4", ("omega_in",)),
        output("phi_out", "rad", "Output shaft angle phi4, continuous over revolutions"),
        output("tau_in", "N.m", "Torque demanded from the driver at the input shaft", ("omega_in", "tau_load")),
        output("twist", "rad", "Angle of twist of the intermediate shaft phi2 - phi3 (Omar Eq. 1, sign reversed)"),
        output("dynamic_misalignment", "rad", "Dynamic angular misalignment phi: joint angles beta1 + phi and "
               "beta2 + phi cos(joint_plane_angle) (Omar Eq. 3)"),
        output("omega_intermediate", "rad/s", "Intermediate shaft angular speed at its joint-1 end, dphi2/dt",
               ("omega_in",)),
        output("shaft_torque", "N.m", "Torque carried by the intermediate shaft: k_theta*twist + c_theta*dtwist/dt "
               "(flexible); rigid, the torque at its middle, (tau_in - J_in alpha1 - J_in' w1^2/2) / (dphi2/dphi1)",
               ("omega_in", "tau_load")),
        output("phi_in", "rad", "Input shaft angle phi1, continuous over revolutions"),
        output("alpha_in", "rad/s2", "Input shaft angular acceleration estimated from omega_in", ("omega_in",)),
        output("stored_energy", "J", "Kinetic plus elastic energy of the driveline", ("omega_in",)),
        output("tau_out", "N.m", "Torque at the output shaft's flange, passed by joint 2 to the output shaft and "
               "load: J_load*d(omega_out)/dt + tau_load (its 2x order is the excitation of what the output drives)",
               ("omega_in", "tau_load")),
    )
    DEFAULT_EXPERIMENT = (0.0, 3.0, 1.0e-3)


class DoubleCardanDrivelineTorqueDriven(TorqueDrivenSlave):
    """Torque-driven DoubleCardanDriveline: driving torque tau_in in, input shaft speed omega_in out (stable in
    explicit hosts).

    The same driveline as DoubleCardanDriveline (rigid: Brutti et al.; flexible: Omar et al.), with the input
    shaft free: its angle and speed join the state, integrated with the driver's rotor inertia J_drive lumped on
    the input shaft (model.TorqueDriven): rigid, (J_drive + J_eq) alpha1 =
    tau_in - J_eq' omega1^2/2 - rho tau_load; flexible, (J_drive + J_in) alpha1 = tau_in - J_in' omega1^2/2 -
    r1 (k_theta twist + c_theta dtwist), with the output and lateral equations unchanged. tau_in and tau_load are
    held over each step (classical RK4, substeps from the torsional mode of both shaft ends and 4|omega1|, or the
    fifth-order formula that starts DoubleCardanDriveline's exponential Adams method: model.flexible_step). The
    driveline starts untwisted at omega_in_start, the output at the kinematic speed. Outputs as
    DoubleCardanDriveline's; tau_input_shaft = tau_in - J_drive*alpha1 is what DoubleCardanDriveline calls tau_in.
    Wire it to MotorController (tau_motor -> tau_in, omega_in -> omega) and a Load. Signs as
    DoubleCardanDriveline's.
    """

    MODEL = dc.TorqueDriven
    VARIABLES = driven_ports(DoubleCardanDriveline)
    DEFAULT_EXPERIMENT = DoubleCardanDriveline.DEFAULT_EXPERIMENT
