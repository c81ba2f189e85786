"""CardanJoint FMU: one universal joint between a driving and a driven shaft (Feng, Wang, Zhu)."""

import math

from . import model as cardan
from ...fmu.base import SPEED_RANGE, TORQUE_RANGE, PrescribedInputSlave, input_, output, parameter
from ...fmu.torque_driven import TorqueDrivenSlave, driven_ports

_ANGLE = dict(min=-cardan.MAX_ANGLE, max=cardan.MAX_ANGLE)
_INERTIA = dict(min=0.0, max=1.0e6)


class CardanJoint(PrescribedInputSlave):
    """Universal (Cardan/Hooke) joint with structural and error misalignment, Feng, Wang, Zhu Eqs. (1)-(10).

    The driving shaft follows the input speed omega_in; the driven shaft follows the joint's exact kinematics,
    theta2 = theta2(theta1), omega2 = r(theta1)*omega1 with r = K_z/xi^2. The driven-side inertia J2 and the load
    torque set the transmitted moment, M_z = tau_load + J2*alpha2, alpha2 = r*alpha1 + r'*omega1^2; Eq. (8)/(10)
    then give the moment vector (M_x, M_y, M_z) in the driven xyz frame and the driving torque
    tau_in = J1*alpha1 + M (e_n . K) that the joint demands from the driver.

    Driving acceleration from the input speed history, to second order: alpha1 at t_k is the slope at t_k of the
    parabola through omega_in at t_k, t_k-1 and t_k-2 (BDF2, (3 w_k - 4 w_k-1 + w_k-2) / 2h for equal steps;
    the backward difference after the first step, zero before it), so that tau_in at t_k is the instantaneous
    torque, not the one of half a step earlier. Over a step the driving angle is advanced with the input
    extrapolated linearly, theta1 += omega_in*h + alpha1*h^2/2, which is exact for constant speed and for
    constant acceleration (Feng's start-up). In a host that couples explicitly (no iteration) the speed-driven
    joint is stable while its inertia reflected to the input, J1 + J2 r^2, is below half the driver's.

    Signs: omega_in, omega_out > 0 turn the shafts the same way; tau_in > 0 is the torque the driver applies in
    the sense of positive rotation; tau_load > 0 opposes positive rotation of the driven shaft; M_z > 0 drives it.
    Lossless: tau_in*omega_in = M_z*omega_out when J1 = J2 = 0.
    """

    MODEL = cardan
    ACCELERATION_ORDER = 2
    VARIABLES = (
        parameter("bend_angle", math.radians(30.0), "rad",
                  "Structural misalignment phi, C_phi = R_x(phi) (Feng Eq. 1); laboratory model 30 deg", **_ANGLE),
        parameter("bend_plane_angle", 0.0, "rad",
                  "Structural misalignment delta, C_delta = R_y(delta) (Feng Eq. 1): a second bend component about "
                  "y, not the azimuth of the bend plane (shaft angle acos(cos phi cos delta))", **_ANGLE),
        parameter("error_angle_beta", cardan.LAB_ERROR_ANGLE, "rad",
                  "Error misalignment beta, C_beta = R_x(-beta) (Feng Eq. 1); laboratory model 0.3 deg (set it and "
                  "error_angle_gamma to 0 for an ideal joint)", **_ANGLE),
        parameter("error_angle_gamma", cardan.LAB_ERROR_ANGLE, "rad",
                  "Error misalignment gamma, C_gamma = R_y(-gamma) (Feng Eq. 1); laboratory model 0.3 deg (set it "
                  "and error_angle_beta to 0 for an ideal joint)", **_ANGLE),
        parameter("J1", 2.0e-7, "kg.m2", "Driving shaft moment of inertia (Feng Eq. 8); laboratory model",
                  **_INERTIA),
        parameter("J2", 0.0, "kg.m2",
                  "Driven-side moment of inertia carried by the joint (0: Feng's massless driven side)", **_INERTIA),
        parameter("phi_in_start", 0.0, "rad", "Driving shaft angle theta1 at the start time (0: driving yoke's pin "
                  "in the bend plane, speed ratio at its maximum 1/cos(phi), with delta and the error angles 0)",
                  min=-1.0e6, max=1.0e6),
        input_("omega_in", 0.0, "rad/s", "Driving shaft angular speed omega1", **SPEED_RANGE),
        input_("tau_load", 0.0, "N.m", "Load torque on the driven shaft (positive opposes positive rotation)",
               **TORQUE_RANGE),
        output("omega_out", "rad/s", "Driven shaft angular speed omega2 = r(theta1)*omega1", ("omega_in",)),
        output("phi_out", "rad", "Driven shaft angle theta2, continuous over revolutions"),
        output("tau_in", "N.m", "Driving torque T0 demanded from the driver (Feng Eq. 8)",
               ("omega_in", "tau_load")),
        output("M_x", "N.m", "Transmitted moment on the driven shaft, x component (Feng Eq. 10)",
               ("omega_in", "tau_load")),
        output("M_y", "N.m", "Transmitted moment on the driven shaft, y component (Feng Eq. 10)",
               ("omega_in", "tau_load")),
        output("M_z", "N.m", "Transmitted moment on the driven shaft, z (torsional) component (Feng Eq. 10)",
               ("omega_in", "tau_load")),
        output("phi_in", "rad", "Driving shaft angle theta1, continuous over revolutions"),
        output("alpha_in", "rad/s2", "Driving shaft angular acceleration alpha1 estimated from omega_in",
               ("omega_in",)),
    )
    DEFAULT_EXPERIMENT = (0.0, 1.0, 1.0e-3)


class CardanJointTorqueDriven(TorqueDrivenSlave):
    """Torque-driven CardanJoint: driving torque tau_in in, input shaft speed omega_in out (stable in explicit hosts).

    The same joint as CardanJoint (Feng, Wang, Zhu Eqs. 1-10), with the driving shaft free: its angle and speed
    are a state integrated from (J_drive + J1 + J2 r^2) alpha1 = tau_in - J2 r r' omega1^2 - r tau_load
    (model.TorqueDriven), J_drive the driver's rotor inertia lumped on the driving shaft,
    tau_in and tau_load held over each step (classical RK4, substeps from the kinematic harmonics 4|omega1|).
    Outputs as CardanJoint's; tau_input_shaft = tau_in - J_drive*alpha1 is what CardanJoint calls tau_in.
    Wire it to MotorController (tau_motor -> tau_in, omega_in -> omega) and a Load (omega_out -> omega,
    tau -> tau_load). Signs as CardanJoint's.
    """

    MODEL = cardan.TorqueDriven
    VARIABLES = driven_ports(CardanJoint)
    DEFAULT_EXPERIMENT = CardanJoint.DEFAULT_EXPERIMENT
