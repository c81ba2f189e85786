"""Signal analysis helpers: order amplitudes and spectra recover known signals."""

import math

import numpy as np
import pytest

from ujfmu.analysis import amplitude_spectrum, order_amplitudes


def test_order_amplitudes_recover_harmonics_of_a_varying_speed():
    """Along the angle, not time: a ramp in speed does not smear the orders."""
    t = np.linspace(0.0, 2.0, 4001)
    angle = 30.0 * t + 10.0 * t ** 2
    signal = 0.3 + 2.0 * np.cos(angle - 0.4) + 0.5 * np.cos(2 * angle + 1.0) + 0.01 * np.sin(4 * angle)
    amp, phase = order_amplitudes(angle, signal, [1, 2, 3, 4])
    np.testing.assert_allclose(amp, [2.0, 0.5, 0.0, 0.01], atol=1e-12)
    assert phase[0] == pytest.approx(0.4) and phase[1] == pytest.approx(-1.0)


def test_amplitude_spectrum_peak_is_the_sinusoid_amplitude():
    t = np.arange(20000) * 1e-3
    freq, amp = amplitude_spectrum(t, 5.0 + 0.7 * np.sin(2 * math.pi * 12.5 * t))
    assert freq[np.argmax(amp)] == pytest.approx(12.5)
    assert amp.max() == pytest.approx(0.7, rel=1e-3)
