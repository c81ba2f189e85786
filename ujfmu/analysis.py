"""Signal analysis of results (numpy): running-speed harmonics (order amplitudes), amplitude spectra, orbits."""

import numpy as np


def order_amplitudes(angle, signal, orders):
    """Amplitudes of the given running-speed orders of signal, sampled along the running angle [rad].

    Least-squares fit signal = c0 + sum_k a_k cos(k angle) + b_k sin(k angle) over the samples; amplitude
    sqrt(a_k^2 + b_k^2). Exact for a periodic steady state sampled over whole revolutions, and robust to a slowly
    varying speed because it works on the angle, not on time. Returns (amplitudes, phases) with
    signal ~ amplitude cos(k angle - phase).
    """
    _, amplitudes, phases = order_fit(angle, signal, orders)
    return amplitudes, phases


def order_fit(angle, signal, orders):
    """(c0, amplitudes, phases) of the least-squares fit signal = c0 + sum_k amplitude_k cos(k angle - phase_k)."""
    angle, signal = np.asarray(angle, float), np.asarray(signal, float)
    columns = [np.ones_like(angle)]
    for k in orders:
        columns += [np.cos(k * angle), np.sin(k * angle)]
    coef = np.linalg.lstsq(np.column_stack(columns), signal, rcond=None)[0]
    a, b = coef[1::2], coef[2::2]
    return coef[0], np.hypot(a, b), np.arctan2(b, a)


def amplitude_spectrum(time, signal):
    """(frequency [Hz], single-sided amplitude) of a uniformly sampled signal, mean removed, Hann window with its
    coherent gain corrected, so a sinusoid of amplitude A shows a peak of about A."""
    time, signal = np.asarray(time, float), np.asarray(signal, float)
    n = len(signal)
    window = np.hanning(n)
    spectrum = np.fft.rfft((signal - signal.mean()) * window)
    amplitude = 2.0 * np.abs(spectrum) / window.sum()
    return np.fft.rfftfreq(n, d=(time[-1] - time[0]) / (n - 1)), amplitude


def decay_rates(rhs, y0, step=1e-7):
    """Decay rates -Re(lambda) [1/s] of the linearisation of y' = rhs(y) at y0, slowest first: the eigenvalues
    lambda of the Jacobian (central differences of relative size step). A transient of mode i falls as
    exp(-rate_i t), so the slowest rate bounds how long a run needs to reach its steady state."""
    y0 = np.asarray(y0, float)
    jac = np.empty((len(y0), len(y0)))
    for i in range(len(y0)):
        d = step * max(1.0, abs(y0[i]))
        hi, lo = y0.copy(), y0.copy()
        hi[i] += d
        lo[i] -= d
        jac[:, i] = (np.asarray(rhs(hi), float) - np.asarray(rhs(lo), float)) / (2.0 * d)
    return np.sort(-np.linalg.eigvals(jac).real)
