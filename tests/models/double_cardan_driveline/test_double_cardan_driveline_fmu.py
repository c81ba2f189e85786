"""DoubleCardanDriveline.fmu through fmpy: continuity, power balance, errors. Every output of the flexible
driveline against the independent monolithic reference: scenarios/double_cardan_omar_*.toml."""

import math
from pathlib import Path

import numpy as np
import pytest
from fmpy.fmi1 import FMICallException

OUT = ("omega_out", "phi_out", "tau_in", "twist", "dynamic_misalignment", "omega_intermediate", "shaft_torque",
       "phi_in", "stored_energy")
DEG = math.pi / 180.0


def test_rigid_constant_velocity_layout_at_speed_keeps_angles_continuous(open_fmu, drive):
    """Z layout, yokes in phase, rigid, 200 rad/s for 1 s (~32 revolutions): output angle = input angle."""
    r = drive(open_fmu("DoubleCardanDriveline"), lambda t: 200.0, 50.0, 1e-3, 1000, OUT,
              dict(rigid_intermediate_shaft=True, J_load=0.0))
    np.testing.assert_allclose(r.phi_out, r.phi_in, atol=1e-9)
    np.testing.assert_allclose(r.tau_in, 50.0, rtol=1e-12)
    assert np.all(np.diff(r.phi_out) > 0) and r.phi_out[-1] > 60 * math.pi
    assert np.ptp(r.omega_intermediate) > 5.0


def test_power_balance_through_the_fmu_outputs(open_fmu, drive):
    """Undamped, constant input speed and load: tau_in w1 - tau_load w4 = dE/dt (E the FMU's stored_energy)."""
    h = 2e-4
    r = drive(open_fmu("DoubleCardanDriveline"), lambda t: 60.0, 5.0, h, 2500, OUT,
              dict(xi_theta=0.0, xi_phi=0.0, beta2=-15 * DEG))
    power = r.tau_in * r.omega_in - 5.0 * r.omega_out
    work = np.concatenate([[0.0], np.cumsum(0.5 * (power[1:] + power[:-1]) * h)])
    energy = r.stored_energy - r.stored_energy[0]
    assert np.ptp(energy) > 0.01
    assert np.max(np.abs(energy - work)) < 2e-3 * np.ptp(energy)   # trapezoidal rule, O(h^2)


@pytest.mark.parametrize("params,needle", [({"J_load": 0.0}, "J_load"),
                                           ({"I_cross_pin": 1e-3, "I_cross_normal": 3e-3}, "I_cross_normal")])
def test_inconsistent_parameters_are_errors_naming_them(open_fmu, params, needle):
    inst = open_fmu("DoubleCardanDriveline")
    with pytest.raises(FMICallException):
        inst.initialize(params)
    assert any(needle in m for m in inst._log), inst._log


@pytest.mark.parametrize("rigid", [True, False])
def test_fmu_estimates_the_input_acceleration_to_second_order(open_fmu, drive, rigid):
    """Fed a speed quadratic in time, alpha_in is its exact derivative at t_k from the third point on (BDF2; the
    backward difference would be off by b h, half a step late), in both modes; the first step has one difference
    only (backward)."""
    a, b, h = 30.0, 400.0, 1e-3
    r = drive(open_fmu("DoubleCardanDriveline"), lambda t: 5.0 + a * t + b * t * t, 5.0, h, 40, ("alpha_in",),
              dict(rigid_intermediate_shaft=rigid))
    np.testing.assert_allclose(r.alpha_in[2:], a + 2.0 * b * r.time[2:], rtol=1e-9)
    np.testing.assert_allclose(r.alpha_in[1], a + b * h, rtol=1e-9)


@pytest.mark.parametrize("name", ["DoubleCardanDriveline", "DoubleCardanDrivelineTorqueDriven"])
def test_steps_from_the_outputs_evaluation_are_the_steps_evaluated_afresh(monkeypatch, name):
    """Python level, in the host's order (speed-driven: omega_in, read, tau_load, step; torque-driven: read
    omega_in, tau_in, read alpha_in, tau_load, step): two instances stepped in turns, with different inputs, reuse
    their outputs' evaluation from the second step on (speed-driven: the Dormand-Prince steps that start the
    exponential Adams method take 6 evaluations of the equations where there were 7, then the method 2 for 3; the
    torque-driven Dormand-Prince steps 6 for 7, its first read, of omega_in alone, evaluating nothing:
    ``TorqueDriven.STATE_OUTPUTS``) and follow, bit for
    bit, two instances that reuse nothing; a saved FMU state restored, in memory or through serialization into a
    fresh instance, repeats the steps bit for bit."""
    from ujfmu.build import fmu_class
    from ujfmu.models.double_cardan_driveline import model as dc
    cls = fmu_class(name)
    torque_driven = name.endswith("TorqueDriven")
    calls, rates = [0], dc._flexible_rates

    def counting(*args):
        calls[0] += 1
        return rates(*args)
    monkeypatch.setattr(dc, "_flexible_rates", counting)

    def start(instance_name):
        inst = cls(instance_name=instance_name)
        inst.exit_initialization_mode()
        return inst

    def step(inst, k, scale, afresh=False):
        """One communication step from point k: the host's calls, then doStep; the evaluations it took (afresh:
        nothing reused, the memo emptied before each read and the step)."""
        vr = {v.name: v.value_reference for v in inst.vars.values()}
        t, calls[0] = k * 1e-3, 0

        def read(*names):
            if afresh:
                inst._p.outputs_memo = None
            inst.get_real([vr[name] for name in names])
        if torque_driven:
            read("omega_in")
            inst.set_real([vr["tau_in"]], [scale * (3.0 + 40.0 * t)])
            read("alpha_in", "shaft_torque")
        else:
            inst.set_real([vr["omega_in"]], [scale * (70.0 + 300.0 * t)])
            read("tau_in", "shaft_torque")
        inst.set_real([vr["tau_load"]], [scale * (1.0 + 20.0 * t)])
        if afresh:
            inst._p.outputs_memo = None
        assert inst.do_step(t, 1e-3)
        return calls[0]

    served, afresh = [start("a"), start("b")], [start("c"), start("d")]
    counts = []
    for k in range(30):
        for pair, scale in zip(zip(served, afresh), (1.0, 0.6)):
            counts.append((step(pair[0], k, scale), step(pair[1], k, scale, afresh=True)))
            assert pair[0]._y == pair[1]._y
    assert all(n_served == n_afresh - 1 for n_served, n_afresh in counts[2:])   # from the second step on
    served_counts = [n for n, _ in counts]   # two instances a step: from step k on, counts[2 k:]
    if torque_driven:
        assert set(served_counts[2:]) == {6}
    else:   # alpha_in jumps from 0 to 300 rad/s^2 at step 1, which restarts the method: steps 1-5 start it, the
        # Adams method takes over at step 6
        assert set(served_counts[2:12]) == {6} and set(served_counts[12:]) == {2}
    inst = served[0]
    state = inst._get_fmu_state()
    first = [(step(inst, k, 1.0), inst._y)[1] for k in range(30, 40)]
    inst._set_fmu_state(state)
    assert [(step(inst, k, 1.0), inst._y)[1] for k in range(30, 40)] == first
    fresh = start("e")
    fresh._set_fmu_state(cls._fmu_state_from_bytes(cls._fmu_state_to_bytes(state)))
    assert [(step(fresh, k, 1.0), fresh._y)[1] for k in range(30, 40)] == first


@pytest.mark.parametrize("rigid", [True, False])
def test_the_output_flange_torque_follows_the_load_set_after_a_read(open_fmu, rigid):
    """The host's order: omega_in, read, tau_load, read. tau_out = J_load dw4/dt + tau_load answers the load set
    after the first read: rigid, the output's acceleration is kinematic, so tau_out moves by the load's change and
    tau_in by rho = omega_out / omega_in times it; flexible without crosses' or intermediate inertia, tau_out is
    joint 2's torque on the output shaft, which the load does not move at that instant (nor tau_in)."""
    inst = open_fmu("DoubleCardanDriveline")
    inst.initialize(dict(rigid_intermediate_shaft=rigid, beta2=5 * DEG, J_load=0.05))
    for k in range(50):
        inst.set(omega_in=100.0 + 2.0 * k, tau_load=20.0)
        inst.get("omega_out")
        inst.slave.doStep(k * 1e-3, 1e-3)
    inst.set(omega_in=200.0)
    omega_in, omega_out, tau_in, tau_out = inst.get("omega_in", "omega_out", "tau_in", "tau_out")
    inst.set(tau_load=50.0)
    (tau_in_later,) = inst.get("tau_in")   # the outputs that do not move with the load, read alone first
    (tau_out_later,) = inst.get("tau_out")
    if rigid:
        assert tau_out_later - tau_out == pytest.approx(30.0, rel=1e-9)
        assert tau_in_later - tau_in == pytest.approx(30.0 * omega_out / omega_in, rel=1e-9)
    else:
        assert (tau_out_later, tau_in_later) == (pytest.approx(tau_out, rel=1e-12), tau_in)
    assert abs(tau_out - 20.0) > 1.0   # the output shaft accelerates with the kinematics' 2x


def test_the_rigid_drivelines_torques_under_an_accelerating_source_agree_with_the_reference(fmu_dir):
    """Brutti's rigid driveline run up by an ideal source at 400 rad/s^2 (the bundled scenario runs at constant
    speed, where no inertia term shows): tau_in = J_eq alpha1 + J_eq' w1^2 / 2 + rho tau_load and shaft_torque =
    (tau_in - J_in alpha1 - J_in' w1^2 / 2) / (dphi2/dphi1), the FMU's equations against the reference's
    independent vector kinematics, within 1e-4 of their ranges after the first steps (the FMU's acceleration is
    estimated from the speed's history and is 0 at the start)."""
    from ujfmu.master import cosimulate
    from ujfmu.references import generate
    from ujfmu.scenario import Scenario
    brutti = Scenario(Path(__file__).parents[3] / "scenarios" / "double_cardan_brutti_rigid.toml")
    ramp = brutti.with_parameters({"motor.profile": 1, "motor.accel": 400.0})
    ramp.stop_time = 0.3
    reference, _ = generate(ramp)
    names = ["driveline.tau_in", "driveline.shaft_torque"]
    run = cosimulate(ramp.master_components(fmu_dir), ramp.connections, ramp.stop_time, ramp.step_size, names,
                     coupling=ramp.coupling)
    late = run["time"] > 0.01
    for name in names:
        expected = np.interp(run["time"], reference["time"], reference[name])
        assert np.ptp(expected) > 5.0, name
        assert np.max(np.abs(run[name] - expected)[late]) < 1e-4 * np.ptp(expected), name
