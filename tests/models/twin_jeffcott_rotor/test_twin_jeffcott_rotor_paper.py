"""Tchomeni et al.'s printed mass matrix (Eq. 10) against Lagrange's equations formed by sympy from the kinetic
energy Eq. (4), in the paper's own 5-DOF setting (torsionally rigid: theta2 = f(theta1) through the joint).

The extraction is garbled; ujfmu/models/twin_jeffcott_rotor/README.md lists the readings this test pins down: the
unbalance terms turn with the disc angle (sin theta, not sin 2 theta), and (mu - 1) stands for the joint's speed
ratio up to sign."""

import pytest
import sympy as sp

th = sp.Symbol("theta1", real=True)
x1, y1, x2, y2 = sp.symbols("X1 Y1 X2 Y2", real=True)
w, vx1, vy1, vx2, vy2 = sp.symbols("w vx1 vy1 vx2 vy2", real=True)
j_m1, j_gb, j_m2, m1, m2, mu1, mu2, e = sp.symbols("J_M1 J_gb J_M2 M1 M2 m_u1 m_u2 e", positive=True)
f = sp.Function("f")(th)          # theta2 = f(theta1): the joint's output angle
ratio = sp.diff(f, th)


def _derived_mass_matrix():
    """Hessian of Eq. (4)'s kinetic energy in (theta1', X1', Y1', X2', Y2'), unbalance masses at angle theta."""
    kinetic = (j_m1 + j_gb) * w ** 2 / 2 + j_m2 * (ratio * w) ** 2 / 2
    for m, mu, th_i, rate, vx, vy in ((m1, mu1, th, w, vx1, vy1), (m2, mu2, f, ratio * w, vx2, vy2)):
        unbalance = sp.Matrix([vx - e * sp.sin(th_i) * rate, vy + e * sp.cos(th_i) * rate])
        kinetic += m * (vx ** 2 + vy ** 2) / 2 + mu * unbalance.dot(unbalance) / 2
    qd = (w, vx1, vy1, vx2, vy2)
    return sp.Matrix(5, 5, lambda i, j: sp.diff(kinetic, qd[i], qd[j]))


def _printed_mass_matrix(mu_minus_1, theta2):
    """Eq. (10) as printed, with the garbled 2*theta arguments read as theta (a 2x unbalance would whirl at twice
    the shaft speed)."""
    s1, c1, s2, c2 = sp.sin(th), sp.cos(th), sp.sin(theta2), sp.cos(theta2)
    m = sp.zeros(5, 5)
    m[0, 0] = (j_m1 + j_gb + mu1 * e ** 2) + (j_m2 + mu2 * e ** 2) * mu_minus_1 ** 2
    m[0, 1] = m[1, 0] = -mu1 * e * s1
    m[0, 2] = m[2, 0] = mu1 * e * c1
    m[0, 3] = m[3, 0] = mu2 * e * mu_minus_1 * s2
    m[0, 4] = m[4, 0] = mu2 * e * mu_minus_1 * c2
    m[1, 1] = m[2, 2] = m1 + mu1
    m[3, 3] = m[4, 4] = m2 + mu2
    return m


@pytest.mark.paper
def test_printed_eq10_agrees_with_lagrange_except_the_sign_of_the_secondary_cross_terms():
    """Documentation of the paper (sympy on its printed equations), not a test of ujfmu's computations.

    Eq. (10) agrees with Lagrange's equations from Eq. (4) in every entry but one: one of disc 2's two cross
    terms has the wrong sign whichever sign of the speed ratio r = dtheta2/dtheta1 is read into (mu - 1).
    With Eq. (5)'s reading, (mu - 1) = r, it is M_theta,X2. We use Eq. (4)."""
    derived = _derived_mass_matrix()
    with_ratio = sp.Matrix(sp.simplify(derived - _printed_mass_matrix(ratio, f)))
    assert with_ratio[0, 3] == sp.simplify(-2 * mu2 * e * ratio * sp.sin(f))
    assert with_ratio[0, 4] == 0
    with_minus_ratio = sp.Matrix(sp.simplify(derived - _printed_mass_matrix(-ratio, f)))
    assert with_minus_ratio[0, 3] == 0
    assert with_minus_ratio[0, 4] == sp.simplify(2 * mu2 * e * ratio * sp.cos(f))
    for diff in (with_ratio, with_minus_ratio):
        diff[0, 3] = diff[3, 0] = diff[0, 4] = diff[4, 0] = 0
        assert diff == sp.zeros(5, 5)


@pytest.mark.paper
def test_eq5_cross_terms_agree_with_lagrange_when_mu_minus_1_is_the_speed_ratio():
    """Documentation of the paper (sympy on its printed equations), not a test of ujfmu's computations.

    Eq. (5)'s last term -m_u2 e (mu - 1)(sin theta2 X2' - cos theta2 Y2') theta1' is the derived one with
    (mu - 1) = r, so Eq. (5) and Eq. (10) disagree on M_theta,X2."""
    derived = _derived_mass_matrix()
    assert sp.simplify(derived[0, 3] - (-mu2 * e * ratio * sp.sin(f))) == 0
    assert sp.simplify(derived[0, 4] - (mu2 * e * ratio * sp.cos(f))) == 0
