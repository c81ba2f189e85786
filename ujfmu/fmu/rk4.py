"""Classical fixed-step RK4 for the models whose input shaft follows a prescribed angle (standard library only).

Over one communication step the input angle is phi(t) = phi0 + w0 t + alpha t^2 / 2 (speed extrapolated linearly
from the host's omega_in and its backward difference); every other input is held.
The torque-driven variants carry the input shaft in their state and use integrate_time with every input held.
"""

import math
from collections.abc import Callable, Sequence

#: substep length times the fastest rate of the model (natural frequencies, decay rates, forcing harmonics).
#: At w h = 0.5 classical RK4 keeps a free oscillation's amplitude to 1 - (w h)^6/144 = 1 - 1.1e-4 per substep
#: (0.14% per period) and its frequency to (w h)^4/120 = 0.05%, and the rates fed in are upper bounds (the
#: models' natural_rate bounds, 4x the running speed), so the actual modes see less. Against 0.15, every
#: scenario's agreement with its reference is the same to the printed digits (`ujfmu check`), the worst scenario
#: error stays below 0.81 of its tolerance, and the FMUs run 1.3-2x faster.
RATE_STEP = 0.5


def fastest_rate(natural: float, forcing: float) -> float:
    """The rate [1/s] the RK4 substeps resolve: max(natural, forcing), not their sum.

    natural bounds |lambda| over the eigenvalues of the model's Jacobian (its free modes and decay rates, at any
    angle of the input shaft); forcing bounds the frequencies with which the inputs and the joints' kinematics drive
    it (4|omega| covers harmonics 1x, 2x and the 4x of amplitude q^2, q the joint's modulation depth).
    Stability of classical RK4 depends on the Jacobian alone: h |lambda| <= 2.83 on the imaginary axis, 2.78 on the
    negative real one; RATE_STEP = 0.5 keeps 5.6x from it. Accuracy: RK4's local error on a component of frequency
    w is of relative size (w h)^5 / 120, so each part needs w h <= RATE_STEP on its own. The kinematics modulate the
    free modes (parametric forcing) into combination frequencies natural +- 2|omega| <= 1.5 max(natural, forcing),
    whose amplitudes are O(q) of the mode's: at RATE_STEP they take (0.75)^5 / 120 = 2e-3 relative error per
    substep of an O(q) part, below the 2.6e-4 of a full-amplitude part at w h = 0.5 once q < 0.13.
    Whether that is accurate enough is decided by the tolerances the model must meet, which the error scales
    with h^4: the RingCoupling uses it (every scenario's agreement the same to the printed digits); the
    DoubleCardanDriveline and the TwinJeffcottRotor keep the sum natural + forcing (with the max their errors grow
    16x and 10x, past a scenario tolerance and the energy audit's bound: see their ``rate_bound``).
    """
    return max(natural, forcing)


#: more substeps than this in one communication step means parameters far outside any real driveline (or a huge
#: step): the step is refused with a message instead of keeping the host busy for hours
MAX_SUBSTEPS = 100_000


def substeps(rate: float, h: float, max_substeps: int = MAX_SUBSTEPS) -> int:
    """Number of RK4 substeps for a step h so that each is at most RATE_STEP / rate long; ValueError above
    max_substeps (or for a non-finite rate)."""
    n = h * rate / RATE_STEP
    if not n <= max_substeps:
        raise ValueError(f"a step of {h!r} s needs {n:.3g} RK4 substeps for the model's fastest rate {rate:.6g} 1/s "
                         f"(allowed at most {max_substeps}): reduce the communication step, or check the "
                         "stiffness, damping and inertia parameters")
    return max(1, math.ceil(n))


def integrate(derivatives: Callable, y: Sequence[float], t_span: float,
        n: int, phi0: float, w0: float, alpha: float) -> list:
    """Advance y over t_span with n classical RK4 substeps of y' = derivatives(phi(t), w(t), y)."""
    def rates(t, y):
        return derivatives(phi0 + t * (w0 + 0.5 * alpha * t), w0 + alpha * t, y)
    return integrate_time(rates, y, t_span, n)


def integrate_time(rates, y, t_span: float, n: int) -> list:
    """Advance y over t_span with n classical RK4 substeps of y' = rates(t, y), t counted from the step's start."""
    h = t_span / n
    t = 0.0
    for _ in range(n):
        tm, te = t + 0.5 * h, t + h
        k1 = rates(t, y)
        k2 = rates(tm, [a + 0.5 * h * b for a, b in zip(y, k1)])
        k3 = rates(tm, [a + 0.5 * h * b for a, b in zip(y, k2)])
        k4 = rates(te, [a + h * b for a, b in zip(y, k3)])
        h6 = h / 6.0
        y = [a + h6 * (b + 2.0 * (c + d) + e) for a, b, c, d, e in zip(y, k1, k2, k3, k4)]
        t = te
    return y
