"""RingCoupling.fmu through fmpy against Turla and Iljin's closed forms: pendulum, Eq. (20), validity limit."""

import math
from pathlib import Path

import numpy as np
import pytest
from fmpy.fmi1 import FMICallException
from scipy.special import ellipk

from ujfmu.analysis import order_amplitudes
from ujfmu.models.ring_coupling import model as rc
from ujfmu.steady import halves_change

SCENARIOS = Path(__file__).parents[3] / "scenarios"

OUT = ("omega_out", "phi_out", "phi_in", "tau_in", "x_e", "M_p", "transmitted_torque", "stored_energy")
E, D, R, ECC, I2 = 2.1e11, 0.003, 0.1, 0.003, 0.05          # the Fig. 3 set
A_E = rc.pendulum_constant(E, D, R, ECC, I2)
PENDULUM = dict(c_s=0.0, c_d=0.0)


def first_integral(r):
    """Eq. (13): y'^2/2 - A_e cos y with y = pi/2 - (phi1 + phi2)."""
    y = math.pi / 2 - (r.phi_in + r.phi_out)
    dy = -(r.omega_in + r.omega_out)
    return 0.5 * dy ** 2 - A_E * np.cos(y)


@pytest.mark.parametrize("omega_in, y0, dy0", [(0.0, 1.0, 0.0), (0.0, -0.3, 4.0), (37.0, 2.5, 1.0),
                                               (100.0, 0.0, -200.0)],
                         ids=["oscillating", "oscillating-kicked", "oscillating-at-speed", "rotating-fig3"])
def test_pendulum_case_conserves_the_first_integral_and_has_the_elliptic_period(open_fmu, drive, omega_in, y0, dy0):
    """c_s = c_d = tau_load = 0 is Eq. (9); y obeys y'' + A_e sin y = 0 (Eq. 12) whatever the input speed."""
    params = dict(PENDULUM, phi_out_start=math.pi / 2 - y0, start_at_input_speed=False,
                  omega_out_start=-dy0 - omega_in)
    h, n = 1e-3, 12000
    r = drive(open_fmu("RingCoupling"), lambda t: omega_in, 0.0, h, n, OUT, params)
    # Eq. (5): M_p = 157 (EI/R^3) e^2 cos(phi1 + phi2) = A_e I2 cos(phi1 + phi2); the driver holds its reaction
    m_p = A_E * I2 * np.cos(r.phi_in + r.phi_out)
    np.testing.assert_allclose(r.M_p, m_p, rtol=1e-9, atol=1e-12 * A_E * I2)
    np.testing.assert_allclose(r.transmitted_torque, m_p, rtol=1e-9, atol=1e-12 * A_E * I2)
    np.testing.assert_allclose(r.tau_in, -m_p, rtol=1e-9, atol=1e-12 * A_E * I2)
    energy = first_integral(r)
    scale = max(abs(energy[0]), A_E)
    assert np.max(np.abs(energy - energy[0])) < 1e-6 * scale
    m = math.sin(y0 / 2) ** 2 + dy0 ** 2 / (4 * A_E)              # k1^2, Eq. (15)
    if m < 1.0:
        y = math.pi / 2 - (r.phi_in + r.phi_out)
        up = np.nonzero((y[:-1] < 0) & (y[1:] >= 0))[0]
        crossings = r.time[up] - y[up] * h / (y[up + 1] - y[up])
        period = (crossings[-1] - crossings[0]) / (len(crossings) - 1)
        assert len(crossings) >= 5
        assert period == pytest.approx(4 * ellipk(m) / math.sqrt(A_E), rel=1e-4)


def small_parameter_run(open_fmu, drive, omega, params, tau_load=0.0, n=1500, settle=500):
    r = drive(open_fmu("RingCoupling", f"w{omega:g}"), lambda t: omega, tau_load, 1e-3, n, OUT, params)
    return r[settle:]


def test_fig3_double_frequency_amplitude_is_eq20_and_falls_as_one_over_omega_squared(open_fmu, drive):
    """Fig. 3 set, pendulum case: the 2x amplitude of x_e is 39.25 e^2 EI / (omega^2 I2 R^3) within 2% at
    100 rad/s (5.90e-4 rad) and, over 50-400 rad/s, omega^2 times it is constant. Other orders stay below 2% of
    it (at 50 rad/s the second-order drift of the mean speed leaks 0.7% into the 1x fit)."""
    products = []
    for omega in (50.0, 100.0, 200.0, 400.0):
        r = small_parameter_run(open_fmu, drive, omega, PENDULUM)
        amp = order_amplitudes(r.phi_in, r.x_e, [1, 2, 3, 4])[0]
        eq20 = rc.small_parameter_amplitude(E, D, R, ECC, I2, omega)
        assert amp[1] == pytest.approx(eq20, rel=0.02)
        assert max(amp[0], amp[2]) < 0.02 * amp[1]
        products.append(amp[1] * omega ** 2)
    assert rc.small_parameter_amplitude(E, D, R, ECC, I2, 100.0) == pytest.approx(5.899e-4, rel=1e-3)
    np.testing.assert_allclose(products, products[-1], rtol=0.02)


def test_validity_speed_is_where_eq20_reaches_the_largest_static_shift():
    """Written out from the paper: EI = E pi d^4 / 64, c_s = 87 EI/R, omega_min = sqrt(c_s / (4 I2)) = 60.3, 42.6,
    34.8 rad/s for R = 0.1, 0.2, 0.3 m (Fig. 4 set); there Eq. (20)'s amplitude 39.25 e^2 EI / (omega^2 I2 R^3)
    equals the largest static shift x_e_max = M_p,max / c_s = (157/87)(e/R)^2 (Eq. 22, the paper rounds to 1.8),
    for any e."""
    ei = E * math.pi * D ** 4 / 64
    for radius, expected in ((0.1, 60.27), (0.2, 42.62), (0.3, 34.80)):
        w = rc.validity_speed(E, D, radius, I2)
        assert w == pytest.approx(expected, abs=0.01)
        assert w == pytest.approx(math.sqrt(87 * ei / radius / (4 * I2)), rel=1e-12)
        for e in (0.001, 0.003, 0.01):
            assert rc.small_parameter_amplitude(E, D, radius, e, I2, w) == pytest.approx(157 / 87 * (e / radius) ** 2,
                                                                                         rel=1e-12)
            assert 39.25 * e ** 2 * ei / (w ** 2 * I2 * radius ** 3) == pytest.approx(1.8 * (e / radius) ** 2,
                                                                                    rel=0.003)


@pytest.mark.parametrize("radius", [0.1, 0.2, 0.3])
def test_eq20_error_grows_below_the_validity_speed(open_fmu, drive, radius):
    """With the coupling's stiffness c_s = 87 EI/R (10% damping) the simulated 2x amplitude is the linear forced
    response A_e / |omega_n^2 - 4 omega^2 + 2i omega c_d/I2|, omega_n = 2 omega_min; Eq. (20)'s error grows as the
    speed falls towards omega_min, from under 10% at 4 omega_min to over 50% at 1.2 omega_min."""
    c_s = rc.rotational_stiffness(E, D, radius)
    c_d = 0.2 * math.sqrt(c_s * I2)
    a_e = rc.pendulum_constant(E, D, radius, ECC, I2)
    w_min = rc.validity_speed(E, D, radius, I2)
    errors = []
    for ratio in (4.0, 2.0, 1.5, 1.2):
        omega = ratio * w_min
        r = small_parameter_run(open_fmu, drive, omega, dict(R=radius, c_s=c_s, c_d=c_d), n=2500, settle=1500)
        assert halves_change(r.phi_in, r, ["x_e"], [2])[0] < 1e-4   # it has settled
        amp = order_amplitudes(r.phi_in, r.x_e, [2])[0][0]
        linear = a_e / abs(4 * w_min ** 2 - 4 * omega ** 2 + 2j * omega * c_d / I2)
        assert amp == pytest.approx(linear, rel=0.01)
        errors.append(abs(rc.small_parameter_amplitude(E, D, radius, ECC, I2, omega) / amp - 1))
    assert errors[0] < 0.1 and errors[-1] > 0.5
    assert all(a < b for a, b in zip(errors, errors[1:]))


def test_steady_running_with_stiffness_and_load(open_fmu, drive):
    """Mean transmitted torque = load torque, mean twist = -T/c_s, and the speed of shaft 2 fluctuates at twice the
    shaft frequency (other orders below 1e-3 of it)."""
    tau, omega = 10.0, 100.0
    c_s = rc.rotational_stiffness(E, D, R)
    r = small_parameter_run(open_fmu, drive, omega, dict(c_d=0.2 * math.sqrt(c_s * I2)), tau_load=tau, n=3000,
                            settle=1500)
    assert halves_change(r.phi_in, r, ["x_e", "omega_out"])[0] < 1e-4   # it has settled
    revolutions = slice(0, int(round(2 * math.pi / omega * 20 / 1e-3)))       # 20 whole revolutions
    assert np.mean(r.transmitted_torque[revolutions]) == pytest.approx(tau, rel=1e-3)
    assert np.mean(r.x_e[revolutions]) == pytest.approx(-tau / c_s, rel=1e-3)
    amp = order_amplitudes(r.phi_in, r.omega_out, [1, 2, 3, 4])[0]
    assert amp[1] > 1e-3 and max(amp[0], amp[2], amp[3]) < 1e-3 * amp[1]


def test_power_balance_through_the_fmu_outputs(open_fmu, drive):
    """Undamped, ramped input, load: tau_in w1 - tau_load w2 = dE/dt with E the FMU's stored_energy."""
    h, tau = 2e-4, 3.0
    r = drive(open_fmu("RingCoupling"), lambda t: 20.0 + 60.0 * t, tau, h, 5000, OUT, dict(I1=0.01, c_d=0.0))
    power = r.tau_in * r.omega_in - tau * r.omega_out
    work = np.concatenate([[0.0], np.cumsum(0.5 * (power[1:] + power[:-1]) * h)])
    energy = r.stored_energy - r.stored_energy[0]
    assert np.ptp(energy) > 1.0
    assert np.max(np.abs(energy - work)) < 1e-3 * np.ptp(energy)


@pytest.mark.parametrize("params,needle", [({"e": 0.1}, "e = 0.1"), ({"e": 0.2, "R": 0.1}, "smaller than the ring")])
def test_eccentricity_at_or_beyond_the_ring_radius_is_an_error(open_fmu, params, needle):
    """The model's own check (e < R); single out-of-range parameters: tests/fmu/test_bad_input.py."""
    inst = open_fmu("RingCoupling")
    with pytest.raises(FMICallException, match="fmi2ExitInitializationMode"):
        inst.initialize(params)
    assert any(needle in m and "allowed range" in m for m in inst._log), inst._log


@pytest.mark.parametrize("name", ["RingCoupling", "RingCouplingTorqueDriven"])
def test_another_ring_with_the_default_rings_stiffness_is_warned_about(open_fmu, name, tmp_path):
    """c_s is a parameter of its own: a ring of R = 0.05 m, d = 4 mm left at the default ring's c_s (87 EI/R of
    R = 0.1 m, d = 3 mm) runs, with a warning giving its own 87 EI/R (closed form: E pi d^4 / 64 times 87 / R);
    none when c_s is set, or for the default ring. The scenario layer says the same before a run."""
    own = 87.0 * 2.1e11 * math.pi * 0.004 ** 4 / 64.0 / 0.05
    damped = {"c_d": 1.0}   # the undamped ring's own warning left out (test_ring_coupling_model.py)
    for params, warned in (({"R": 0.05, "d": 0.004, "e": 0.001, **damped}, True),
                           ({"R": 0.05, "d": 0.004, "e": 0.001, "c_s": own, **damped}, False), (damped, False)):
        inst = open_fmu(name, f"ring{len(params)}")
        inst.initialize(params)
        warnings = [m for m in inst._log if "[warning]" in m and "c_s" in m]
        assert len(warnings) == warned, (params, inst._log)
        if warned:
            assert f"this ring's 87 EI/R is {own:.6g} N.m/rad" in warnings[0]
    from ujfmu.scenario import Scenario
    text = (SCENARIOS / "ring_coupling_startup.toml").read_text()
    assert Scenario(SCENARIOS / "ring_coupling_startup.toml").model_advice() == []
    changed = tmp_path / "other_ring.toml"
    changed.write_text(text.replace('fmu = "RingCoupling"\nparameters = {',
                                    'fmu = "RingCoupling"\nparameters = { R = 0.05, d = 0.004,'))
    assert changed.read_text() != text
    (advice,) = Scenario(changed).model_advice()
    assert advice.startswith("coupling: c_s = ") and f"{own:.6g} N.m/rad" in advice


def test_the_torque_driven_ring_at_its_default_experiment_follows_a_fine_solve(fmu_dir):
    """fmpy's simulate_fmu of RingCouplingTorqueDriven.fmu with every default (an undamped ring: c_d = 0, J_drive
    = 1e-3 kg.m^2 on shaft 1, misaligned, the torques 0): the misalignment moment sets both shafts swinging and the
    undamped two-mass mode (861 rad/s) rings for the whole run. Against a fine solve of both shafts' equations
    written out here (scipy DOP853, rtol 1e-12), omega_in and omega_out stay within 1e-4 of omega_in's range; RK4
    at its h w_n = 0.5 had been 3.6% off by 2 s (a fresh-eyes FMI audit)."""
    from fmpy import simulate_fmu
    from scipy.integrate import solve_ivp
    result = simulate_fmu(str(fmu_dir / "RingCouplingTorqueDriven.fmu"), output=["omega_in", "omega_out"])
    amplitude = 157 * E * math.pi * D ** 4 / 64 / R ** 3 * ECC ** 2
    c_s, j1 = 87 * E * math.pi * D ** 4 / 64 / R, 1e-3

    def both(t, y):
        phi1, w1, phi2, w2 = y
        m_p = amplitude * math.cos(phi1 + phi2)
        return [w1, (m_p + c_s * (phi2 - phi1)) / j1, w2, (m_p - c_s * (phi2 - phi1)) / I2]
    t = result["time"]
    fine = solve_ivp(both, (t[0], t[-1]), (0.0, 0.0, 0.0, 0.0), method="DOP853", rtol=1e-12, atol=1e-12,
                     t_eval=t).y
    span = np.ptp(fine[1])
    assert t[-1] == 2.0 and span > 10.0
    assert np.max(np.abs(result["omega_in"] - fine[1])) < 1e-4 * span
    assert np.max(np.abs(result["omega_out"] - fine[3])) < 1e-4 * span


def test_a_light_input_shaft_swinging_on_the_ring_is_stepped_not_refused(open_fmu):
    """J_drive = 1e-7 kg.m^2 on the default ring, shaft 1 at 100 rad/s: the misalignment moment accelerates it at
    1.2e9 rad/s^2, which the speed-reach bound extrapolates to 1.2e6 rad/s in 1 ms, but the two-mass mode (85000
    rad/s) swings it back within the step: it reaches about 240 rad/s (a fresh-eyes analyst's solve). The step is
    taken and follows a fine solve of both shafts' equations written out here; a torque that does take the shaft
    out of its range is still refused."""
    from scipy.integrate import solve_ivp
    inst = open_fmu("RingCouplingTorqueDriven")
    inst.initialize(dict(J_drive=1e-7, omega_in_start=100.0))
    amplitude = 157 * E * math.pi * D ** 4 / 64 / R ** 3 * ECC ** 2
    c_s = 87 * E * math.pi * D ** 4 / 64 / R

    def both(t, y):
        phi1, w1, phi2, w2 = y
        m_p = amplitude * math.cos(phi1 + phi2)
        return [w1, (m_p + c_s * (phi2 - phi1)) / 1e-7, w2, (m_p - c_s * (phi2 - phi1)) / I2]
    fine = solve_ivp(both, (0.0, 5e-3), (0.0, 100.0, 0.0, 100.0), method="DOP853", rtol=1e-11, atol=1e-11,
                     t_eval=[1e-3 * (k + 1) for k in range(5)], max_step=1e-6).y
    for k in range(5):
        assert inst.raw("fmi2DoStep")(inst.slave.component, k * 1e-3, 1e-3, 1) == 0, inst._log[-1:]
        assert inst.get("omega_in")[0] == pytest.approx(fine[1][k], abs=1e-3 * np.ptp(fine[1]) + 1e-6)
    assert np.max(np.abs(fine[1])) < 1e3
    inst.set(tau_in=1e3)   # 1e3 N.m on 1e-7 kg.m^2: out of the range for good
    assert inst.raw("fmi2DoStep")(inst.slave.component, 5e-3, 1e-3, 1) == 2
    assert "would reach" in inst._log[-1]
