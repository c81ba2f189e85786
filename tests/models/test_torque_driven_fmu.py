"""Torque-driven FMUs (CardanJointTorqueDriven, DoubleCardanDrivelineTorqueDriven) and MotorController through
fmpy: closed forms of the straight and constant-velocity layouts, the ports an explicit host needs."""

import dataclasses

import pytest
from fmpy.fmi1 import FMICallException

H = 1e-3


def _run(inst, params, inputs, n, outputs):
    inst.initialize(params)
    for k in range(n):
        inst.set(**inputs)
        inst.slave.doStep(k * H, H)
    return dict(zip(outputs, inst.get(*outputs)))


def test_straight_cardan_joint_is_a_rigid_inertia(open_fmu):
    """bend 0, no error angles: (J_drive + J1 + J2) alpha = tau_in - tau_load, output = input (closed form)."""
    params = dict(bend_angle=0.0, error_angle_beta=0.0, error_angle_gamma=0.0, J_drive=0.02, J1=0.01, J2=0.07,
                  omega_in_start=5.0, phi_in_start=0.3)
    out = _run(open_fmu("CardanJointTorqueDriven"), params, dict(tau_in=3.0, tau_load=1.0), 500,
               ("omega_in", "phi_in", "omega_out", "phi_out", "alpha_in", "tau_input_shaft", "M_z"))
    alpha, t = 2.0 / 0.1, 500 * H
    assert out["alpha_in"] == pytest.approx(alpha, rel=1e-12)
    assert out["omega_in"] == pytest.approx(5.0 + alpha * t, rel=1e-12)
    assert out["phi_in"] == pytest.approx(0.3 + 5.0 * t + 0.5 * alpha * t * t, rel=1e-12)
    assert (out["omega_out"], out["phi_out"]) == pytest.approx((out["omega_in"], out["phi_in"]), rel=1e-12)
    assert out["tau_input_shaft"] == pytest.approx(3.0 - 0.02 * alpha, rel=1e-12)   # what J1 + J2 + load take
    assert out["M_z"] == pytest.approx(0.07 * alpha + 1.0, rel=1e-12)


def test_constant_velocity_double_cardan_is_a_rigid_inertia(open_fmu):
    """Z layout (beta1 = beta2, yokes in phase), rigid shaft, massless joints: (J_drive + J_load) alpha = tau_in -
    tau_load and omega_out = omega_in."""
    params = dict(beta1=0.3, beta2=0.3, rigid_intermediate_shaft=True, J_drive=0.05, J_load=0.45)
    out = _run(open_fmu("DoubleCardanDrivelineTorqueDriven"), params, dict(tau_in=10.0, tau_load=4.0), 300,
               ("omega_in", "omega_out", "alpha_in", "tau_input_shaft", "shaft_torque"))
    alpha = 6.0 / 0.5
    assert out["alpha_in"] == pytest.approx(alpha, rel=1e-10)
    assert out["omega_in"] == pytest.approx(alpha * 300 * H, rel=1e-10)
    assert out["omega_out"] == pytest.approx(out["omega_in"], rel=1e-10)
    assert out["tau_input_shaft"] == pytest.approx(10.0 - 0.05 * alpha, rel=1e-10)


def test_flexible_double_cardan_settles_to_the_transmitted_torque(open_fmu):
    """Straight flexible driveline, held at speed by a load equal to the drive torque: the shaft carries tau_load
    (twist = tau_load / k_theta) once the torsional mode has decayed."""
    params = dict(beta1=0.0, beta2=0.0, J_drive=0.05, J_load=0.5, k_theta=2e4, xi_theta=0.01, omega_in_start=20.0)
    out = _run(open_fmu("DoubleCardanDrivelineTorqueDriven"), params, dict(tau_in=40.0, tau_load=40.0), 1500,
               ("omega_in", "omega_out", "shaft_torque", "twist"))
    assert out["shaft_torque"] == pytest.approx(40.0, rel=1e-3)
    assert out["twist"] == pytest.approx(40.0 / 2e4, rel=1e-3)
    assert out["omega_out"] == pytest.approx(out["omega_in"], rel=1e-4)


def test_speed_outputs_have_no_direct_feedthrough(fmu_dir):
    """An explicit host can read omega_in before setting tau_in: no algebraic loop with the controller."""
    from fmpy import read_model_description
    for name in ("CardanJointTorqueDriven", "DoubleCardanDrivelineTorqueDriven"):
        md = read_model_description(str(fmu_dir / f"{name}.fmu"))
        deps = {u.variable.name: [d.name for d in u.dependencies] for u in md.outputs}
        assert deps["omega_in"] == deps["omega_out"] == deps["phi_in"] == [], name
        assert sorted(deps["alpha_in"]) == ["tau_in", "tau_load"], name
    md = read_model_description(str(fmu_dir / "MotorController.fmu"))
    assert [d.name for u in md.outputs if u.variable.name == "tau_motor" for d in u.dependencies] == ["omega"]


def test_motor_controller_pi_law_and_anti_windup(open_fmu):
    """Constant reference 100 rad/s, measured speed 90 held: I = 10 t, tau = Kp 10 + Ki I until the limit; then
    the integral stops (conditional integration) and tau stays at tau_max."""
    m = open_fmu("MotorController")
    m.initialize(dict(profile=0, omega_set=100.0, Kp=0.5, Ki=2.0, tau_max=9.0))
    for k in range(100):
        m.set(omega=90.0)
        m.slave.doStep(k * H, H)
    assert m.get("tau_motor")[0] == pytest.approx(0.5 * 10.0 + 2.0 * 10.0 * 0.1, rel=1e-12)
    for k in range(100, 400):
        m.slave.doStep(k * H, H)
    assert m.get("tau_motor")[0] == 9.0
    m.set(omega=110.0)   # the error reverses: the integral, frozen near the limit, brings tau back at once
    assert m.get("tau_motor")[0] == pytest.approx(0.5 * -10.0 + 2.0 * 10.0 * 0.2, abs=0.05)


@pytest.mark.parametrize("fmu, params, needle", [
    ("CardanJointTorqueDriven", dict(J_drive=0.0, J1=0.0), "J_drive + J1"),
    ("DoubleCardanDrivelineTorqueDriven", dict(J_drive=0.0, I_input=0.0), "J_drive + I_input"),
])
def test_massless_input_shaft_is_refused(open_fmu, fmu, params, needle):
    inst = open_fmu(fmu)
    with pytest.raises(FMICallException):
        inst.initialize(params)
    assert any(needle in msg and "allowed range" in msg for msg in inst._log), inst._log


def test_a_torque_that_would_overspeed_the_input_shaft_within_the_step_is_refused(open_fmu):
    """1e6 N.m on 1e-3 kg.m2 reaches 1e6 rad/s in 1 ms, past the 1e4 rad/s port range: fmi2Discard with a
    message naming the cause, instead of 1e5 RK4 substeps of a meaningless motion."""
    inst = open_fmu("CardanJointTorqueDriven")
    inst.initialize(dict(J_drive=1e-3, J2=0.0))
    inst.set(tau_in=1e6)
    assert inst.raw("fmi2DoStep")(inst.slave.component, 0.0, H, 1) == 2
    assert "tau_in = 1000000.0 N.m" in inst._log[-1] and "would reach" in inst._log[-1], inst._log[-1]
    inst.set(tau_in=1.0)    # usable again with a sane torque
    inst.slave.doStep(0.0, H)
    assert inst.get("omega_in")[0] == pytest.approx(1.0 / (1e-3 + 2e-7) * H, rel=1e-12)


def test_the_flexible_double_cardan_checks_the_speed_reach_from_its_first_stage(open_fmu):
    """The flexible double Cardan steps from the rates its FMU evaluates for the speed check (``integrate_from``):
    an overspeeding torque is refused with the cause named, and a sane one then steps as the model's own
    ``integrate`` does, bit for bit."""
    from ujfmu.models.double_cardan_driveline import model as dc
    from ujfmu.models.protocol import Torques
    inst = open_fmu("DoubleCardanDrivelineTorqueDriven")
    inst.initialize(dict(J_drive=1e-3, omega_in_start=10.0))
    inst.set(tau_in=1e6)
    assert inst.raw("fmi2DoStep")(inst.slave.component, 0.0, H, 1) == 2
    assert "tau_in = 1000000.0 N.m" in inst._log[-1] and "would reach" in inst._log[-1], inst._log[-1]
    inst.set(tau_in=5.0, tau_load=1.0)
    from ujfmu.models.double_cardan_driveline.fmu import DoubleCardanDrivelineTorqueDriven as declared
    values = {v.name: v.start for v in declared.VARIABLES if v.causality == "parameter"}
    values.update(J_drive=1e-3, omega_in_start=10.0)
    p = dc.TorqueDrivenParameters(**{f.name: values[f.name] for f in dataclasses.fields(dc.TorqueDrivenParameters)
                                     if f.init})
    y0 = dc.TorqueDriven.initial_state(p, 0.0, Torques(5.0, 1.0))
    inst.slave.doStep(0.0, H)
    y1 = dc.TorqueDriven.integrate(p, 0.0, H, y0, Torques(5.0, 1.0))
    assert tuple(inst.get("omega_in", "phi_in")) == (y1[1], y1[0])


def test_aligned_twin_rotor_conserves_angular_momentum(open_fmu):
    """beta = 0, no unbalance: the shaft torques are internal, so (J_drive + J_gb) w_in + J_M1 w1 + J_M2 w2 grows
    at exactly tau_in - tau_load (a linear invariant, which RK4 keeps to round-off), while the shafts twist."""
    params = dict(beta=0.0, m_u1=0.0, m_u2=0.0, J_drive=0.02, omega_in_start=10.0)
    inst = open_fmu("TwinJeffcottRotorTorqueDriven")
    out = _run(inst, params, dict(tau_in=3.0, tau_load=1.0), 400,
               ("omega_in", "omega_disc1", "omega_out", "primary_shaft_torque", "X1", "Y2"))
    j_gb, j1, j2 = (inst.get(n)[0] for n in ("J_gb", "J_M1", "J_M2"))
    momentum = (0.02 + j_gb) * out["omega_in"] + j1 * out["omega_disc1"] + j2 * out["omega_out"]
    assert momentum == pytest.approx((0.02 + j_gb + j1 + j2) * 10.0 + 2.0 * 400 * H, rel=1e-12)
    assert out["primary_shaft_torque"] > 0.1     # twisted: the flange drives the discs
    assert out["X1"] == out["Y2"] == 0.0


def test_aligned_ring_coupling_conserves_angular_momentum(open_fmu):
    """e = 0 (no misalignment moment): the coupling's torque is internal, so (J_drive + I1) w1 + I2 w2 grows at
    exactly tau_in - tau_load; the coupling twists by the torque it passes to shaft 2, x_e -> -(I2 alpha + tau_load)
    / c_s with alpha = (tau_in - tau_load) / (J_in + I2), once the two-mass mode has decayed."""
    params = dict(e=0.0, I1=0.01, I2=0.05, J_drive=0.04, c_d=2.0, omega_in_start=5.0)
    inst = open_fmu("RingCouplingTorqueDriven")
    out = _run(inst, params, dict(tau_in=6.0, tau_load=2.0), 1500, ("omega_in", "omega_out", "x_e", "M_p"))
    c_s = inst.get("c_s")[0]
    assert 0.05 * out["omega_in"] + 0.05 * out["omega_out"] == pytest.approx(0.1 * 5.0 + 4.0 * 1500 * H, rel=1e-12)
    assert out["M_p"] == 0.0
    assert out["x_e"] == pytest.approx(-(0.05 * 4.0 / 0.1 + 2.0) / c_s, rel=1e-3)


@pytest.mark.parametrize("fmu", ["TwinJeffcottRotorTorqueDriven", "RingCouplingTorqueDriven",
                                 "DoubleCardanDrivelineTorqueDriven"])
def test_outputs_follow_the_torques_set_between_reads(open_fmu, fmu):
    """After a step the host reads the outputs, sets tau_in and tau_load (the FMU recomputes only the outputs that
    move with them, ``load_outputs``) and reads again: every output equals a second instance's that took the same
    step and got the final torques before its first read (never a stale value), and the acceleration moved."""
    insts = [open_fmu(fmu, f"i{k}") for k in range(2)]
    for inst in insts:
        inst.initialize(dict(omega_in_start=50.0))
        inst.set(tau_in=2.0, tau_load=1.0)
        inst.slave.doStep(0.0, H)
    from ujfmu.build import fmu_class
    names = [v.name for v in fmu_class(fmu).VARIABLES if v.causality == "output"]
    first, second = insts
    before = dict(zip(names, first.get(*names)))
    for tau_in, tau_load in ((5.0, 1.0), (5.0, 3.0), (-1.0, 0.5)):
        first.set(tau_in=tau_in, tau_load=tau_load)
        second.set(tau_in=tau_in, tau_load=tau_load)
        assert first.get(*names) == second.get(*names)
    assert dict(zip(names, first.get(*names)))["alpha_in"] != before["alpha_in"]


@pytest.mark.parametrize("fmu, params", [
    ("CardanJointTorqueDriven", dict(bend_angle=0.5)),
    ("DoubleCardanDrivelineTorqueDriven", dict()),
    ("DoubleCardanDrivelineTorqueDriven", dict(rigid_intermediate_shaft=True))])
def test_a_read_of_the_speeds_alone_is_never_stale(open_fmu, fmu, params):
    """A host reads omega_in and omega_out after each step (the FMU computes only its STATE_OUTPUTS then), sets the
    torques and reads every output: each read equals a second instance's that took the same steps and read every
    output each time. A state saved before such a read and restored after it gives the same speeds again (the
    restored output variables are those of before the read)."""
    from ujfmu.build import fmu_class
    names = [v.name for v in fmu_class(fmu).VARIABLES if v.causality == "output"]
    speeds = ["omega_in", "omega_out"]
    first, second = (open_fmu(fmu, f"i{k}") for k in range(2))
    for inst in (first, second):
        inst.initialize(dict(params, omega_in_start=50.0))
    for k, (tau_in, tau_load) in enumerate(((2.0, 1.0), (5.0, 1.0), (-1.0, 0.5), (3.0, 3.0))):
        assert first.get(*speeds) == [dict(zip(names, second.get(*names)))[s] for s in speeds]
        for inst in (first, second):
            inst.set(tau_in=tau_in, tau_load=tau_load)
        assert first.get(*names) == second.get(*names)
        for inst in (first, second):
            inst.slave.doStep(k * H, H)
    saved = first.slave.getFMUState()
    read = first.get(*speeds)
    first.slave.setFMUState(saved)
    assert first.get(*speeds) == read == [dict(zip(names, second.get(*names)))[s] for s in speeds]
    first.slave.freeFMUState(saved)


@pytest.mark.parametrize("name, names", [("CardanJointTorqueDriven", "J_drive + J1"),
                                         ("DoubleCardanDrivelineTorqueDriven", "J_drive + I_input"),
                                         ("TwinJeffcottRotorTorqueDriven", "J_drive + J_gb"),
                                         ("RingCouplingTorqueDriven", "J_drive + I1")])
def test_a_denormal_driver_inertia_is_refused_by_name(fmu_dir, name, names):
    """J_drive = 2.2e-311 kg.m2 (a denormal, within J_drive's declared range [0, 1e6], with the default shaft
    inertia 0 beside it): the ring coupling's setup had divided by it and died on a bare "float division by zero"
    (hypothesis found it). Every torque-driven FMU refuses it at initialization, naming the sum and its least
    value."""
    from ujfmu.master import Component, CosimulationError, cosimulate
    zero = {"CardanJointTorqueDriven": "J1", "DoubleCardanDrivelineTorqueDriven": "I_input",
            "TwinJeffcottRotorTorqueDriven": "J_gb", "RingCouplingTorqueDriven": "I1"}[name]
    with pytest.raises(CosimulationError) as info:
        cosimulate([Component("m", fmu_dir / f"{name}.fmu", {"J_drive": 2.2e-311, zero: 0.0})], [], 0.01, 1e-3,
                   ["m.omega_in"])
    assert f"{names} = 2.2e-311 kg.m2 must be at least 1e-09" in str(info.value), str(info.value)
