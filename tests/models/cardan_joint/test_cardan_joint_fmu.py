"""CardanJoint.fmu through fmpy: power balance, continuity, acceleration from history, errors."""

import math

import numpy as np
import pytest
from fmpy.fmi1 import FMICallException

from ujfmu.models.cardan_joint import model as cardan

OUT = ("omega_out", "phi_out", "tau_in", "M_x", "M_y", "M_z", "phi_in", "alpha_in")


def test_lossless_at_constant_speed_to_round_off(open_fmu, drive):
    rows = drive(open_fmu("CardanJoint"), lambda t: 80.0, 0.3, 1e-3, 400, OUT,
                 dict(J1=0.0, J2=0.0, bend_plane_angle=0.2))
    omega_in, omega_out, tau_in, m_z = rows.omega_in, rows.omega_out, rows.tau_in, rows.M_z
    np.testing.assert_allclose(tau_in * omega_in, m_z * omega_out, rtol=1e-14)
    assert np.ptp(tau_in) > 0.05  # the balance is not trivial: tau_in fluctuates


def test_driven_angle_is_the_hooke_closed_form_and_continuous(open_fmu, drive):
    """Bend phi only: tan(theta2) = tan(theta1) / cos(phi) (the driven angle in the quadrant of theta1)."""
    h, w, phi = 1e-3, 300.0, math.radians(30)  # ~48 revolutions in 1 s
    rows = drive(open_fmu("CardanJoint"), lambda t: w, 0.3, h, 1000, OUT,
                 dict(error_angle_beta=0.0, error_angle_gamma=0.0))
    theta1 = w * rows.time
    np.testing.assert_allclose(rows.phi_in, theta1, rtol=1e-12, atol=1e-12)
    closed = np.unwrap(np.arctan2(np.sin(theta1), np.cos(theta1) * math.cos(phi)))
    np.testing.assert_allclose(rows.phi_out, closed, rtol=0, atol=1e-11)
    ratio = math.cos(phi) / (1 - math.sin(phi) ** 2 * np.cos(theta1) ** 2)
    np.testing.assert_allclose(rows.omega_out, ratio * w, rtol=1e-12)
    assert np.max(np.abs(np.diff(rows.phi_out))) < 2 * w * h  # no 2*pi jumps


@pytest.mark.parametrize("tau_load", [0.3, -0.2])
def test_moment_components_satisfy_the_torque_balance(open_fmu, drive, tau_load):
    """M = (M_x, M_y, M_z) on the driven shaft, bend phi only, driving shaft accelerating (J1, J2 > 0):
    - driven shaft: M_z = J2 alpha2 + tau_load, alpha2 = d(omega_out)/dt;
    - driving shaft, about its axis K = R_x(phi) e_z = (0, -sin phi, cos phi): M . K = tau_in - J1 alpha1;
    - no moment through the frictionless driven pin e2 = (-cos theta2, -sin theta2, 0): M . e2 = 0."""
    h, a, phi, j1, j2 = 1e-4, 400.0, math.radians(30), 2e-4, 1e-3
    rows = drive(open_fmu("CardanJoint"), lambda t: 60.0 + a * t, tau_load, h, 3000, OUT,
                 dict(error_angle_beta=0.0, error_angle_gamma=0.0, J1=j1, J2=j2))[2:]
    alpha2 = np.gradient(rows.omega_out, h)
    inner = slice(1, -1)                                  # central differences, error (h omega)^2/6 ~ 2e-4
    m_x, m_y, m_z = rows.M_x, rows.M_y, rows.M_z
    assert np.ptp(j2 * alpha2[inner]) > 10 * abs(tau_load)   # the inertia term matters
    np.testing.assert_allclose(m_z[inner], j2 * alpha2[inner] + tau_load, rtol=0, atol=1e-3 * np.ptp(m_z))
    np.testing.assert_allclose(-m_y * math.sin(phi) + m_z * math.cos(phi), rows.tau_in - j1 * a, rtol=1e-12,
                               atol=1e-12 * np.ptp(m_z))
    theta2 = rows.phi_out
    np.testing.assert_allclose(-m_x * np.cos(theta2) - m_y * np.sin(theta2), 0.0, atol=1e-12 * np.ptp(m_z))
    assert min(np.ptp(m_x), np.ptp(m_y)) > 0.1 * np.ptp(m_z)


def test_driving_acceleration_from_speed_history_is_exact_for_a_ramp(open_fmu, drive):
    """alpha1 estimated from the omega_in history; theta1 advanced with linear extrapolation: exact for a ramp."""
    a, h = 30.0, 1e-3
    rows = drive(open_fmu("CardanJoint"), lambda t: a * t, 0.3, h, 2000, OUT, dict(J2=1e-5))
    np.testing.assert_allclose(rows.alpha_in[1:], a, rtol=1e-9)
    np.testing.assert_allclose(rows.phi_in[2:], 0.5 * a * rows.time[2:] ** 2, atol=a * h * h)


def test_fmu_estimates_the_acceleration_to_second_order(open_fmu, drive):
    """The CardanJoint FMU's alpha_in fed a speed quadratic in time is its exact derivative from the third point
    on (the backward difference would be off by b h); alpha_in is the alpha1 in its tau_in."""
    a, b, h = 30.0, 400.0, 1e-3
    rows = drive(open_fmu("CardanJoint"), lambda t: 5.0 + a * t + b * t * t, 0.3, h, 50,
                 ("alpha_in", "phi_in", "tau_in"), dict(J2=1e-5))
    np.testing.assert_allclose(rows.alpha_in[2:], a + 2.0 * b * rows.time[2:], rtol=1e-9)
    np.testing.assert_allclose(rows.alpha_in[1], a + b * h, rtol=1e-9)   # one difference only: backward
    frame = cardan.joint_frame(math.radians(30.0), 0.0, math.radians(0.3), math.radians(0.3))
    tau = [cardan.joint_torques(frame, p, w, al, 0.3, 2e-7, 1e-5)[0]
           for p, w, al in zip(rows.phi_in, rows.omega_in, rows.alpha_in)]
    np.testing.assert_allclose(rows.tau_in, tau, rtol=1e-12)


def test_combined_shaft_angle_beyond_limit_is_rejected(open_fmu):
    inst = open_fmu("CardanJoint")
    with pytest.raises(FMICallException):
        inst.initialize(dict(bend_angle=math.radians(85), bend_plane_angle=math.radians(85)))
    assert any("total shaft angle" in m for m in inst._log)


def test_many_instances_after_failures_in_one_process(open_fmu):
    """pythonfmu 0.7.0 workarounds: instances keep working after failed ones (process survives)."""
    for i in range(3):
        bad = open_fmu("CardanJoint", f"bad{i}")
        with pytest.raises(FMICallException):
            bad.initialize(dict(J1=-1.0))
    good = [open_fmu("CardanJoint", f"good{i}") for i in range(5)]
    for i, inst in enumerate(good):
        inst.initialize(dict(bend_angle=math.radians(5 * (i + 1))))
        inst.set(omega_in=10.0, tau_load=1.0)
    for inst in good:
        inst.slave.doStep(0.0, 1e-3)
    r = [inst.get("tau_in")[0] for inst in good]
    assert len(set(r)) == 5


def test_output_read_in_initialization_mode_with_bad_parameters_is_an_error_not_a_crash(open_fmu):
    inst = open_fmu("CardanJoint")
    inst.slave.setupExperiment(startTime=0.0)
    inst.slave.enterInitializationMode()
    inst.set(bend_angle=math.pi / 2)  # cos(phi) = 0: the kinematics are singular
    with pytest.raises(FMICallException):
        inst.get("tau_in", "omega_out")
    assert any("cannot compute" in m for m in inst._log), inst._log


def test_a_percent_sign_in_a_message_reaches_a_formatting_host_intact(fmu_dir):
    """An FMI 2.0 logger message is a printf format, which fmpy's simulate_fmu expands like a C host: the
    default error angles' warning at a 2 deg bend ("-25.4% ... +34.4% at the mirror-image bend") had arrived as
    "+34.4 0x0.05...p-1022t the mirror-image" ('%a' read as a conversion). It arrives as written, and the
    run completes."""
    from fmpy import simulate_fmu
    messages = []

    def logger(component, instance, status, category, message):
        messages.append(message.decode())
    inputs = np.array([(0.0, 62.83, 0.3), (1.0, 62.83, 0.3)],
                      dtype=[("time", float), ("omega_in", float), ("tau_load", float)])
    result = simulate_fmu(str(fmu_dir / "CardanJoint.fmu"), stop_time=0.01, output_interval=1e-3, input=inputs,
                          start_values={"bend_angle": math.radians(2.0)}, output=["omega_out"], logger=logger,
                          debug_logging=True)
    assert result["time"][-1] == pytest.approx(0.01)
    (warning,) = [m for m in messages if "error_angle_beta" in m]
    assert "% at the mirror-image bend_angle" in warning and "0x" not in warning and "%%" not in warning


@pytest.mark.parametrize("phase, low, high", [(math.pi / 2, 1.0, 1.0),
                                              (0.0, math.cos(0.35) ** 2, 1.0 / math.cos(0.35) ** 2)])
def test_two_joints_in_a_z_layout_cancel_when_their_yokes_are_in_phase(fmu_dir, phase, low, high):
    """Two ideal CardanJoints of 0.35 rad in series on a constant-speed ideal source (README, "Angle origins"): with
    the second's phi_in_start a quarter turn after the first's phi_out at the start, the intermediate yokes are in
    phase and the output turns at the input's speed (a Z layout, the classical cancellation); with both at 0 the 2x
    fluctuations add, the ratio from cos^2 beta to 1/cos^2 beta."""
    from ujfmu.master import Component, Connection, cosimulate
    joint = dict(bend_angle=0.35, error_angle_beta=0.0, error_angle_gamma=0.0)
    components = [Component("motor", fmu_dir / "Motor.fmu", dict(ideal_speed_source=True, profile=0, omega_set=30.0)),
                  Component("j1", fmu_dir / "CardanJoint.fmu", joint),
                  Component("j2", fmu_dir / "CardanJoint.fmu", dict(joint, phi_in_start=phase))]
    connections = [Connection("motor.omega", "j1.omega_in"), Connection("j1.omega_out", "j2.omega_in")]
    table = cosimulate(components, connections, 0.5, 1e-4, ["motor.omega", "j2.omega_out"], coupling="explicit")
    ratio = table["j2.omega_out"] / table["motor.omega"]
    assert ratio.min() == pytest.approx(low, rel=1e-5) and ratio.max() == pytest.approx(high, rel=1e-5)
