"""TwinJeffcottRotor FMU: two unbalanced Jeffcott rotors coupled through a Hooke joint (Tchomeni, Alugongo, Masu)."""

import math

from . import model as tj
from ...fmu.base import SPEED_RANGE, TORQUE_RANGE, PrescribedInputSlave, input_, output, parameter
from ...fmu.torque_driven import TorqueDrivenSlave, driven_ports

_RIG = tj.rig_parameters()
_MASS = dict(min=1.0e-6, max=1.0e6)
_INERTIA = dict(min=1.0e-9, max=1.0e6)
_STIFFNESS = dict(min=1.0e-6, max=1.0e12)
_DAMPING = dict(min=0.0, max=1.0e9)
_PHASE = dict(min=-2.0 * math.pi, max=2.0 * math.pi)


def _disc_parameters(i, shaft):
    return (
        parameter(f"M{i}", _RIG[f"M{i}"], "kg", f"Mass of disc {i} without its unbalance (paper M{i})", **_MASS),
        parameter(f"J_M{i}", _RIG[f"J_M{i}"], "kg.m2", f"Polar moment of inertia of disc {i} (paper J_M{i})",
                  **_INERTIA),
        parameter(f"m_u{i}", _RIG[f"m_u{i}"], "kg", f"Unbalance mass on disc {i} (paper m_u{i})", min=0.0, max=1.0e3),
        parameter(f"phase_u{i}", 0.0, "rad", f"Angle of disc {i}'s unbalance at theta{i} = 0 from the X axis (in "
                  "the plane of the two shafts), positive in the direction of rotation", **_PHASE),
        parameter(f"K{i}X", _RIG[f"K{i}X"], "N/m", f"Lateral stiffness of the {shaft} shaft at disc {i}, X "
                  "(paper K{i}X{i}X; default 48 E I / L^3)", **_STIFFNESS),
        parameter(f"K{i}Y", _RIG[f"K{i}Y"], "N/m", f"Lateral stiffness of the {shaft} shaft at disc {i}, Y",
                  **_STIFFNESS),
        parameter(f"C{i}X", _RIG[f"C{i}X"], "N.s/m", f"Lateral viscous damping at disc {i}, X (paper C{i}X{i}X)",
                  **_DAMPING),
        parameter(f"C{i}Y", _RIG[f"C{i}Y"], "N.s/m", f"Lateral viscous damping at disc {i}, Y", **_DAMPING),
        parameter(f"K{i}T", _RIG[f"K{i}T"], "N.m/rad", f"Torsional stiffness of the {shaft} shaft (paper K{i}T; "
                  "default G J_p / L)", min=1.0e-6, max=1.0e9),
        parameter(f"C{i}T", _RIG[f"C{i}T"], "N.m.s/rad", f"Torsional viscous damping of the {shaft} shaft "
                  f"(paper C{i}T)", min=0.0, max=1.0e6),
        parameter(f"L{i}", _RIG[f"L{i}"], "m", f"Bearing span of the {shaft} shaft (disc mid-span; the joint-end "
                  f"slope is 3 X{i} / L{i})", min=1.0e-3, max=1.0e3),
    )


class TwinJeffcottRotor(PrescribedInputSlave):
    """Two unbalanced Jeffcott rotors coupled through a Hooke joint, Tchomeni, Alugongo, Masu Eqs. (1)-(11).

    Input (gearbox output flange, inertia J_gb) -> primary shaft (torsion K1T, C1T) -> disc 1 (lateral X1, Y1) ->
    Hooke joint at angle beta -> secondary shaft (torsion K2T, C2T) -> disc 2 (lateral X2, Y2) <- tau_load.
    Six degrees of freedom (theta1, X1, Y1, theta2, X2, Y2) from Lagrange's equations with the paper's energies
    (Eqs. 4-8, re-derived: README.md), exact Hooke kinematics tan(psi) = cos(beta) tan(theta1) between
    the shafts' bent end sections, so that the joint's transmitted torque loads the shafts laterally (secondary
    couple, twice running speed). Integrated by an exponential Adams predictor-corrector, one evaluation of the
    equations per substep (the torsional chain and the Jeffcott oscillators exactly; model.multistep_step, its
    history of the equations' values part of the FMU state), started and restarted by a fourth-order exponential
    Runge-Kutta method (model.exponential_step), one substep per 1 ms step on the default rig; the input angle
    follows omega_in extrapolated linearly over each step (alpha_in the backward difference). Starts with untwisted
    shafts and centred discs turning with the input until the first step.
    Signs: tau_in > 0 drives; tau_load > 0 opposes disc 2's positive rotation; shaft torques > 0 while transmitting drive.
    X1, Y1 in the primary shaft's frame, X2, Y2 in the secondary's: Z along each shaft towards the load, X in the
    plane of the two shafts, positive towards the side the secondary shaft leans to at beta > 0 (the inside of the
    bend), Y = Z x X (README.md, "The system").
    """

    MODEL = tj
    VARIABLES = (
        parameter("beta", _RIG["beta"], "rad", "Hooke joint angle between primary and secondary shaft (paper beta)",
                  min=-tj.MAX_ANGLE, max=tj.MAX_ANGLE),
        *_disc_parameters(1, "primary"),
        *_disc_parameters(2, "secondary"),
        parameter("e", _RIG["e"], "m", "Radius of both unbalance masses from the disc centre (paper e)",
                  min=0.0, max=10.0),
        parameter("J_gb", _RIG["J_gb"], "kg.m2", "Gearbox output inertia, turning with the input (paper J_gb1)",
                  min=0.0, max=1.0e6),
        parameter("phi_in_start", 0.0, "rad", "Input angle at the start time (0: driving pin normal to the plane "
                  "of the shafts)", min=-1.0e6, max=1.0e6),
        input_("omega_in", 0.0, "rad/s", "Input (gearbox output) angular speed", **SPEED_RANGE),
        input_("tau_load", 0.0, "N.m", "Load torque on disc 2 (positive opposes positive rotation)",
               **TORQUE_RANGE),
        output("omega_out", "rad/s", "Disc 2 angular speed theta2'", ("omega_in",)),
        output("phi_out", "rad", "Disc 2 angle theta2, continuous over revolutions"),
        output("tau_in", "N.m", "Torque demanded from the driver, J_gb alpha_in + primary shaft torque",
               ("omega_in",)),
        output("X1", "m", "Disc 1 centre displacement along X (primary frame, in the plane of the shafts, "
               "positive towards the side the secondary shaft leans to at beta > 0)"),
        output("Y1", "m", "Disc 1 centre displacement along Y (normal to the plane of the shafts, Z x X, Z "
               "towards the load)"),
        output("X2", "m", "Disc 2 centre displacement along X (secondary frame, in the plane of the shafts, "
               "positive towards the inside of the bend at beta > 0)"),
        output("Y2", "m", "Disc 2 centre displacement along Y (normal to the plane of the shafts, Z x X, Z "
               "towards the load)"),
        output("phi_in", "rad", "Input angle, continuous over revolutions"),
        output("alpha_in", "rad/s2", "Input angular acceleration estimated from omega_in", ("omega_in",)),
        output("phi_disc1", "rad", "Disc 1 angle theta1, continuous over revolutions"),
        output("omega_disc1", "rad/s", "Disc 1 angular speed theta1'", ("omega_in",)),
        output("primary_shaft_torque", "N.m", "K1T (phi_in - theta1) + C1T (omega_in - theta1')", ("omega_in",)),
        output("secondary_shaft_torque", "N.m", "K2T (psi - theta2) + C2T (psi' - theta2'), psi the joint output",
               ("omega_in",)),
        output("stored_energy", "J", "Kinetic energy of gearbox flange and discs plus elastic energy", ("omega_in",)),
        output("dissipated_energy", "J", "Energy dissipated by all dampers since the start"),
        output("input_work", "J", "Work done on the rotor through the input since the start"),
    )
    DEFAULT_EXPERIMENT = (0.0, 4.0, 1.0e-3)


class TwinJeffcottRotorTorqueDriven(TorqueDrivenSlave):
    """Torque-driven TwinJeffcottRotor: driving torque tau_in in, input (gearbox flange) speed omega_in out.

    The same rotor as TwinJeffcottRotor (Tchomeni, Alugongo, Masu Eqs. 1-11, re-derived), with the gearbox flange
    free: its angle and speed are a state integrated from (J_drive + J_gb) alpha_in = tau_in - T1, T1 the primary
    shaft torque, J_drive the driver's rotor inertia lumped on the flange (model.TorqueDriven); tau_in and tau_load
    held over each step. Integrated as TwinJeffcottRotor is, in twist coordinates about the flange's rigid rotation
    with the flange in the torsional chain: an exponential Adams predictor-corrector, one evaluation of the equations
    per step (model.torque_multistep_step, its history of the equations' values part of the FMU state), started and
    restarted (step length changed, torque steps) by ETDRK4-B (model.torque_exponential_step); one substep per 1 ms
    step on the default rig up to about 240 rad/s. Outputs as TwinJeffcottRotor's; tau_input_shaft = tau_in - J_drive*alpha_in is what TwinJeffcottRotor calls
    tau_in, and input_work its integral times omega_in. Offers Model Exchange (FMI 3.0): no input derivative is
    needed. Wire it to MotorController (tau_motor -> tau_in, omega_in -> omega) and a Load (omega_out -> omega,
    tau -> tau_load). Signs as TwinJeffcottRotor's.
    """

    MODEL = tj.TorqueDriven
    VARIABLES = driven_ports(TwinJeffcottRotor)
    DEFAULT_EXPERIMENT = TwinJeffcottRotor.DEFAULT_EXPERIMENT
