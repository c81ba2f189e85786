"""ujfmu.models.load.model: limits of the smooth torque law."""

import numpy as np
import pytest

from ujfmu.models.load.model import load_torque


def test_limits_far_from_rest():
    w = 200.0
    assert load_torque(w, 0.3, 0.0, 0.0, 0.1) == pytest.approx(0.3, rel=1e-6)
    assert load_torque(w, 0.0, 0.01, 0.0, 0.1) == pytest.approx(2.0)
    assert load_torque(w, 0.0, 0.0, 0.017, 0.1) == pytest.approx(0.017 * w * w, rel=1e-6)  # Brutti's M_u


def test_odd_and_smooth_through_rest():
    w = np.linspace(-2, 2, 4001)
    tau = np.array([load_torque(x, 0.3, 0.01, 0.02, 0.5) for x in w])
    np.testing.assert_allclose(tau, -tau[::-1], atol=1e-15)
    assert load_torque(0.0, 0.3, 0.01, 0.02, 0.5) == 0.0
    d2 = np.diff(tau, 2)
    assert np.max(np.abs(np.diff(d2))) < 1e-6  # no kink: third differences stay small
