"""TwinJeffcottRotor.fmu through fmpy: the aligned Jeffcott limit, the misalignment 2x, energy, errors."""

import math

import numpy as np
import pytest

from ujfmu.analysis import order_amplitudes
from ujfmu.models.twin_jeffcott_rotor import model as tj
from ujfmu.steady import halves_change

OUT = ("omega_out", "phi_out", "tau_in", "X1", "Y1", "X2", "Y2", "phi_in", "phi_disc1", "omega_disc1",
       "stored_energy", "dissipated_energy", "input_work")
DEG = math.pi / 180.0
RIG = tj.rig_parameters()


def well_damped(**changes):
    """The default rig with 10% lateral and 20% torsional damping, so that runs settle within a second."""
    params = {}
    for i in (1, 2):
        m = RIG[f"M{i}"] + RIG[f"m_u{i}"]
        c = 2.0 * 0.1 * math.sqrt(RIG[f"K{i}X"] * m)
        params.update({f"C{i}X": c, f"C{i}Y": c, f"C{i}T": 2.0 * 0.2 * math.sqrt(RIG[f"K{i}T"] * RIG[f"J_M{i}"])})
    params.update(changes)
    return params


def jeffcott(i, omega, params):
    """Steady unbalance response (amplitude, phase lag) of disc i as a plain Jeffcott rotor, M the disc's whole
    translating mass M_i + m_ui."""
    k, c, m = RIG[f"K{i}X"], params[f"C{i}X"], RIG[f"M{i}"] + RIG[f"m_u{i}"]
    amplitude = RIG[f"m_u{i}"] * RIG["e"] * omega ** 2 / math.hypot(k - m * omega ** 2, c * omega)
    return amplitude, math.atan2(c * omega, k - m * omega ** 2)


W1 = math.sqrt(RIG["K1X"] / (RIG["M1"] + RIG["m_u1"]))   # 153.8 rad/s
W2 = math.sqrt(RIG["K2X"] / (RIG["M2"] + RIG["m_u2"]))   # 117.0 rad/s


@pytest.mark.parametrize("tau_load", [0.0, 2.0])
@pytest.mark.parametrize("omega", [0.5 * W2, W2, W1, 1.6 * W1], ids=["below", "at-disc2", "at-disc1", "above"])
def test_aligned_discs_are_plain_jeffcott_rotors(open_fmu, drive, omega, tau_load):
    """beta = 0: each disc's steady 1x orbit has the Jeffcott amplitude and phase lag, the orbit is a circle (X and
    Y equal, 90 deg apart) and there is no 2x. Phases of the unbalance differ per disc. Exact (1e-5) without load;
    a transmitted torque T adds the joint's geometric stiffness ~ T (3/L)^2 (0.1% here; within 1%)."""
    params = well_damped(beta=0.0, phase_u1=0.4, phase_u2=-1.1)
    h, n_settle, n = 1e-3, 1500, 2000
    rel = 1e-5 if tau_load == 0.0 else 0.01
    r = drive(open_fmu("TwinJeffcottRotor"), lambda t: omega, tau_load, h, n, OUT, params)
    steady = r[n_settle:]
    assert halves_change(steady.phi_in, steady, ["X1", "Y1", "X2", "Y2"])[0] < 1e-5   # it has settled
    for i, angle in ((1, steady.phi_disc1), (2, steady.phi_out)):
        amplitude, lag = jeffcott(i, omega, params)
        phase_u = params[f"phase_u{i}"]
        amp_x, phase_x = order_amplitudes(angle, steady[f"X{i}"], [1, 2])
        amp_y, phase_y = order_amplitudes(angle, steady[f"Y{i}"], [1, 2])
        assert amp_x[0] == pytest.approx(amplitude, rel=rel) and amp_y[0] == pytest.approx(amplitude, rel=rel)
        # X = A cos(theta + phase_u - lag), Y = A sin(theta + phase_u - lag)
        assert math.remainder(phase_x[0] - (lag - phase_u), 2 * math.pi) == pytest.approx(0.0, abs=rel)
        assert math.remainder(phase_y[0] - (lag - phase_u + math.pi / 2), 2 * math.pi) == pytest.approx(0.0, abs=rel)
        assert amp_x[1] < 1e-4 * amplitude and amp_y[1] < 1e-4 * amplitude


def test_misalignment_puts_a_growing_2x_into_the_secondary_disc(open_fmu, drive):
    """At 70 rad/s with a 3 N.m load: the 2x amplitude of the secondary disc's orbit is absent at beta = 0 and grows
    with beta (the joint's secondary couple T tan(beta)-sized, at twice the running speed)."""
    omega, h, n_settle, n = 70.0, 1e-3, 1500, 2000
    twice = []
    for beta in (0.0, 5.0, 10.0, 15.0):
        r = drive(open_fmu("TwinJeffcottRotor", f"b{beta:g}"), lambda t: omega, 3.0, h, n, OUT,
                  well_damped(beta=beta * DEG))[n_settle:]
        assert halves_change(r.phi_in, r, ["X2", "Y2"])[0] < 1e-4   # it has settled
        amp_x = order_amplitudes(r.phi_in, r.X2, [1, 2])[0]
        amp_y = order_amplitudes(r.phi_in, r.Y2, [1, 2])[0]
        twice.append(math.hypot(amp_x[1], amp_y[1]))
        if beta == 0.0:
            unbalance = math.hypot(amp_x[0], amp_y[0])
    assert twice[0] < 1e-4 * unbalance
    assert twice[1] > 0.05 * unbalance
    assert twice[1] < twice[2] < twice[3]


def test_energy_balance_through_the_fmu_outputs(open_fmu, drive):
    """Run-up 0 -> 180 rad/s through both lateral criticals, beta = 10 deg, 2 N.m load:
    input_work - load work - dissipated_energy = stored_energy change (RK4 accuracy), and the FMU's input_work is
    what the host measures as the integral of tau_in * omega_in."""
    h, n, tau = 2e-4, 10000, 2.0
    r = drive(open_fmu("TwinJeffcottRotor"), lambda t: 90.0 * t, tau, h, n, OUT, dict(beta=10 * DEG))
    load_work = tau * (r.phi_out - r.phi_out[0])          # tau_load is held over each step: exact
    change = r.stored_energy - r.stored_energy[0]
    residual = r.input_work - load_work - r.dissipated_energy - change
    assert r.dissipated_energy[-1] > 1e-3 * r.input_work[-1]
    assert np.max(np.abs(residual)) < 1e-7 * r.input_work[-1]
    power = r.tau_in * r.omega_in
    host = np.concatenate([[0.0], np.cumsum(0.5 * h * np.diff(power) + h * power[:-1])])
    assert np.max(np.abs(host - r.input_work)) < 2e-3 * r.input_work[-1]


@pytest.mark.parametrize("speed", [lambda t: min(300.0 * t, 60.0), lambda t: 40.0 if t < 0.2 else 60.0],
                         ids=["ramp-end", "step"])
def test_energy_balance_holds_where_the_input_speed_kinks_or_jumps(open_fmu, drive, speed):
    """A ramp's end (alpha 300 -> 0 rad/s^2 at 0.2 s) and a speed step at 0.2 s, 1 ms steps: each step extrapolates
    omega_in linearly, so at the next communication point the host sets the flange to another speed (by about
    delta-alpha h at the kink, 20 rad/s at the step), a jump of the flange's kinetic energy J_gb omega delta-omega
    (0.018 J at the kink, 1 J at the step) that the driver supplies as an impulse: counted in input_work, the
    balance holds to the integrator's accuracy where, as here, the jump restarts the Adams history."""
    h, n, tau = 1e-3, 400, 2.0
    r = drive(open_fmu("TwinJeffcottRotor"), speed, tau, h, n, OUT, dict(beta=10 * DEG))
    load_work = tau * (r.phi_out - r.phi_out[0])
    residual = r.input_work - load_work - r.dissipated_energy - (r.stored_energy - r.stored_energy[0])
    assert np.max(np.abs(residual)) < 1e-6 * r.input_work[-1]


def test_before_the_first_step_the_discs_turn_with_the_input(open_fmu):
    inst = open_fmu("TwinJeffcottRotor")
    inst.initialize(dict(beta=20 * DEG, phi_in_start=0.3))
    inst.set(omega_in=50.0)
    omega_out, phi_out, omega_disc1 = inst.get("omega_out", "phi_out", "omega_disc1")
    psi, ratio = tj.joint(tj.Parameters(**{**RIG, "beta": 20 * DEG, "phase_u1": 0.0, "phase_u2": 0.0}),
                          0.3, 0.0, 0.0, 0.0, 0.0)[:2]
    assert (phi_out, omega_out, omega_disc1) == pytest.approx((psi, ratio * 50.0, 50.0), rel=1e-14)


@pytest.mark.parametrize("name", ["TwinJeffcottRotor", "TwinJeffcottRotorTorqueDriven"])
def test_a_step_past_the_linear_shafts_validity_is_refused_naming_it(open_fmu, name):
    """A 1 kg unbalance on disc 2 at 100 rad/s: as a plain Jeffcott rotor its steady orbit would be 35 mm, an end
    slope 3 X / L2 of 0.17 rad, past the 0.1 rad within which a linear shaft holds (Euler-Bernoulli: the slope's
    square against 1). The step that bends the shaft past it is refused, naming the slope, the disc and the limit,
    and the state before it, within the limit, is kept; the default rig at its disc-2 resonance stays 20x inside."""
    from fmpy.fmi1 import FMICallException
    heavy = dict(RIG, m_u2=1.0)
    amplitude = heavy["m_u2"] * RIG["e"] * 100.0 ** 2 / abs(RIG["K2X"] - (RIG["M2"] + 1.0) * 100.0 ** 2)
    assert 3.0 * amplitude / RIG["L2"] > 1.5 * tj.MAX_END_SLOPE
    assert 3.0 * jeffcott(2, W2, RIG)[0] / RIG["L2"] < tj.MAX_END_SLOPE / 20.0
    inst = open_fmu(name)
    torque_driven = name.endswith("TorqueDriven")
    inst.initialize(dict(m_u2=1.0, **({"omega_in_start": 100.0, "J_drive": 10.0} if torque_driven else {})))
    with pytest.raises(FMICallException):
        for k in range(1000):
            inst.set(**({"tau_in": 2.0} if torque_driven else {"omega_in": 100.0}), tau_load=2.0)
            inst.slave.doStep(k * 1e-3, 1e-3)
    assert 10 < k < 500
    assert any("the shaft of disc 2 bent to an end slope of" in m and "past the 0.1 rad" in m for m in inst._log)
    x2, y2 = inst.get("X2", "Y2")
    assert 0.9 * tj.MAX_END_SLOPE < 3.0 * math.hypot(x2, y2) / RIG["L2"] <= tj.MAX_END_SLOPE


def test_a_read_of_the_light_outputs_alone_is_never_stale(open_fmu):
    """A host reads only outputs without the joint's kinematics (the FMU computes only its LIGHT_OUTPUTS then), on
    some steps before it sets the inputs, on others after, and every output on every third step: each read equals
    a second instance's that took the same steps and read every output each time, the joint's outputs
    (secondary_shaft_torque, stored_energy) included; so does a read after restoring a state saved before a light
    read, once and again."""
    from ujfmu.build import fmu_class
    light = ["omega_out", "tau_in", "X2", "Y2", "phi_in", "input_work"]
    names = [v.name for v in fmu_class("TwinJeffcottRotor").VARIABLES if v.causality == "output"]
    first, second = (open_fmu("TwinJeffcottRotor", f"i{k}") for k in range(2))
    for inst in (first, second):
        inst.initialize(dict(beta=15 * DEG))
    h = 1e-3
    for k in range(40):
        inputs = dict(omega_in=40.0 + (30.0 * k * h if k < 25 else 2.0), tau_load=2.0 + 0.1 * (k % 3))
        if k % 2 or k == 26:   # at 26 the host sets the speed it held, which the step had extrapolated past
            assert first.get(*light) == [dict(zip(names, second.get(*names)))[s] for s in light]
        for inst in (first, second):
            inst.set(**inputs)
        expected = dict(zip(names, second.get(*names)))
        assert first.get(*light) == [expected[s] for s in light]
        if k % 3 == 2:
            assert first.get(*names) == [expected[s] for s in names]
        for inst in (first, second):
            inst.slave.doStep(k * h, h)
    saved = first.slave.getFMUState()
    read = first.get(*light)
    first.slave.setFMUState(saved)
    expected = dict(zip(names, second.get(*names)))
    assert first.get(*light) == read == [expected[s] for s in light]
    first.slave.setFMUState(saved)   # the same state again: its stale outputs come back with it
    assert first.get(*light) == read
    assert first.get(*names) == [expected[s] for s in names]
    first.slave.freeFMUState(saved)


def test_a_light_read_computes_the_light_outputs_once_and_nothing_else():
    """In process, what the FMU asks of the model: after a step and a new omega_in, reads of only light outputs
    compute light_outputs once (never the full outputs, with the joint), reads of inputs or parameters alone
    nothing; a new tau_load, one of the inputs they are computed at, once more; a read that names a joint output
    computes the outputs once; the next step or omega_in makes the light outputs stale again."""
    from ujfmu.models.twin_jeffcott_rotor.fmu import TwinJeffcottRotor
    calls = []

    class Counting(TwinJeffcottRotor):
        @staticmethod
        def _outputs(p, t, y, u):
            calls.append("outputs")
            return tj.outputs(p, t, y, u)

        @staticmethod
        def _light_outputs(p, t, y, u):
            calls.append("light")
            return tj.light_outputs(p, t, y, u)

    inst = Counting(instance_name="counting")
    vr = {name: ref for ref, name in inst._real_names.items()}
    light = [vr[n] for n in ("omega_out", "tau_in", "X2", "phi_in")]
    inst.exit_initialization_mode()
    inst.set_real([vr["omega_in"]], [40.0])
    inst.do_step(0.0, 1e-3)
    for k, omega in enumerate((41.0, 42.5)):
        calls.clear()
        inst.set_real([vr["omega_in"]], [omega])
        for _ in range(3):
            inst.get_real(light)
        inst.get_real([vr["omega_in"]])
        inst.get_real([vr["beta"]])
        assert calls == ["light"]
        inst.set_real([vr["tau_load"]], [2.0 + k])
        inst.get_real(light)
        inst.get_real(light)
        assert calls == ["light", "light"]
        inst.get_real(light + [vr["secondary_shaft_torque"]])
        assert calls == ["light", "light", "outputs"]
        inst.do_step((k + 1) * 1e-3, 1e-3)
    calls.clear()
    inst.get_real(light)
    assert calls == ["light"]
