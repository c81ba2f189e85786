"""Double Cardan physics: joint kinematics against tan relations and vectors, the kinematic oracles of the
constant-velocity layouts, Brutti's rigid case, Omar's natural frequencies, power balance."""

import math

import numpy as np
import pytest
from scipy.integrate import cumulative_simpson

from ujfmu.models.double_cardan_driveline import model as dc
from ujfmu.models.double_cardan_driveline.reference import DrivelineReference

DEG = math.pi / 180.0
OMAR = dict(I_input=0.0, I_cross_pin=0.0, I_cross_normal=0.0, I_intermediate=0.0, J_load=0.0045, k_theta=92.2,
            xi_theta=0.002, m_s=4.09, k_phi=26331.0, xi_phi=0.002, L_c=0.325)
BRUTTI = dict(OMAR, I_input=0.01528, I_cross_pin=0.00111, I_cross_normal=0.00202, J_load=0.01528)


def driveline(beta1, beta2, yoke_phase=0.0, plane=0.0, **inertias):
    return dc.Parameters(beta1, beta2, yoke_phase, plane, **{**OMAR, **inertias})


def reference(beta1, beta2, yoke_phase=0.0, plane=0.0, **inertias):
    values = {**OMAR, **inertias}
    return DrivelineReference({"beta1": beta1, "beta2": beta2, "yoke_phase": yoke_phase, "joint_plane_angle": plane,
                               **values})


# --- one joint ------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("b", [1 * DEG, 15 * DEG, -30 * DEG, 60 * DEG])
def test_joint_error_satisfies_tan_relation_and_stays_continuous(b):
    x = np.linspace(-20 * math.pi, 20 * math.pi, 20001)
    y = np.array([xi + dc.joint_error(xi, b) for xi in x])
    ok = np.abs(np.cos(x)) > 1e-3
    assert np.allclose(np.tan(y[ok]), np.tan(x[ok]) / math.cos(b), rtol=1e-9, atol=1e-9)
    assert np.all(np.diff(y) > 0)                       # monotonic: no branch jump over 20 revolutions
    assert np.max(np.abs(y - x)) < math.pi / 2


@pytest.mark.parametrize("b", [5 * DEG, 40 * DEG])
def test_joint_inverse_undoes_joint(b):
    for x in np.linspace(-7, 7, 101):
        y = x + dc.joint_error(x, b)
        assert dc.joint_inverse(y, b) == pytest.approx(x, abs=1e-12)


@pytest.mark.parametrize("b", [10 * DEG, -35 * DEG])
def test_joint_ratio_derivatives_match_finite_differences(b):
    eps = 1e-6
    for x in np.linspace(-3, 3, 37):
        r, dr, dyb = dc.joint_ratio(x, b)
        assert r == pytest.approx((dc.joint_error(x + eps, b) - dc.joint_error(x - eps, b)) / (2 * eps) + 1,
                                  abs=1e-8)
        assert dr == pytest.approx((dc.joint_ratio(x + eps, b)[0] - dc.joint_ratio(x - eps, b)[0]) / (2 * eps),
                                   abs=1e-7)
        assert dyb == pytest.approx((dc.joint_error(x, b + eps) - dc.joint_error(x, b - eps)) / (2 * eps),
                                    abs=1e-8)


def _cross_energy_from_vectors(x, b, i_pin, i_normal, eps=1e-6):
    """J(x) from the cross frame (e_A, e_B, e_n) by finite differences of the rotation matrix (numpy)."""
    def frame(x):
        c, s = math.cos(b), math.sin(b)
        e_a = np.array([-math.sin(x), c * math.cos(x), s * math.cos(x)])
        e_b = np.cross([0.0, 0.0, 1.0], e_a)
        e_b /= np.linalg.norm(e_b)
        return np.column_stack([e_a, e_b, np.cross(e_a, e_b)])
    r = frame(x)
    w = r.T @ (frame(x + eps) - frame(x - eps)) / (2 * eps)
    rates = np.array([w[2, 1], w[0, 2], w[1, 0]])
    return i_pin * (rates[0] ** 2 + rates[1] ** 2) + i_normal * rates[2] ** 2


@pytest.mark.parametrize("b", [0.0, 10 * DEG, 45 * DEG])
def test_cross_inertia_is_the_cross_kinetic_energy(b):
    eps = 1e-6
    for x in np.linspace(-3, 3, 25):
        j, dj = dc.cross_inertia(x, b, 0.00111, 0.00202)
        assert j == pytest.approx(_cross_energy_from_vectors(x, b, 0.00111, 0.00202), rel=1e-8)
        fd = (dc.cross_inertia(x + eps, b, 0.00111, 0.00202)[0] - dc.cross_inertia(x - eps, b, 0.00111, 0.00202)[0])
        assert dj == pytest.approx(fd / (2 * eps), abs=1e-9)
    assert dc.cross_inertia(0.3, 0.0, 0.00111, 0.00202)[0] == pytest.approx(0.00202)   # aligned: spins on normal


# --- acceptance 1: kinematic oracles --------------------------------------------------------------------------

def _output_error(p, phi1):
    return np.array([dc.rigid_output_angle(p, x) for x in phi1]) - phi1


def _harmonic(signal, phi1, n):
    """Complex amplitude of the n-th harmonic of a signal sampled over one revolution."""
    return 2.0 * np.mean(signal * np.exp(-1j * n * phi1))


PHI1 = np.linspace(0.0, 2 * math.pi, 720, endpoint=False)


@pytest.mark.parametrize("layout,beta2_sign", [("Z", 1.0), ("W", -1.0)])
@pytest.mark.parametrize("beta_deg", [10.0, 30.0])
def test_equal_angles_in_phase_is_constant_velocity(layout, beta2_sign, beta_deg):
    p = driveline(beta_deg * DEG, beta2_sign * beta_deg * DEG)
    assert np.max(np.abs(_output_error(p, PHI1 + 40 * math.pi))) < 1e-12
    rigid = [dc.rigid_state(p, x, 50.0, 0.0, 0.0) for x in PHI1]
    assert max(abs(s["omega4"] - 50.0) for s in rigid) < 1e-11
    assert np.ptp([s["omega2"] for s in rigid]) > 1.0          # the intermediate shaft does fluctuate


def test_yokes_90_deg_apart_double_the_second_harmonic_speed_error():
    b = 10 * DEG
    single = np.array([dc.joint_ratio(x, b)[0] for x in PHI1]) - 1.0
    p = driveline(b, b, yoke_phase=math.pi / 2)
    double = np.array([dc.rigid_state(p, x, 1.0, 0.0, 0.0)["omega4"] for x in PHI1]) - 1.0
    ratio = abs(_harmonic(double, PHI1, 2)) / abs(_harmonic(single, PHI1, 2))
    q = math.tan(b / 2) ** 2
    assert ratio == pytest.approx(2.0, abs=4 * q)   # exact to first order in q
    assert abs(ratio - 2.0) > 1e-6                    # and only to first order


@pytest.mark.parametrize("b1_deg,b2_deg,phase_deg,plane_deg", [(3, 3, 30, 0), (4, 2, 0, 50), (2, 5, 80, 10),
                                                               (3, -4, 45, 0)])
def test_second_harmonic_of_output_error_is_q1_minus_q2_exp_2i_delta(b1_deg, b2_deg, phase_deg, plane_deg):
    b1, b2 = b1_deg * DEG, b2_deg * DEG
    delta = (phase_deg - plane_deg) * DEG
    p = driveline(b1, b2, phase_deg * DEG, plane_deg * DEG)
    q1, q2 = math.tan(b1 / 2) ** 2, math.tan(b2 / 2) ** 2
    amplitude = abs(_harmonic(_output_error(p, PHI1), PHI1, 2))
    assert amplitude == pytest.approx(abs(q1 - q2 * np.exp(2j * delta)), abs=2 * max(q1, q2) ** 2)


@pytest.mark.parametrize("phase_deg, plane_deg", [(30, 0), (0, -30), (70, 25)])
def test_a_positive_yoke_phase_turns_joint_2_ahead_in_the_sense_of_rotation(phase_deg, plane_deg):
    """The sense of delta = yoke_phase - joint_plane_angle (README, "Layout"), which the |q1 - q2 exp(2i delta)|
    amplitude cannot tell from -delta (it sets the ripple's phase against the input angle): at 20 and 35 deg (a
    steering column's) the output speed is the product of the textbook ratios, joint 1's
    cos b1 / (1 - sin^2 b1 cos^2 phi1) and joint 2's cos b2 / (1 - sin^2 b2 sin^2(psi2 + delta)), psi2 the
    intermediate shaft's angle (tan psi2 = tan phi1 / cos b1); with -delta it differs by up to 41-49%."""
    b1, b2, delta = 20 * DEG, 35 * DEG, (phase_deg - plane_deg) * DEG
    p = driveline(b1, b2, phase_deg * DEG, plane_deg * DEG)
    phi1 = np.linspace(0.01, 2 * math.pi, 97)
    psi2 = np.unwrap(np.arctan2(np.sin(phi1), np.cos(phi1) * math.cos(b1)))

    def textbook(d):
        return (math.cos(b1) / (1 - math.sin(b1) ** 2 * np.cos(phi1) ** 2)
                * math.cos(b2) / (1 - math.sin(b2) ** 2 * np.sin(psi2 + d) ** 2))
    ratio = np.array([dc.rigid_state(p, x, 1.0, 0.0, 0.0)["omega4"] for x in phi1])
    np.testing.assert_allclose(ratio, textbook(delta), rtol=1e-12)
    assert np.max(np.abs(ratio / textbook(-delta) - 1.0)) > 0.05


# --- acceptance 2: Brutti's rigid case ------------------------------------------------------------------------

C_FAN = 0.017      # N.m.s^2, M_u = c omega5^2
RPM = math.pi / 30


def _brutti_tau_in(p, rpm):
    w = rpm * RPM
    out = []
    for x in PHI1:
        rigid = dc.rigid_state(p, x, w, 0.0, 0.0)
        out.append(dc.rigid_state(p, x, w, 0.0, C_FAN * rigid["omega4"] ** 2)["tau_in"])
    return np.array(out)


def test_brutti_without_inertia_input_torque_equals_resisting_torque():
    p = driveline(10 * DEG, 10 * DEG,
                  **{**BRUTTI, "I_input": 0.0, "I_cross_pin": 0.0, "I_cross_normal": 0.0, "J_load": 0.0})
    tau = _brutti_tau_in(p, 2000)
    assert np.allclose(tau, C_FAN * (2000 * RPM) ** 2, rtol=1e-12)
    assert C_FAN * (2000 * RPM) ** 2 == pytest.approx(750, rel=0.01)   # Brutti's catalogue M_u


def test_brutti_inertia_torque_is_second_harmonic_and_grows_with_speed_squared():
    p = driveline(10 * DEG, 10 * DEG, **BRUTTI)
    fluct = {rpm: _brutti_tau_in(p, rpm) - C_FAN * (rpm * RPM) ** 2 for rpm in (2000, 4000)}
    for f in fluct.values():
        spectrum = np.abs(np.fft.rfft(f))
        assert np.argmax(spectrum) == 2                                     # twice per revolution
        assert abs(np.mean(f)) < 1e-9 * np.ptp(f)                           # no mean: lossless
    assert np.ptp(fluct[4000]) / np.ptp(fluct[2000]) == pytest.approx(4.0, rel=1e-9)
    assert 1.0 < np.ptp(fluct[2000]) < 50.0                                 # N.m: a few per mil of 746 N.m


def test_rigid_power_balance_against_independent_kinetic_energy():
    """tau_in w1 - tau_load w4 = dT/dt along a speed-varying input, T from the reference's vector kinematics."""
    b = dict(BRUTTI, I_intermediate=0.004)
    p = driveline(10 * DEG, 14 * DEG, yoke_phase=0.3, plane=0.1, **b)
    ref = reference(10 * DEG, 14 * DEG, 0.3, 0.1, **b)
    t = np.linspace(0.0, 0.05, 5001)
    alpha = 400.0
    w1, phi1 = 200.0 + alpha * t, 0.2 + 200.0 * t + 0.5 * alpha * t ** 2
    rg = ref.rigid(phi1)
    kinetic = 0.5 * rg["j_eq"] * w1 ** 2
    tau_load = 300.0
    states = [dc.rigid_state(p, x, w, alpha, tau_load) for x, w in zip(phi1, w1)]
    power = np.array([s["tau_in"] * w - tau_load * s["omega4"] for s, w in zip(states, w1)])
    dtdt = np.gradient(kinetic, t, edge_order=2)
    assert np.allclose(np.array([s["energy"] for s in states]), kinetic, rtol=1e-10)
    assert np.max(np.abs(power - dtdt)[2:-2]) < 1e-5 * np.max(np.abs(power))


def test_rigid_output_flange_torque_passes_on_the_power_the_inner_parts_do_not_keep():
    """tau_out = J_load dw4/dt + tau_load at the output shaft's flange: tau_in w1 - tau_out w4 = d/dt of the kinetic
    energy of what lies between (input shaft, crosses, intermediate shaft), from the reference's vector kinematics,
    along a speed-varying input; with no inertia between, tau_in w1 = tau_out w4 (massless joints pass the power
    on). A constant-velocity layout at constant speed passes tau_load itself."""
    b = dict(BRUTTI, I_intermediate=0.004)
    t = np.linspace(0.0, 0.05, 5001)
    alpha, tau_load = 400.0, 300.0
    w1, phi1 = 200.0 + alpha * t, 0.2 + 200.0 * t + 0.5 * alpha * t ** 2
    for inertias in (b, dict(b, I_input=0.0, I_cross_pin=0.0, I_cross_normal=0.0, I_intermediate=0.0)):
        p = driveline(10 * DEG, 14 * DEG, yoke_phase=0.3, plane=0.1, **inertias)
        rg = reference(10 * DEG, 14 * DEG, 0.3, 0.1, **inertias).rigid(phi1)
        inner = 0.5 * rg["j_eq"] * w1 ** 2 - 0.5 * p.J_load * (rg["rho"] * w1) ** 2
        states = [dc.rigid_state(p, x, w, alpha, tau_load) for x, w in zip(phi1, w1)]
        power = np.array([s["tau_in"] * w - s["tau_out"] * s["omega4"] for s, w in zip(states, w1)])
        flange = np.array([s["tau_out"] for s in states])
        assert np.ptp(flange) > 1.0                                          # the flange torque's 2x swing
        kept = np.gradient(inner, t, edge_order=2)
        assert np.max(np.abs(power - kept)[2:-2]) < 1e-6 * tau_load * np.max(w1)   # of the power passed on
        assert np.max(np.abs(kept)) > 10.0 or inertias["I_input"] == 0.0
    assert np.max(np.abs(power)) < 1e-12 * tau_load * np.max(w1)             # no inertia between: none kept
    cv = driveline(10 * DEG, 10 * DEG, **BRUTTI)
    assert all(dc.rigid_state(cv, x, 200.0, 0.0, tau_load)["tau_out"] == pytest.approx(tau_load, rel=1e-12)
               for x in np.linspace(0.0, math.pi, 7))


@pytest.mark.parametrize("massless", [False, True])
def test_flexible_output_flange_torque_is_the_reference_equations(massless):
    """A flexible shaft's tau_out (speed- and torque-driven) is J_load phi4'' + tau_load with phi4'' from Lagrange's
    equations of the independent reference (sympy, vector kinematics), at random rigs, states and inputs."""
    rng = np.random.default_rng(19)
    for _ in range(40):
        p = _random_rig(rng, massless)
        ref = reference(p.beta1, p.beta2, p.yoke_phase, p.joint_plane_angle, I_input=p.I_input,
                        I_cross_pin=p.I_cross_pin, I_cross_normal=p.I_cross_normal, I_intermediate=p.I_intermediate)
        phi1, w1, alpha, tau_load = rng.uniform(-50, 50), rng.uniform(-100, 100), rng.uniform(-500, 500), \
            rng.uniform(-9, 9)
        y = (rng.uniform(-50, 50), rng.uniform(-100, 100), rng.uniform(-0.05, 0.05), rng.uniform(-5, 5))
        acc, _ = ref.accelerations((phi1, y[0], y[2]), (w1, y[1], y[3]), known_alpha1=alpha, tau_load=tau_load)
        expected = p.J_load * acc[1] + tau_load
        ours = dc.outputs(p, 0.0, dc.State(*y), dc.Drive(phi1, w1, alpha, tau_load))["tau_out"]
        assert ours == pytest.approx(expected, rel=1e-9, abs=1e-9 * (1.0 + abs(p.J_load * acc[1])))
        assert dc.load_outputs(p, 0.0, dc.State(*y), dc.Drive(phi1, w1, alpha, tau_load)) == {"tau_out": ours}
        fields = {f: getattr(p, f) for f in ("beta1", "beta2", "yoke_phase", "joint_plane_angle", *OMAR, "I_input",
                                             "I_cross_pin", "I_cross_normal", "I_intermediate")}
        q = dc.TorqueDrivenParameters(**fields, J_drive=0.01, omega_in_start=0.0)
        tau_drive = rng.uniform(-50, 50)
        acc, _ = ref.accelerations((phi1, y[0], y[2]), (w1, y[1], y[3]), tau_drive=tau_drive, extra_inertia=0.01,
                                   tau_load=tau_load)
        driven = dc.TorqueDriven.outputs(q, 0.0, (phi1, w1, *y), dc.TorqueDriven.Inputs(tau_drive, tau_load))
        assert driven["tau_out"] == pytest.approx(q.J_load * acc[1] + tau_load, rel=1e-9,
                                                  abs=1e-9 * (1.0 + abs(q.J_load * acc[1])))


# --- acceptance 3: Omar's natural frequencies; flexible power balance -----------------------------------------

def test_aligned_linearised_system_has_omars_natural_frequencies():
    p = driveline(0.0, 0.0, xi_theta=0.0, xi_phi=0.0)
    y0 = (0.0, 0.0, 0.0, 0.0)
    eps = 1e-7
    jac = np.column_stack([(np.array(dc.flexible_derivatives(p, 0.0, 0.0, tuple(np.add(y0, e)), 0.0))
                            - np.array(dc.flexible_derivatives(p, 0.0, 0.0, tuple(np.subtract(y0, e)), 0.0)))
                           / (2 * eps) for e in eps * np.eye(4)])
    freqs = sorted(np.abs(np.linalg.eigvals(jac).imag))[::2]
    assert freqs == pytest.approx([math.sqrt(26331.0 / 4.09), math.sqrt(92.2 / 0.0045)], rel=1e-6)
    assert freqs == pytest.approx([80.0, 143.0], rel=0.005)                  # Omar section 2.3


@pytest.mark.parametrize("layout", [dict(beta2=15 * DEG), dict(beta2=-20 * DEG, yoke_phase=0.4, plane=0.2)])
def test_flexible_power_balance(layout):
    """tau_in w1 - tau_load w4 = dE/dt + c_theta dtwist^2 + c_phi (L_c cos beta1)^2 dphi^2 along a run."""
    inertias = dict(I_input=1e-3, I_cross_pin=2e-4, I_cross_normal=3e-4, I_intermediate=1e-3, xi_theta=0.01,
                    xi_phi=0.01, m_s=0.05)
    p = driveline(15 * DEG, layout["beta2"], layout.get("yoke_phase", 0.0), layout.get("plane", 0.0), **inertias)
    h, alpha, tau_load = 1e-4, 300.0, 5.0
    phi1, w1 = 0.1, 60.0
    state = (dc.rigid_output_angle(p, phi1), w1, 0.0, 0.0)
    rows = []
    for _ in range(2500):
        out = dc.flexible_outputs(p, phi1, w1, alpha, state)
        diss = p.c_theta * out["dtwist"] ** 2 + p.c_phi * p.lever2 * state[3] ** 2
        lateral = 0.5 * p.k_phi * p.lever2 * state[2] ** 2 + 0.5 * p.m_lat * state[3] ** 2
        rows.append((out["energy"], out["tau_in"] * w1 - tau_load * state[1] - diss, lateral))
        state = dc.flexible_step(p, h, phi1, w1, alpha, state, tau_load, 4)
        phi1, w1 = phi1 + h * (w1 + 0.5 * alpha * h), w1 + alpha * h
    energy, net_power, lateral = np.array(rows).T
    assert np.ptp(energy) > 1.0                                             # a real exchange of energy
    work = cumulative_simpson(net_power, dx=h, initial=0.0)
    assert np.max(np.abs(energy - energy[0] - work)) < 2e-9 * np.ptp(energy)
    # the lateral support's own energy (spring and mass, small here) is still over 10x the balance's tolerance:
    # a missing lateral term in the energy or the equations would show
    assert np.max(lateral) > 10 * 2e-9 * np.ptp(energy)


def test_lateral_force_is_quadratic_in_torque_for_z_and_linear_for_w():
    """Why Table 2's misalignment grows as T^2: in the Z layout the joints' dy/db terms cancel untwisted, and g
    grows with the twist; in the W layout they add."""
    for b2, expect in ((15 * DEG, 1), (-15 * DEG, 0)):
        p = driveline(15 * DEG, b2)
        g = [abs(dc.flexible_kinematics(p, 0.4, 0.0, dc.rigid_output_angle(p, 0.4) - tw, 0.0, 0.0, 0.0)[4])
             for tw in (0.01, 0.02)]
        if expect:
            assert g[1] / g[0] == pytest.approx(2.0, rel=0.02)
        else:
            assert g[1] / g[0] == pytest.approx(1.0, rel=0.02)


def _random_rig(rng, massless):
    """Parameters at a random layout, with random cross and intermediate-shaft inertias or (massless) none, which
    takes the straight-line code's constant-inertia branch."""
    b1, b2, phase, plane = rng.uniform(-0.6, 0.6, 4)
    inertias = {} if massless else dict(I_cross_pin=rng.uniform(0, 1e-3), I_cross_normal=rng.uniform(0, 1e-3),
                                        I_intermediate=rng.uniform(0, 1e-2))
    p = driveline(b1, b2, phase, plane, I_input=rng.uniform(0, 1e-2), **inertias)
    assert p.constant_inertias == massless
    return p


@pytest.mark.parametrize("massless", [False, True])
def test_straight_line_derivatives_are_the_composed_equations(massless):
    """flexible_derivatives (straight-line code, the integrator's inner loop) is Lagrange's equations assembled from
    flexible_kinematics and output_inertia (each tested against the kinematics and energies above), at random
    layouts, inertias (none: the constant-inertia branch), states and inputs."""
    rng = np.random.default_rng(16)
    for _ in range(200):
        p = _random_rig(rng, massless)
        phi1, w1, tau = rng.uniform(-50, 50), rng.uniform(-100, 100), rng.uniform(-10, 10)
        phi4, w4, phi, dphi = rng.uniform(-50, 50), rng.uniform(-100, 100), rng.uniform(-0.05, 0.05), rng.uniform(-5, 5)
        twist, dtwist, r1, r2, g, _ = dc.flexible_kinematics(p, phi1, w1, phi4, w4, phi, dphi)
        shaft = p.k_theta * twist + p.c_theta * dtwist
        j_out, dj_out = dc.output_inertia(p, phi4)
        if not massless:
            assert dj_out != 0.0   # the branch with a varying J_out
        composed = (w4, (r2 * shaft - 0.5 * dj_out * w4 * w4 - tau) / j_out, dphi,
                    -(p.c_phi * dphi + p.k_phi * phi) / p.m_s - g * shaft / p.m_lat)
        ours = dc.flexible_derivatives(p, phi1, w1, (phi4, w4, phi, dphi), tau)
        np.testing.assert_allclose(ours, composed, rtol=1e-12, atol=1e-12 * max(map(abs, composed)))


@pytest.mark.parametrize("massless", [False, True])
def test_fmu_outputs_are_the_composed_flexible_outputs(massless):
    """The FMU's outputs (``outputs``: the kinematics of the straight-line code) are flexible_outputs (power balance
    tested above) and the state, at random layouts, inertias, states and inputs (tau_out against the reference's
    equations: test_flexible_output_flange_torque_is_the_reference_equations)."""
    rng = np.random.default_rng(17)
    for _ in range(200):
        p = _random_rig(rng, massless)
        phi1, w1, alpha1, tau = rng.uniform(-50, 50), rng.uniform(-100, 100), rng.uniform(-500, 500), rng.uniform(-9, 9)
        y = dc.State(rng.uniform(-50, 50), rng.uniform(-100, 100), rng.uniform(-0.05, 0.05), rng.uniform(-5, 5))
        out = dc.flexible_outputs(p, phi1, w1, alpha1, y)
        ours = dc.outputs(p, 0.0, y, dc.Drive(phi1, w1, alpha1, tau))
        expected = {"phi_out": y.phi4, "omega_out": y.omega4, "dynamic_misalignment": y.phi, "twist": out["twist"],
                    "tau_in": out["tau_in"], "shaft_torque": out["shaft_torque"], "omega_intermediate": out["omega2"],
                    "stored_energy": out["energy"]}
        assert ours.keys() == expected.keys() | {"tau_out"}
        for key, value in expected.items():
            assert ours[key] == pytest.approx(value, rel=1e-12, abs=1e-12 * (1.0 + abs(value))), key


@pytest.mark.parametrize("massless", [False, True])
def test_torque_driven_outputs_are_the_speed_driven_ones_at_the_accelerating_input(massless):
    """DoubleCardanDrivelineTorqueDriven's outputs (one evaluation of the kinematics) are the speed-driven outputs
    at the input shaft's motion, its acceleration from the equation of motion (torque_driven_rates), at random
    rigs, states and torques."""
    rng = np.random.default_rng(18)
    for _ in range(100):
        base = _random_rig(rng, massless)
        fields = {f: getattr(base, f) for f in ("beta1", "beta2", "yoke_phase", "joint_plane_angle", *OMAR,
                                                "I_input")}
        p = dc.TorqueDrivenParameters(**fields, J_drive=rng.uniform(1e-3, 0.1), omega_in_start=0.0)
        y = (rng.uniform(-50, 50), rng.uniform(-100, 100), rng.uniform(-50, 50), rng.uniform(-100, 100),
             rng.uniform(-0.05, 0.05), rng.uniform(-5, 5))
        u = dc.TorqueDriven.Inputs(rng.uniform(-50, 50), rng.uniform(-9, 9))
        alpha = dc.torque_driven_rates(p, p.J_drive, y, u.tau_in, u.tau_load)[1]
        speed_driven = dc.flexible_outputs(p, y[0], y[1], alpha, y[2:])
        ours = dc.TorqueDriven.outputs(p, 0.0, y, u)
        assert ours["alpha_in"] == pytest.approx(alpha, rel=1e-12, abs=1e-9)
        for key, out_key in (("tau_input_shaft", "tau_in"), ("twist", "twist"), ("shaft_torque", "shaft_torque"),
                             ("omega_intermediate", "omega2"), ("stored_energy", "energy")):
            value = speed_driven[out_key]
            assert ours[key] == pytest.approx(value, rel=1e-12, abs=1e-12 * (1.0 + abs(value))), key
        assert (ours["phi_in"], ours["omega_in"], ours["phi_out"], ours["omega_out"]) == (y[0], y[1], y[2], y[3])


def test_a_twist_no_real_shaft_takes_is_said_wherever_it_is_reached():
    """state_advice warns exactly where the intermediate shaft's twist phi2 - phi3 (flexible_kinematics, evaluated
    afresh) passes LARGE_TWIST, at random joint angles up to 60 deg, dynamic misalignments up to 0.3 rad and input
    and output angles around it (the cheap bound it uses first must never hide one), for both causalities; the
    message names the stiffness to set. A rigid shaft has no twist to warn of."""
    rng = np.random.default_rng(5)
    said = 0
    for _ in range(2000):
        p = driveline(rng.uniform(-60, 60) * DEG, rng.uniform(-60, 60) * DEG, rng.uniform(0, 2 * math.pi),
                      rng.uniform(0, 2 * math.pi))
        phi1, h = rng.uniform(-20, 20), 1e-3
        y = (phi1 - rng.uniform(-1.0, 1.0), 50.0, rng.uniform(-0.3, 0.3), 0.0)
        u = dc.Drive(phi1 - h * 60.0, 60.0, 0.0, 0.0)   # phi1 at the step's end
        twist = dc.flexible_kinematics(p, phi1, 0.0, y[0], 0.0, y[2], 0.0)[0]
        advice = dc.state_advice(p, h, y, u)
        assert bool(advice) == (abs(twist) > dc.LARGE_TWIST), (twist, advice)
        torque = dc.TorqueDrivenParameters(**{f: getattr(p, f) for f in ("beta1", "beta2", "yoke_phase",
                                                                         "joint_plane_angle", *OMAR, "I_input")},
                                           J_drive=0.01, omega_in_start=0.0)
        assert bool(dc.TorqueDriven.state_advice(torque, h, (phi1, 60.0) + y, dc.Torques(0.0, 0.0))) == bool(advice)
        if advice:
            said += 1
            assert "k_theta" in advice[0] and f"{twist:.3g} rad" in advice[0]
    assert 300 < said < 1700   # both sides of the bound are sampled
    rigid = dc.Parameters(0.2, 0.2, 0.0, 0.0, **OMAR, rigid_intermediate_shaft=True)
    assert dc.state_advice(rigid, 1e-3, (5.0, 0.0, 0.0, 0.0), dc.Drive(0.0, 0.0, 0.0, 0.0)) == []


def test_the_twist_advice_blames_the_defaults_only_at_the_default_stiffness():
    """The twist advice had told a truck engineer whose own 1e5 N.m/rad shaft twisted 1 rad in a diverging run that
    "the shaft is likely not yours: the defaults are Omar's laboratory rig": that is said at Omar's k_theta only;
    another shaft's advice names its stiffness and the torques on it."""
    y, u = (-0.8, 50.0, 0.0, 0.0), dc.Drive(0.0, 50.0, 0.0, 0.0)
    omar = dc.Parameters(0.2, 0.2, 0.0, 0.0, **OMAR)
    assert omar.k_theta == dc.OMAR_K_THETA
    own = dc.Parameters(0.2, 0.2, 0.0, 0.0, **{**OMAR, "k_theta": 1e5})
    said_omar, said_own = dc.state_advice(omar, 0.0, y, u)[0], dc.state_advice(own, 0.0, y, u)[0]
    assert "the defaults are Omar's laboratory rig" in said_omar
    assert "defaults" not in said_own and "check k_theta and the torques on the shaft" in said_own


@pytest.mark.parametrize("beta2, warnings", [(50.0, 1), (-50.0, 1), (48.0, 2), (10.0, 1)])
def test_steep_joints_of_one_angle_are_one_warning(beta2, warnings):
    """A constant-velocity pair of steep joints (Z: beta2 = beta1, W: beta2 = -beta1) is named in one warning, not
    one a joint; joints of other angles each get their own, and a joint within the usual range none."""
    advice = dc.advice(driveline(50.0 * DEG, beta2 * DEG))
    assert len(advice) == warnings, advice
    assert ("beta1 = beta2 = " in advice[0]) == (beta2 == 50.0)
    assert ("beta1 = -beta2 = " in advice[0]) == (beta2 == -50.0)
