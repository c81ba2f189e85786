"""Classical fixed-step RK4 over one communication step (standard library only).

For the models whose input shaft follows a prescribed angle (``integrate_drive``), over one communication step
the input angle is phi(t) = phi0 + w0 t + alpha t^2 / 2 (speed extrapolated linearly from the host's omega_in and
its backward difference); every other input is held. The torque-driven variants carry the input shaft in their
state and hold every input (``integrate_held``). ``integrate_time`` states the scheme readably; the two the FMUs
run compute the same numbers with the stage arithmetic written out per state component (``unrolled``).
"""

import math
import sys
from collections.abc import Callable, Sequence
from pathlib import Path

from . import rk4_unrolled

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
    DoubleCardanDriveline and the TwinJeffcottRotor's RK4 keep the sum natural + forcing (with the max their errors
    grow 16x and 10x, past a scenario tolerance and the energy audit's bound: see their ``rate_bound``); the
    speed-driven TwinJeffcottRotor's FMU steps with its exponential integrator instead (``model.integrate``), whose
    free modes are exact, so its own rule resolves only the remainder's rates.
    """
    return max(natural, forcing)


#: the relative rounding of a double
_EPS = sys.float_info.epsilon


def kept_substep(h: float, kept: float, t: float, n: int) -> float:
    """``kept`` (the substep length a multistep method's history or a step operator was made for) where this step's
    substep h (of n) differs from it by no more than the rounding of the times a host computes its steps from,
    |h - kept| <= 8 eps (|t| + n h) / n (fmpy's simulate_fmu steps t_(k+1) - t_k with t_k = k dt, which differ
    from dt in their last bits), so the history and its operators carry on; else h."""
    return kept if abs(h - kept) <= 8.0 * _EPS * (abs(t) + n * h) / n else h

#: more substeps than this in one communication step means parameters far outside any real driveline (or a huge
#: step): the step is refused with a message instead of keeping the host busy for hours
MAX_SUBSTEPS = 100_000


class TooManySubsteps(ValueError):
    """A step that needs more than ``MAX_SUBSTEPS`` substeps (:func:`substeps`); its ``rate`` [1/s] the fastest."""

    def __init__(self, message: str, rate: float):
        super().__init__(message)
        self.rate = rate


def substeps(rate: float, h: float, max_substeps: int = MAX_SUBSTEPS) -> int:
    """Number of RK4 substeps for a step h so that each is at most RATE_STEP / rate long; TooManySubsteps (a
    ValueError) above max_substeps (or for a non-finite rate)."""
    n = h * rate / RATE_STEP
    if n <= 1.0:
        return 1
    if not n <= max_substeps:
        raise TooManySubsteps(f"a step of {h!r} s needs {n:.3g} substeps (each at most {RATE_STEP} / rate long) for "
                              f"the model's fastest rate {rate:.6g} 1/s, more than the {max_substeps} allowed: check "
                              "the stiffness, damping and inertia parameters, and joint angles near 90 deg (a joint's "
                              "speed ratio, up to 1/cos(angle), scales the stiffness its shafts feel) (a mode this "
                              "fast is far beyond what the step resolves; a smaller communication step takes fewer "
                              "substeps each, not fewer in all)", rate)
    return math.ceil(n)


def integrate(derivatives: Callable, y: Sequence[float], t_span: float,
        n: int, phi0: float, w0: float, alpha: float) -> list:
    """Advance y over t_span with n classical RK4 substeps of y' = derivatives(phi(t), w(t), y)."""
    def rates(p, t, y, phi, w, alpha, tau_load):
        return derivatives(phi, w, y)
    return list(integrate_drive(rates, None, 0.0, y, t_span, n, phi0, w0, alpha, 0.0))


def integrate_time(rates: Callable, y: Sequence[float], t_span: float, n: int) -> list:
    """Advance y over t_span with n classical RK4 substeps of y' = rates(t, y), t counted from the step's start.

    The readable statement of the scheme: per substep of h from t, k1 = f(t, y), k2 = f(t + h/2, y + h/2 k1),
    k3 = f(t + h/2, y + h/2 k2), k4 = f(t + h, y + h k3), y <- y + h/6 (k1 + 2 (k2 + k3) + k4).
    :func:`integrate_held` and :func:`integrate_drive` (what the FMUs run) compute exactly the same numbers.
    """
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


def integrate_held(derivatives: Callable, p, t0: float, u, y: Sequence[float], t_span: float, n: int,
        k1: Sequence[float] | None = None) -> tuple:
    """:func:`integrate_time` of y' = derivatives(p, t0 + t, y, u), the inputs u held over the step (the model
    protocol's ``derivatives``), with the stage arithmetic unrolled over the state (:func:`unrolled`).

    k1: derivatives(p, t0, y, u) if the caller has it already (it is not evaluated again)."""
    return unrolled("held", len(y))(derivatives, p, t0, u, y, t_span, n, k1)


def integrate_drive(derivatives: Callable, p, t0: float, y: Sequence[float], t_span: float, n: int,
        phi0: float, w0: float, alpha: float, tau_load: float) -> tuple:
    """:func:`integrate_time` of y' = derivatives(p, t0 + t, y, phi(t), w(t), alpha, tau_load) under the input
    motion phi(t) = phi0 + t (w0 + alpha t / 2), w(t) = w0 + alpha t (the protocol's ``drive_derivatives``),
    with the stage arithmetic unrolled over the state (:func:`unrolled`)."""
    return unrolled("drive", len(y))(derivatives, p, t0, y, t_span, n, phi0, w0, alpha, tau_load)


#: per kind of stage evaluation: the integrator's parameters, the right-hand side's call at stage time ``{t}``,
#: state ``{y}`` and input motion ``{phi}``, ``{w}``, and the input motion at stage time ``{t}`` (drive only)
_KINDS = {
    "held": ("derivatives, p, t0, u, y, t_span, n, k1=None", "derivatives(p, t0 + {t}, {y}, u)", None),
    "drive": ("derivatives, p, t0, y, t_span, n, phi0, w0, alpha, tau_load, k1=None",
              "derivatives(p, t0 + {t}, {y}, {phi}, {w}, alpha, tau_load)",
              "{phi}, {w} = phi0 + {t} * (w0 + 0.5 * alpha * {t}), w0 + alpha * {t}"),
}
#: the state sizes of the models (Motor 3, MotorController 1, RingCoupling 2 and 4, CardanJoint torque-driven 2,
#: DoubleCardanDriveline 4 and 6, TwinJeffcottRotor 14 and 16): ``rk4_unrolled`` holds an integrator of each kind
#: for each
SIZES = (1, 2, 3, 4, 6, 14, 16)

_UNROLLED_SOURCE = """

def {name}({params}):
    h = t_span / n
    hh, h6 = 0.5 * h, h / 6.0
    s = 0.0
    {motion_s}
    for _ in range(n):
        sm, se = s + 0.5 * h, s + h
        {motion_m}
        {motion_e}
        {y} = y
        if k1 is None:   # else: the first stage's rates, given
            k1 = {f1}
        {k1} = k1
        k1 = None
        k = {f2}
        {k2} = k
        k = {f3}
        {k3} = k
        k = {f4}
        {k4} = k
        y = {y_next}
        s = se
        {motion_next}
    return y
"""


def unrolled(kind: str, size: int) -> Callable:
    """The RK4 integrator of :func:`integrate_time`'s scheme for a state of ``size`` floats and a right-hand side
    called as ``_KINDS[kind]`` says (k1: the rates at the start, when the caller has them), its stage arithmetic
    written out per state component (no per-component loop, list or zip: about 2.5x less time than the loops
    outside the right-hand side): ``rk4_unrolled.<kind>_<size>``, generated from ``_UNROLLED_SOURCE`` by
    :func:`unrolled_source` (the same operations in the same order as :func:`integrate_time`, so the same numbers
    bit for bit: tests). A size not in SIZES gets :func:`integrate_time` with the same call."""
    return getattr(rk4_unrolled, f"{kind}_{size}", None) or _LOOPED[kind]


def _held_looped(derivatives, p, t0, u, y, t_span, n, k1=None):
    return tuple(integrate_time(lambda s, y: derivatives(p, t0 + s, y, u), y, t_span, n))


def _drive_looped(derivatives, p, t0, y, t_span, n, phi0, w0, alpha, tau_load, k1=None):
    def rates(s, y):
        return derivatives(p, t0 + s, y, phi0 + s * (w0 + 0.5 * alpha * s), w0 + alpha * s, alpha, tau_load)
    return tuple(integrate_time(rates, y, t_span, n))


_LOOPED = {"held": _held_looped, "drive": _drive_looped}


def unrolled_source(sizes: Sequence[int] = SIZES) -> str:
    """The text of ``rk4_unrolled.py``: one integrator per kind of ``_KINDS`` and size in sizes."""
    header = ('"""Classical RK4 with the stage arithmetic written out per state component, one function per kind '
              'and state size\n(``ujfmu.fmu.rk4.unrolled``). Generated by ``ujfmu.fmu.rk4.unrolled_source``: do '
              'not edit; regenerate with\n``python -m ujfmu.fmu.rk4`` (a test checks that this file is what it '
              'generates).\n"""\n')
    return header + "".join(_unrolled_function(kind, size) for kind in _KINDS for size in sizes)


def _unrolled_function(kind: str, size: int) -> str:
    """The source of ``<kind>_<size>``: ``_UNROLLED_SOURCE`` with the stages written out for ``size`` components."""
    params, call, motion = _KINDS[kind]

    def tuple_of(terms):   # one line up to 2 components, else one component a line
        terms = list(terms)
        if len(terms) <= 2:
            return "(" + ", ".join(terms) + ",)"
        return "(\n" + "".join(f"            {term},\n" for term in terms) + "        )"

    def names(prefix):
        return ", ".join(f"{prefix}{i}" for i in range(size)) + ","

    def stage(c, k):
        return tuple_of(f"y{i} + {c} * {k}{i}" for i in range(size))

    def at(t, y, phi, w):
        return call.format(t=t, y=y, phi=phi, w=w)
    motions = (["", "", "", ""] if motion is None else
               [motion.format(t=t, phi=phi, w=w) for t, phi, w in (("s", "phi_s", "w_s"), ("sm", "phi_m", "w_m"),
                                                                    ("se", "phi_e", "w_e"))]
               + ["phi_s, w_s = phi_e, w_e"])
    y_next = tuple_of(f"y{i} + h6 * (a{i} + 2.0 * (b{i} + c{i}) + d{i})" for i in range(size))
    text = _UNROLLED_SOURCE.format(
        name=f"{kind}_{size}", params=params, motion_s=motions[0], motion_m=motions[1], motion_e=motions[2],
        motion_next=motions[3], y=names("y"), k1=names("a"), k2=names("b"), k3=names("c"), k4=names("d"),
        f1=at("s", "y", "phi_s", "w_s"), f2=at("sm", stage("hh", "a"), "phi_m", "w_m"),
        f3=at("sm", stage("hh", "b"), "phi_m", "w_m"), f4=at("se", stage("h", "c"), "phi_e", "w_e"), y_next=y_next)
    return "\n".join(line.rstrip() for line in text.splitlines() if line.strip() or not line) + "\n"


if __name__ == "__main__":
    (Path(__file__).parent / "rk4_unrolled.py").write_text(unrolled_source())
