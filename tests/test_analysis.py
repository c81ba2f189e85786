"""Signal analysis helpers: order amplitudes and spectra recover known signals."""

import math
from pathlib import Path

import numpy as np
import pytest

from ujfmu.analysis import amplitude_spectrum, decay_rates, order_amplitudes, order_fit

SCENARIOS = Path(__file__).parents[1] / "scenarios"


def test_order_amplitudes_recover_harmonics_of_a_varying_speed():
    """Along the angle, not time: a ramp in speed does not smear the orders."""
    t = np.linspace(0.0, 2.0, 4001)
    angle = 30.0 * t + 10.0 * t ** 2
    signal = 0.3 + 2.0 * np.cos(angle - 0.4) + 0.5 * np.cos(2 * angle + 1.0) + 0.01 * np.sin(4 * angle)
    amp, phase = order_amplitudes(angle, signal, [1, 2, 3, 4])
    np.testing.assert_allclose(amp, [2.0, 0.5, 0.0, 0.01], atol=1e-12)
    assert phase[0] == pytest.approx(0.4) and phase[1] == pytest.approx(-1.0)


@pytest.mark.parametrize("frequency", [12.5, 12.525, 12.5375])
def test_amplitude_spectrum_peak_is_the_sinusoid_amplitude(frequency):
    """On a bin, a quarter and half-way between bins (0.05 Hz apart over 20 s): the peak reads the amplitude within
    0.2% (a Hann window read 15% low half-way)."""
    t = np.arange(20000) * 1e-3
    freq, amp = amplitude_spectrum(t, 5.0 + 0.7 * np.sin(2 * math.pi * frequency * t))
    assert freq[np.argmax(amp)] == pytest.approx(frequency, abs=0.05)
    assert amp.max() == pytest.approx(0.7, rel=2e-3)


def test_decay_rates_are_those_of_damped_oscillators():
    """Two uncoupled oscillators m x'' + c x' + k x = 0: each mode decays at c / (2 m) (underdamped)."""
    def rhs(y):
        x1, v1, x2, v2 = y
        return [v1, -(400.0 * x1 + 0.8 * v1) / 2.0, v2, -(9.0 * x2 + 0.3 * v2) / 0.5]
    np.testing.assert_allclose(decay_rates(rhs, np.zeros(4)), [0.2, 0.2, 0.3, 0.3], rtol=1e-7)


def test_order_fit_mean_does_not_depend_on_where_a_window_ends():
    """The fitted mean of a periodic signal over a window that is not whole revolutions is exact, where the
    sample mean is biased by the part revolution."""
    angle = np.linspace(0.0, 2 * 2 * math.pi + 1.0, 700)
    signal = 0.3 + 2.0 * np.cos(2 * angle) + 0.1 * np.cos(5 * angle)
    c0, amplitudes, _ = order_fit(angle, signal, range(1, 9))
    assert c0 == pytest.approx(0.3, abs=1e-12) and amplitudes[1] == pytest.approx(2.0, abs=1e-12)
    assert abs(signal.mean() - 0.3) > 1e-2


def test_natural_frequencies_of_a_damped_oscillator_and_a_rigid_body():
    """x'' + 2 zeta w x' + w^2 x = 0 (w = 50 rad/s, zeta = 0.1) beside a free body (theta'' = 0): one natural
    frequency, the undamped w (|lambda|, not the damped w sqrt(1 - zeta^2)); the rigid body has none."""
    from ujfmu.analysis import natural_frequencies
    w, zeta = 50.0, 0.1

    def rhs(y):
        x, v, theta, omega = y
        return [v, -2 * zeta * w * v - w * w * x, omega, 0.0]

    assert natural_frequencies(rhs, [0.0, 0.0, 0.0, 0.0]) == pytest.approx([w], rel=1e-6)


def test_a_modes_share_in_chosen_states_is_its_participation_whatever_their_units():
    """Two oscillators, x'' = -w1^2 x and z'' = -w2^2 z (w1 = 30, w2 = 70 rad/s): uncoupled, the first mode lies
    wholly in (x, x'), the second wholly outside, and a unit change of x (x in mm: the states scaled by 1000) leaves
    the shares alone. Two equal oscillators joined by a spring: each mode lies half in each."""
    from ujfmu.analysis import natural_modes
    w1, w2 = 30.0, 70.0

    def rhs(y, scale=1.0, coupling=0.0, w2=w2):
        x, v, z, u = y[0] / scale, y[1] / scale, y[2], y[3]
        return [scale * v, scale * (-w1 * w1 * x - coupling * (x - z)), u, -w2 * w2 * z - coupling * (z - x)]

    for scale in (1.0, 1e3):
        w, share = natural_modes(lambda y: rhs(y, scale), [0.0] * 4, (0, 1))
        assert w == pytest.approx([w1, w2], rel=1e-6) and share == pytest.approx([1.0, 0.0], abs=1e-6)
    w, share = natural_modes(lambda y: rhs(y, coupling=400.0, w2=w1), [0.0] * 4, (0, 1))
    assert w == pytest.approx([w1, math.sqrt(w1 * w1 + 800.0)], rel=1e-6)
    assert share == pytest.approx([0.5, 0.5], abs=1e-6)
    _, share = natural_modes(lambda y: rhs(y, coupling=400.0), [0.0] * 4, (0, 1))
    assert 0.5 < share[0] < 1.0 and 0.0 < share[1] < 0.5   # detuned: each mode mostly in its own oscillator

    def damped(y):   # the same pair, each damped at zeta = 0.6
        return [a + b for a, b in zip(rhs(y, coupling=400.0), [0.0, -2 * 0.6 * w1 * y[1], 0.0, -2 * 0.6 * w2 * y[3]])]
    w, share = natural_modes(damped, [0.0] * 4, (0, 1))
    _, rest = natural_modes(damped, [0.0] * 4, (2, 3))
    assert len(w) == 2 and np.all((share > 0.5) == [True, False]) and share + rest == pytest.approx([1.0, 1.0])


def test_a_defective_linearisation_still_has_its_frequencies():
    """A triple eigenvalue 0 with one eigenvector (a Jordan block: position, speed and acceleration of a free body)
    beside a 10 rad/s oscillator: no eigenvector basis to invert, yet the oscillator's frequency and its whole
    participation are found."""
    from ujfmu.analysis import natural_frequencies, natural_modes

    def rhs(y):
        return [y[1], y[2], 0.0, y[4], -100.0 * y[3]]
    assert natural_frequencies(rhs, [0.0] * 5) == pytest.approx([10.0], rel=1e-6)
    w, share = natural_modes(rhs, [0.0] * 5, (3, 4))
    assert w == pytest.approx([10.0], rel=1e-6) and share == pytest.approx([1.0], abs=1e-6)


def test_a_coupled_rigid_body_motion_is_not_a_mode():
    """The ring coupling's two shafts turning together (a double eigenvalue 0 of its linearisation, which the
    finite differences split into a pair near 0) is not listed as a natural frequency, nor are its order crossings
    near rest; its torsional mode (170.46 rad/s, the two-mass closed form of a fresh-eyes analyst) is."""
    from ujfmu.analysis import scenario_modes
    from ujfmu.scenario import Scenario
    modes = scenario_modes(Scenario(Path(__file__).parent.parent / "scenarios" / "ring_coupling_startup.toml"))
    assert [round(m.omega, 2) for m in modes] == [170.46]


def test_order_fit_refuses_samples_at_too_few_angles():
    """Four samples a revolution, the step a whole quarter turn: cos(2 angle) and the mean take the same values
    at every sample, so orders 1-4 cannot be told apart: refused, not one of many solutions. The same record at
    a step that is no whole fraction of a revolution fits them."""
    angle = 0.5 * math.pi * np.arange(400)
    with pytest.raises(ValueError, match="too few distinct shaft angles"):
        order_fit(angle, np.cos(2 * angle), range(1, 5))
    angle = 0.37 * np.arange(400)
    _, amplitudes, _ = order_fit(angle, np.cos(2 * angle), range(1, 5))
    assert amplitudes == pytest.approx([0.0, 1.0, 0.0, 0.0], abs=1e-9)


def test_a_window_of_a_runaway_speed_is_not_blamed_on_the_step():
    """A diverging run's window: the speed far above the set point, ten samples over four revolutions, too few for
    the orders fitted. It had been blamed on 'a step that is a whole fraction of a revolution' (a fresh-eyes trial's
    5 ms step was not); it names the samples a revolution, and divergence as the likely cause."""
    angle = 2.5 * np.arange(10)   # 2.5 rad a sample: 2.5 samples a revolution
    with pytest.raises(ValueError, match=r"10 samples span 3.58 revolutions \(2.79 a revolution\).*the run diverged"):
        order_fit(angle, np.cos(angle), range(1, 9))


def test_natural_frequencies_of_a_rig_take_the_fmus_other_defaults():
    """The twin rotor's rig_parameters() leave out the FMU-only parameters (unbalance phases, start angle), which
    had raised a bare KeyError: they take the FMU's declared start values, and the lateral modes are the discs'
    Jeffcott frequencies sqrt(K / (M + m_u)), each in X and Y."""
    from ujfmu.analysis import model_natural_frequency_range
    from ujfmu.models.twin_jeffcott_rotor import model as tj
    rig = tj.rig_parameters()
    mean, _, _ = model_natural_frequency_range(tj, rig)
    for i in (1, 2):
        jeffcott = math.sqrt(rig[f"K{i}X"] / (rig[f"M{i}"] + rig[f"m_u{i}"]))
        assert sum(abs(w / jeffcott - 1.0) < 2e-3 for w in mean) == 2, (i, jeffcott, mean)


def test_scenario_modes_are_the_jeffcott_frequencies_and_their_order_crossings():
    """The twin rotor scenario's lateral modes: each disc's sqrt(K / (M + m_u)), X and Y merged into one line of 2
    modes (a round shaft), with damping ratio C / (2 sqrt(K (M + m_u))) (at 0.02, and at 0.5 with C raised);
    drives and loads have none of their own. A crossing of the k-th order is at omega_n / k, and the drive's set
    speed is the motor's omega_set."""
    from ujfmu.analysis import drive_speeds, scenario_modes
    from ujfmu.models.twin_jeffcott_rotor import model as tj
    from ujfmu.scenario import Scenario
    scenario = Scenario(Path(__file__).parent.parent / "scenarios" / "twin_jeffcott_steady.toml")
    rig = tj.rig_parameters()
    modes = scenario_modes(scenario)
    assert {m.component for m in modes} == {"rotor"} and all(m.orders == (1, 2) for m in modes)
    for i in (1, 2):
        jeffcott = math.sqrt(rig[f"K{i}X"] / (rig[f"M{i}"] + rig[f"m_u{i}"]))
        match = [m for m in modes if abs(m.omega / jeffcott - 1.0) < 2e-3]
        assert len(match) == 1 and match[0].count == 2 and match[0].kind == "lateral", (i, jeffcott, modes)
        # its damping ratio, a viscous Jeffcott disc's C / (2 sqrt(K m))
        zeta = rig[f"C{i}X"] / (2.0 * math.sqrt(rig[f"K{i}X"] * (rig[f"M{i}"] + rig[f"m_u{i}"])))
        assert match[0].damping == pytest.approx(zeta, rel=2e-3), (i, zeta, match[0])
        assert match[0].critical_speed(1) == pytest.approx(jeffcott, rel=2e-3)
        assert match[0].critical_speed(2) == pytest.approx(jeffcott / 2, rel=2e-3)
    twist = [m for m in modes if m.count == 1]   # the discs' angles against each other and the flange
    assert len(twist) == 2 and all(m.kind == "torsional" for m in twist), modes
    # damped to zeta = 0.5, disc 1's mode keeps omega_n = |lambda| = sqrt(K / m), its damped frequency 0.87 of it
    c = math.sqrt(rig["K1X"] * (rig["M1"] + rig["m_u1"]))
    damped = scenario_modes(scenario, {"rotor.C1X": c, "rotor.C1Y": c})
    jeffcott = math.sqrt(rig["K1X"] / (rig["M1"] + rig["m_u1"]))
    (disc1,) = [m for m in damped if abs(m.omega / jeffcott - 1.0) < 2e-3]
    assert disc1.damping == pytest.approx(0.5, rel=2e-3), disc1
    stiffer = scenario_modes(scenario, {"rotor.K2X": 4.0 * rig["K2X"], "rotor.K2Y": 4.0 * rig["K2Y"]})
    disc2 = math.sqrt(rig["K2X"] / (rig["M2"] + rig["m_u2"]))
    assert any(abs(m.omega / (2.0 * disc2) - 1.0) < 2e-3 for m in stiffer)   # sqrt(4 K / m)
    assert drive_speeds(scenario) == {"motor.omega_set": 100.0}


def test_modes_crossing_over_the_input_angle_keep_their_shapes():
    """Omar's support stiffened to k_phi = 83634 N/m puts the lateral mode at sqrt(83634 / 4.09) = 143.0 rad/s,
    inside the torsional mode's 138.3-148.2 rad/s span over the input angle: the two cross. Followed by their shapes
    from angle to angle, they stay one pure lateral mode at 143.0 and the torsional one with its span (paired by
    rank, they had been blended into two "lateral-torsional" modes of 62% and 38%, a reviewer's find)."""
    from ujfmu.analysis import scenario_modes
    from ujfmu.scenario import Scenario
    modes = scenario_modes(Scenario(SCENARIOS / "double_cardan_omar_torsional.toml"), {"driveline.k_phi": 83634.0})
    lateral = [m for m in modes if m.kind == "lateral" and abs(m.omega - math.sqrt(83634 / 4.09)) < 0.1]
    torsional = [m for m in modes if m.kind == "torsional" and m.low < 139.0 and m.high > 148.0]
    assert len(lateral) == 1 and lateral[0].high - lateral[0].low < 0.01 and len(torsional) == 1, modes
    assert torsional[0].omega == pytest.approx(143.14, abs=0.01)   # as with the default support


def test_the_torque_driven_twin_rotors_jeffcott_modes_are_lateral():
    """The torque-driven twin rotor (its flange free with the controller's side left out): each disc's Jeffcott
    frequency sqrt(K / (M + m_u)) is a lateral mode, X and Y merged, as in the speed-driven rotor."""
    from ujfmu.analysis import scenario_modes
    from ujfmu.models.twin_jeffcott_rotor import model as tj
    from ujfmu.scenario import Scenario
    rig = tj.rig_parameters()
    modes = scenario_modes(Scenario(SCENARIOS / "twin_jeffcott_torque_driven.toml"))
    for i in (1, 2):
        jeffcott = math.sqrt(rig[f"K{i}X"] / (rig[f"M{i}"] + rig[f"m_u{i}"]))
        (match,) = [m for m in modes if abs(m.omega / jeffcott - 1.0) < 2e-3]
        assert match.kind == "lateral" and match.count == 2, modes


def test_omars_modes_are_named_by_their_shapes():
    """Omar's double Cardan (section 2.3): the lateral mode sqrt(k_phi / m_s) = sqrt(26331 / 4.09) = 80.2 rad/s, in
    the dynamic misalignment, and the torsional sqrt(k_theta / J_load) = sqrt(92.2 / 0.0045) = 143.1 rad/s, in the
    output shaft's twist, are named so (`ujfmu modes` had left a reader to tell them apart)."""
    from ujfmu.analysis import scenario_modes
    from ujfmu.scenario import Scenario
    lateral, torsional = scenario_modes(Scenario(SCENARIOS / "double_cardan_omar_torsional.toml"))
    assert lateral.omega == pytest.approx(math.sqrt(26331 / 4.09), rel=1e-3) and lateral.kind == "lateral"
    assert torsional.omega == pytest.approx(math.sqrt(92.2 / 0.0045), rel=2e-3) and torsional.kind == "torsional"


@pytest.mark.parametrize("ideal", [True, False])
def test_a_shafts_torsional_mode_is_free_at_a_pi_motors_rotor_and_held_at_an_ideal_source(ideal):
    """A straight (0 deg) double Cardan, k_theta 1.5e4 N.m/rad to a 0.2 kg.m2 output, driven by a motor with a
    0.3 kg.m2 rotor: held by an ideal speed source, its torsional mode is sqrt(k / J_load) = 273.9 rad/s; driven by
    a PI motor it is the two-mass sqrt(k (1 / J_load + 1 / J_rotor)) = 353.6 rad/s (the speed loop left out), which
    a first-day trial's sweep found where the held figure had put the crossing 22% low."""
    from ujfmu.analysis import scenario_modes
    from ujfmu.scenario import Scenario
    scenario = Scenario(Path(__file__).parent.parent / "scenarios" / "double_cardan_omar_startup.toml")
    scenario = scenario.with_parameters({"driveline.beta1": 0.0, "driveline.beta2": 0.0, "driveline.k_theta": 1.5e4,
                                         "driveline.J_load": 0.2, "motor.J_rotor": 0.3,
                                         "motor.ideal_speed_source": ideal})
    k, j_load, rotor = 1.5e4, 0.2, 0.3
    expected = math.sqrt(k / j_load) if ideal else math.sqrt(k * (1.0 / j_load + 1.0 / rotor))
    assert any(abs(m.omega / expected - 1.0) < 1e-6 for m in scenario_modes(scenario)), scenario_modes(scenario)


def test_a_pi_driven_components_modes_come_with_the_held_input_bound():
    """Where a PI Motor drives the driveline, scenario_modes has its input free (the loop left out) and
    held_input_modes the other bound, the input held as a stiff loop holds it: Omar's start-up driveline's twist
    mode is 154.7 rad/s free and 143.1 held (the paper's 684 rpm critical speed is the held one: 2x at 71.57 rad/s);
    with an ideal speed source the input is held already and there is no second bound."""
    from ujfmu.analysis import held_input_modes, scenario_modes
    from ujfmu.scenario import Scenario
    startup = Scenario(SCENARIOS / "double_cardan_omar_startup.toml")
    free = [m.omega for m in scenario_modes(startup)]
    held = [m.omega for m in held_input_modes(startup)]
    assert max(free) == pytest.approx(154.71, rel=1e-4) and max(held) == pytest.approx(143.14, rel=1e-4)
    assert held_input_modes(startup)[-1].critical_speed(2) * 30 / math.pi == pytest.approx(683.4, abs=0.1)
    assert held_input_modes(Scenario(SCENARIOS / "double_cardan_omar_torsional.toml")) == []
    ring = Scenario(SCENARIOS / "ring_coupling_torque_driven.toml")   # a MotorController drives its tau_in
    c_s, i2 = ring.parameters_with_defaults("coupling")["c_s"], ring.parameters_with_defaults("coupling")["I2"]
    (held,) = held_input_modes(ring)
    assert held.omega == pytest.approx(math.sqrt(c_s / i2), rel=1e-3) and held.omega < scenario_modes(ring)[0].omega


def test_modes_list_the_crossings_of_a_loads_periodic_torque(tmp_path, capsys):
    """A Load with a 3x periodic torque on Omar's output shaft (phi fed from driveline.phi_out): `ujfmu modes` lists
    its crossings with each mode at omega_n / 3 beside the joints' 1x and 2x, and counts them among those from rest;
    without the connection or with T_h = 0 there are none."""
    from ujfmu.analysis import load_orders, scenario_modes
    from ujfmu.cli import main
    from ujfmu.scenario import Scenario
    text = (SCENARIOS / "double_cardan_omar_torsional.toml").read_text()
    text = text.replace("parameters = { T0 = 5.0", "parameters = { T_h = 1.0, order_h = 3.0, T0 = 5.0").replace(
        '[[connections]]\nfrom = "load.tau"',
        '[[connections]]\nfrom = "driveline.phi_out"\nto = "load.phi"\n\n[[connections]]\nfrom = "load.tau"')
    path = tmp_path / "blade.toml"
    path.write_text(text)
    scenario = Scenario(path)
    assert load_orders(scenario) == {"driveline": [("load", 3.0)]}
    assert main(["modes", str(path)]) == 0
    out = capsys.readouterr().out
    for mode in scenario_modes(scenario):
        assert f"3x (load's periodic torque) at {mode.omega / 3:.6g} rad/s" in out
    assert "below it lie 4 crossings" in out
    assert load_orders(Scenario(SCENARIOS / "double_cardan_omar_torsional.toml")) == {}


@pytest.mark.parametrize("scenario, point, orders", [
    ("double_cardan_omar_torsional.toml", {}, (2,)),
    ("double_cardan_omar_torsional.toml", {"driveline.beta1": 0.0, "driveline.beta2": 0.0}, ()),
    ("cardan_startup.toml", {}, (2,)),
    ("ring_coupling_startup.toml", {}, (2,)),
    ("twin_jeffcott_steady.toml", {"rotor.m_u1": 0.0, "rotor.m_u2": 0.0}, (2,)),
    ("twin_jeffcott_steady.toml", {"rotor.beta": 0.0}, (1,)),
])
def test_a_modes_orders_are_those_the_machine_excites(scenario, point, orders):
    """A Cardan joint's kinematics repeat every half turn (theta1 -> theta1 + pi turns the cross end for end), and
    a ring coupling's M_p goes with cos(phi1 + phi2): their modes meet the 2x, never a 1x; straight joints excite
    none; a twin rotor's discs add the unbalance's 1x, its bent joint the 2x. The Cardan joint itself has no mode of
    its own: its orders are checked on the model."""
    from ujfmu.analysis import carried_orders, scenario_modes
    from ujfmu.build import fmu_class
    from ujfmu.scenario import Scenario
    s = Scenario(Path(__file__).parent.parent / "scenarios" / scenario)
    modes = scenario_modes(s, point)
    if scenario.startswith("cardan"):
        assert modes == []
        physics = fmu_class("CardanJoint").PHYSICS
        assert carried_orders(physics, s.model_parameters("joint")) == orders
        return
    assert modes and all(m.orders == orders for m in modes), modes


def test_the_cardan_joints_speed_ratio_has_no_odd_order():
    """The oracle behind a joint's 2x-only orders: over a turn its speed ratio (bent, with bend-plane and error
    angles) has no 1x or 3x above round-off, and a 2x of its swing's size."""
    from ujfmu.models.cardan_joint import model as cj
    frame = cj.joint_frame(0.3, 0.1, 0.005, 0.005)
    theta = np.linspace(0.0, 2.0 * math.pi, 256, endpoint=False)
    spectrum = np.abs(np.fft.rfft([cj.velocity_ratio(frame, t) for t in theta])) / 128
    assert spectrum[1] < 1e-12 and spectrum[3] < 1e-12 and spectrum[2] > 0.04


def test_the_spectrums_bins_are_multiples_of_the_records_frequency_resolution():
    """64 samples 1 ms apart: the bins are k / (64 ms), 15.625 Hz apart, and a sinusoid on bin 5 peaks at exactly
    78.125 Hz (a record's span taken as n steps instead of n - 1 had moved every peak 1/63 high)."""
    t = np.arange(64) * 1e-3
    freq, amp = amplitude_spectrum(t, np.cos(2.0 * math.pi * 78.125 * t))
    assert freq[1] == pytest.approx(15.625, rel=1e-12) and freq[int(np.argmax(amp))] == pytest.approx(78.125, rel=1e-12)


@pytest.mark.parametrize("profile, speeds", [(1, {"motor.omega_set": 150.0}),
                                             (2, {"motor.omega_set": 150.0, "motor.omega_initial": 30.0}),
                                             (3, {"motor.omega_set": 150.0, "motor.omega_initial": 30.0})])
def test_drive_speeds_are_the_set_points_a_profile_holds(profile, speeds):
    """A ramp settles at omega_set; a step, or a ramp between two speeds, holds omega_initial first, then omega_set:
    both are speeds the machine runs at (``ujfmu modes`` looks for crossings at each)."""
    from ujfmu.analysis import drive_speeds
    from ujfmu.scenario import Scenario
    startup = Scenario(Path(__file__).parent.parent / "scenarios" / "cardan_startup.toml")
    assert drive_speeds(startup.with_values({"motor.profile": profile, "motor.omega_initial": 30.0})) == speeds


def test_a_periodic_signals_mean_is_its_fits_not_the_samples():
    """An orbit's coordinate at a critical speed: a 0.0014 mm offset under a 0.88 mm 1x, read over 18.6
    revolutions (no whole number of them, as a fresh-eyes trial's window): the samples' mean is ten times the offset;
    the constant of the fit with the orders is the offset, and the spectrum about it has no bump at order 0. Less
    than a revolution falls back to the plain mean."""
    from ujfmu.analysis import periodic_mean
    omega = 117.0
    t = np.arange(0.0, 18.6 * 2.0 * math.pi / omega, 1e-3)
    x = 0.0014 + 0.88 * np.cos(omega * t + 0.3) + 0.003 * np.cos(2.0 * omega * t)
    speed = np.full_like(t, omega)
    assert abs(np.mean(x) - 0.0014) > 5 * 0.0014
    assert periodic_mean(t, x, speed) == pytest.approx(0.0014, rel=1e-6)
    freq, amp = amplitude_spectrum(t, x, periodic_mean(t, x, speed))
    assert amp[0] < 1e-4 * 0.88 < amplitude_spectrum(t, x)[1][0]
    short = t < 0.5 * 2.0 * math.pi / omega
    assert periodic_mean(t[short], x[short], speed[short]) == pytest.approx(np.mean(x[short]))


def test_the_fits_solve_their_least_squares_with_blas_on_one_thread(monkeypatch):
    """order_fit and the steady window's running angle run numpy's least squares with BLAS on one thread: more
    threads spin after each call, and two sweep processes on two cores had each taken twice as long as one."""
    from threadpoolctl import threadpool_info, threadpool_limits

    from ujfmu.analysis import one_blas_thread
    from ujfmu.steady import running_angle

    def blas_threads():
        return max(lib["num_threads"] for lib in threadpool_info() if lib["user_api"] == "blas")

    if not any(lib["user_api"] == "blas" for lib in threadpool_info()):
        pytest.skip("no BLAS threadpoolctl can set (numpy on Accelerate)")
    seen = []
    lstsq = np.linalg.lstsq

    def recording(*args, **kwargs):
        seen.append(blas_threads())
        return lstsq(*args, **kwargs)

    monkeypatch.setattr(np.linalg, "lstsq", recording)
    t = np.linspace(0.0, 1.0, 2001)
    with threadpool_limits(limits=2, user_api="blas"):
        allowed = blas_threads()
        if allowed < 2:
            pytest.skip("BLAS runs on one thread here already (one core): nothing to limit")
        order_fit(10.0 * t, np.cos(10.0 * t), (1, 2))
        running_angle(t, 10.0 + 0.1 * np.cos(20.0 * t))
        after = blas_threads()
        # two threads' fits overlapping: the limit holds until the last one leaves, then the caller's is back
        first, second = one_blas_thread(), one_blas_thread()
        first.__enter__()
        second.__enter__()
        first.__exit__(None, None, None)
        overlapped = blas_threads()
        second.__exit__(None, None, None)
        restored = blas_threads()
    assert len(seen) >= 3 and set(seen) == {1}
    assert after == allowed   # the caller's setting is back
    assert (overlapped, restored) == (1, allowed)


def test_a_drive_is_matched_only_against_the_modes_of_what_it_turns(tmp_path, capsys):
    """Two speed sources each driving its own twin rotor, the second's shafts 9x stiffer (its modes 3x faster): the
    second source set at the first rotor's disc 2 Jeffcott speed sqrt(K2X / (M2 + m_u2)) = 117.02 rad/s is 29% from
    its own rotor's nearest crossing (the 2x with its 330 rad/s torsional mode) and gets no note; the first rotor's
    crossings are not listed under it in `ujfmu modes` either."""
    from ujfmu.analysis import driven_components, near_crossing_notes, nearest_crossings
    from ujfmu.cli import main
    from ujfmu.models.twin_jeffcott_rotor import model as tj
    from ujfmu.scenario import Scenario
    rig = tj.rig_parameters()
    jeffcott = math.sqrt(rig["K2X"] / (rig["M2"] + rig["m_u2"]))
    stiff = ", ".join(f"{k} = {9 * rig[k]!r}" for k in ("K1X", "K1Y", "K2X", "K2Y", "K1T", "K2T"))
    text = (SCENARIOS / "twin_jeffcott_aligned_vs_misaligned.toml").read_text()
    text = text.replace('from = "motor.omega"\nto = "misaligned.omega_in"',
                        'from = "motor2.omega"\nto = "misaligned.omega_in"')
    text = text.replace("parameters = { beta = 0.17453292519943295 }", f"parameters = {{ beta = 0.17453292519943295, "
                        f"{stiff} }}")
    text = text.replace("[components.aligned]", "[components.motor2]\nfmu = \"Motor\"\nparameters = { "
                        f"ideal_speed_source = true, profile = 0, omega_set = {jeffcott!r} }}\n"
                        "inputs = { tau_load = 0.0 }\n\n[components.aligned]")
    path = tmp_path / "two_drives.toml"
    path.write_text(text)
    scenario = Scenario(path)
    assert driven_components(scenario, "motor") == {"aligned", "load_aligned"}
    assert driven_components(scenario, "motor2") == {"misaligned", "load_misaligned"}
    nearest = nearest_crossings(scenario)
    assert nearest["motor.omega_set"].mode.component == "aligned"
    second = nearest["motor2.omega_set"]
    assert second.mode.component == "misaligned" and second.order == 2
    assert second.margin == pytest.approx(jeffcott / (second.mode.omega / 2) - 1) and abs(second.margin) > 0.25
    assert near_crossing_notes(scenario) == []
    assert main(["modes", str(path)]) == 0
    out = capsys.readouterr().out
    lines = out.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("  motor2.omega_set"))
    assert "with misaligned's" in lines[start] and lines[start + 1].startswith("  A crossing"), out   # none below
