"""Drive motor: rotor inertia with a PI speed controller and a torque limit, or an ideal speed source.

    J * domega/dt = tau_motor - tau_load,   dphi/dt = omega
    e = omega_ref(t) - omega,  u = Kp*e + Ki*I,  tau_motor = clamp(u, -tau_max, tau_max)
    dI/dt = e, except while the output is saturated and e drives it further into saturation
            (conditional integration, the usual anti-windup)

Speed profiles omega_ref(t) (Feng et al. accelerate the driving shaft at alpha = 30 rad/s^2 from rest):
    CONSTANT: omega_ref = omega_set
    RAMP:     omega_ref = min(accel * t, omega_set) from t = 0, at rest before
    STEP:     omega_ref = omega_initial before t_step, omega_set from t_step on
    SLEW:     omega_ref = omega_initial before t_step, then towards omega_set at accel (up or down), omega_set once
              reached (a braking or a speed change at a finite rate)
Numerics (PI mode, :func:`integrate`): exact to round-off while the loop is linear over the step (the torque
within its limit all along, :func:`pi_torque_bound`; no profile corner inside), else classical RK4 (order 4). The
MotorController (:meth:`Controller.integrate`, the measured speed held): its integral in closed form while the law
is linear over the step (:func:`controller_torque_peak`), else one RK4 step.
Source: none; a generic drive (PI speed control with conditional-integration anti-windup, the textbook law).
Standard library only: runs inside the Motor and MotorController FMUs (``Controller``: the PI controller without
its rotor, for the torque-driven joints).
"""

import math
from dataclasses import dataclass, field
from typing import NamedTuple

from ...fmu import rk4, series
from ..protocol import TIME_ROUNDING, reached

CONSTANT, RAMP, STEP, SLEW = 0, 1, 2, 3


def speed_reference(t: float, profile: int, omega_set: float,
        accel: float, t_step: float, omega_initial: float) -> tuple:
    """(omega_ref, alpha_ref, phi_ref): reference speed, its derivative and its integral from t = 0."""
    if profile == RAMP:
        if not reached(t, 0.0):   # at rest until the ramp starts (a run may start before t = 0)
            return 0.0, 0.0, 0.0
        t_end = omega_set / accel
        if not reached(t, t_end):   # the corners as corner_inside places them (a host's rounding of its times)
            return accel * t, accel, 0.5 * accel * t * t
        return omega_set, 0.0, 0.5 * accel * t_end * t_end + omega_set * (t - t_end)
    if profile == STEP:
        if not reached(t, t_step):   # a step meant at a communication point happens there
            return omega_initial, 0.0, omega_initial * t
        return omega_set, 0.0, omega_initial * t_step + omega_set * (t - t_step)
    if profile == SLEW:
        if not reached(t, t_step):
            return omega_initial, 0.0, omega_initial * t
        rate = accel if omega_set >= omega_initial else -accel
        span = abs(omega_set - omega_initial) / accel
        if not reached(t, t_step + span):
            s = t - t_step
            return omega_initial + rate * s, rate, omega_initial * t + 0.5 * rate * s * s
        return (omega_set, 0.0,
                omega_initial * (t_step + span) + 0.5 * rate * span * span + omega_set * (t - t_step - span))
    return omega_set, 0.0, omega_set * t


def pi_torque(error: float, integral: float, kp: float, ki: float, tau_max: float) -> tuple:
    """(tau_motor, dI/dt) of the PI law with clamp and conditional-integration anti-windup."""
    u = kp * error + ki * integral
    if u > tau_max:
        return tau_max, (0.0 if error > 0.0 else error)
    if u < -tau_max:
        return -tau_max, (0.0 if error < 0.0 else error)
    return u, error


# --- the model protocol (ujfmu.models.protocol) -----------------------------------------------------------------

@dataclass(slots=True)
class ControllerParameters:
    """The MotorController FMU's parameters (names as declared there): the PI controller's and the profile's."""

    Kp: float
    Ki: float
    tau_max: float
    profile: int
    omega_set: float
    accel: float
    t_step: float
    omega_initial: float
    #: the drive torque at the start [N.m]: the PI integral starts at tau_initial / Ki (:func:`start_integral`)
    tau_initial: float = 0.0
    #: :func:`profile_corners`
    corners: tuple = field(init=False, repr=False, default=())
    #: (corner, the host's rounding there, ``TIME_ROUNDING`` max(1, |corner|)) of each corner (:func:`corners_inside`)
    corner_margins: tuple = field(init=False, repr=False, default=())
    #: the last corner (-inf without one): no corner lies inside a step that starts at or after it
    last_corner: float = field(init=False, repr=False, default=-math.inf)
    #: (t, :func:`reference` at t) of the last time asked, a pure cache (a step starts at the time of the last read)
    reference_memo: tuple = field(init=False, repr=False, compare=False, default=(math.nan, None))

    def __post_init__(self):
        self.corners = profile_corners(self)
        self.corner_margins = tuple((c, TIME_ROUNDING * max(1.0, abs(c))) for c in self.corners)
        self.last_corner = max(self.corners, default=-math.inf)


@dataclass(slots=True, kw_only=True)
class Parameters(ControllerParameters):
    """The Motor FMU's parameters (names as declared there): the controller's, the rotor inertia [kg.m2] and the
    ideal speed source switch."""

    J_rotor: float
    ideal_speed_source: bool = False
    #: (h, :func:`pi_propagator`'s rows) of the last step length, a pure cache (one float compared per step)
    propagator_memo: tuple | None = field(default=None, init=False, repr=False, compare=False)


class State(NamedTuple):
    """Rotor angle [rad] and speed [rad/s] and the controller's integral of the speed error [rad]; an ideal speed
    source holds the angle offset that makes its angle 0 at the start in phi (nothing is integrated)."""

    phi: float
    omega: float
    integral: float


class Inputs(NamedTuple):
    """The reaction torque of the driven machine [N.m], held over a step."""

    tau_load: float


def reference(p: Parameters, t: float) -> tuple:
    """(omega_ref, alpha_ref, phi_ref) of the profile at time t (:func:`speed_reference`), kept on p for the last t
    (``reference_memo``)."""
    memo = p.reference_memo
    if memo[0] == t:
        return memo[1]
    value = speed_reference(t, p.profile, p.omega_set, p.accel, p.t_step, p.omega_initial)
    p.reference_memo = t, value
    return value


def kinematic(p: Parameters) -> bool:
    """The ideal speed source: the rotor follows the profile, nothing to integrate."""
    return p.ideal_speed_source


def start_integral(p: ControllerParameters) -> float:
    """The PI integral at the start, I0 = tau_initial / Ki: at the reference speed (e = 0) the law gives
    Kp e + Ki I0 = tau_initial, a drive already delivering the torque its load takes (0 without an integral)."""
    return p.tau_initial / p.Ki if p.Ki else 0.0


def initial_state(p: Parameters, t: float, u: Inputs) -> State:
    """Rotor at angle 0 and the reference speed, integral :func:`start_integral` (ideal source: the offset
    -phi_ref(t))."""
    omega_ref, _, phi_ref = reference(p, t)
    return State(-phi_ref if p.ideal_speed_source else 0.0, omega_ref, start_integral(p))


def derivatives(p: Parameters, t: float, y: State, u: Inputs) -> tuple:
    """J domega/dt = tau_motor - tau_load, dphi/dt = omega, dI/dt from :func:`pi_torque`."""
    omega_ref = reference(p, t)[0]
    tau, d_integral = pi_torque(omega_ref - y[1], y[2], p.Kp, p.Ki, p.tau_max)
    return y[1], (tau - u.tau_load) / p.J_rotor, d_integral


#: substep length times the closed loop's fastest pole: 0.2, tighter than rk4.RATE_STEP, keeps the PI start-ups'
#: RK4 error well below the 1e-3 of their range they are checked to
POLE_STEP = 0.2


def rate_bound(p: Parameters, y: State, omega_max: float) -> float:
    """The closed loop J s^2 + Kp s + Ki = 0 has |lambda| <= Kp/J + sqrt(Ki/J) (both roots), scaled so that a
    substep (rk4.RATE_STEP / rate) is POLE_STEP / |lambda| long."""
    return (p.Kp / p.J_rotor + math.sqrt(p.Ki / p.J_rotor)) * (rk4.RATE_STEP / POLE_STEP)


def profile_corners(p: ControllerParameters) -> tuple:
    """The times where omega_ref(t) leaves one linear piece for the next, in order (the ramp's start 0 and end
    omega_set/accel, the step time t_step, the slew's start t_step and end; none for the constant profile): between
    corners omega_ref(t) = omega_ref(t0) + alpha_ref (t - t0)."""
    if p.profile == RAMP:
        return 0.0, p.omega_set / p.accel
    if p.profile == STEP:
        return (p.t_step,)
    if p.profile == SLEW:
        return p.t_step, p.t_step + abs(p.omega_set - p.omega_initial) / p.accel
    return ()


def changes_by(p: ControllerParameters, t: float) -> bool:
    """The outputs at time t differ from those at 0 at the same state and inputs: the reference speed or its
    slope moved (an ideal source's angle is the reference's integral less its value at the start)."""
    return speed_reference(0.0, p.profile, p.omega_set, p.accel, p.t_step, p.omega_initial)[:2] != \
        speed_reference(t, p.profile, p.omega_set, p.accel, p.t_step, p.omega_initial)[:2]


def output_jumps(p: ControllerParameters) -> tuple:
    """The times where the outputs jump: the step profile's t_step (omega_ref jumps, and the PI torque with it, or
    an ideal source's speed); none for the others, whose reference is continuous."""
    return (p.t_step,) if p.profile == STEP and p.omega_set != p.omega_initial else ()


def corners_inside(p: ControllerParameters, t: float, h: float) -> list:
    """The corners of the profile (:func:`profile_corners`) inside (t, t + h), farther than a host's rounding of
    its times from either end (``protocol.reached``: a corner meant at a communication point is at the step's end,
    not inside it), in order."""
    return [corner for corner, margin in p.corner_margins if t + margin < corner < t + h - margin]


def corner_inside(p: ControllerParameters, t: float, h: float) -> bool:
    """True if a corner of the profile lies inside (t, t + h) (:func:`corners_inside`; none once t is past the
    last, which every step of a run's steady part is)."""
    if t >= p.last_corner:
        return False
    for corner, margin in p.corner_margins:
        if t + margin < corner < t + h - margin:
            return True
    return False


def split_at_corners(step, p: ControllerParameters, t: float, h: float, y: tuple, u: tuple) -> tuple:
    """step(p, t, h, y, u) over (t, t + h) taken piece by piece between the profile's corners inside it: on each
    piece the reference is one linear piece, which the exact steps need (one RK4 substep across a step profile's
    jump at 0.1005 s in a 1 ms step had left 0.9% of the step in the speed)."""
    ends = corners_inside(p, t, h) + [t + h]
    start = t
    for end in ends:
        y = step(p, start, end - start, y, u)
        start = end
    return y


#: (J_rotor, Kp, Ki, h) -> the propagator rows of :func:`pi_propagator`; bounded (a sweep may visit many)
_PROPAGATORS = {}


def pi_propagator(p: Parameters, h: float) -> tuple:
    """Rows P (3 x 7) of the exact step of the unsaturated PI loop with a reference linear in time, tau_load held:

        x = (phi, omega, I),  x' = A x + F (c + d s),   A = [[0, 1, 0], [0, -Kp/J, Ki/J], [0, -1, 0]],
        F c = (0, c_w, c_I):  c = ((Kp r0 - tau_load)/J, r0),  d = (Kp a / J, a)   (omega_ref = r0 + a s),
        x(h) = P (x(0), c, d),  P = the first three rows of exp(M h),  M = [[A, F, 0], [0, 0, 1], [0, 0, 0]]

    (M augments x with c + d s and d, whose derivatives are d and 0: Van Loan's block exponential). Computed in
    plain Python (``series.expm``) once per (J_rotor, Kp, Ki, h), kept on p for the last h."""
    memo = p.propagator_memo
    if memo is not None and memo[0] == h:
        return memo[1]
    key = (p.J_rotor, p.Kp, p.Ki, h)
    rows = _PROPAGATORS.get(key)
    if rows is None:
        m = [[0.0] * 7 for _ in range(7)]
        m[0][1] = 1.0
        m[1][1], m[1][2], m[1][3] = -p.Kp / p.J_rotor, p.Ki / p.J_rotor, 1.0
        m[2][1], m[2][4] = -1.0, 1.0
        m[3][5], m[4][6] = 1.0, 1.0
        rows = tuple(tuple(row) for row in series.expm(tuple(map(tuple, m)), h)[:3])
        if len(_PROPAGATORS) >= 64:
            _PROPAGATORS.clear()
        _PROPAGATORS[key] = rows
    p.propagator_memo = h, rows
    return rows


def pi_torque_bound(p: Parameters, h: float, y0: tuple, y1: tuple, r0: float, a: float, tau_load: float) -> float:
    """An upper bound of |u(s)|, u = Kp e + Ki I, over a step of h of the unsaturated loop from y0 to y1 (the
    reference r0 + a s, tau_load held). With e = omega_ref - omega the loop gives

        u' = -(Kp/J) u + Ki e + Kp a + Kp tau_load / J,    u'' + (Kp/J) u' + (Ki/J) u = (Ki/J) u*,  u* = J a + tau_load

    so v = u - u* is a damped oscillator whose energy (Ki/J) v^2 + v'^2 never grows (its rate is -2 (Kp/J) v'^2):
    |u''| = |(Kp/J) v' + (Ki/J) v| <= sqrt((Kp/J)^2 + Ki/J) sqrt((Ki/J) v(0)^2 + v'(0)^2) = M2 over the step, and
    a function deviates from its chord by at most h^2/8 max|u''|: |u| <= max(|u(0)|, |u(h)|) + h^2 M2 / 8."""
    kj, w2 = p.Kp / p.J_rotor, p.Ki / p.J_rotor
    e0 = r0 - y0[1]
    u0 = p.Kp * e0 + p.Ki * y0[2]
    u1 = p.Kp * (r0 + a * h - y1[1]) + p.Ki * y1[2]
    v = u0 - p.J_rotor * a - tau_load
    dv = -kj * u0 + p.Ki * e0 + p.Kp * a + kj * tau_load
    curvature = math.sqrt((kj * kj + w2) * (w2 * v * v + dv * dv))
    return max(abs(u0), abs(u1)) + 0.125 * h * h * curvature


def integrate(p: Parameters, t: float, h: float, y: State, u: Inputs) -> tuple:
    """The PI motor's step, tau_load held: taken piece by piece between the profile's corners inside (t, t + h)
    (:func:`split_at_corners`); on a piece, exact (to round-off) where the torque stays within its limit all along
    (:func:`pi_torque_bound` <= tau_max): y(t + h) = P (y, c, d) of :func:`pi_propagator`; elsewhere (the limit
    reached or crossed) the classical RK4 substeps of :func:`rate_bound` (order 4), as the FMU's default."""
    if corner_inside(p, t, h):
        return split_at_corners(integrate, p, t, h, y, u)
    memo = p.propagator_memo
    if memo is not None:   # a step that differs from the last by the rounding of the host's times only: the same
        h = rk4.kept_substep(h, memo[0], t, 1)
    r0, a, _ = reference(p, t)
    tau_load, kp, j = u[0], p.Kp, p.J_rotor
    cw, dw = (kp * r0 - tau_load) / j, kp * a / j
    _, omega, integral = y
    p0, p1, p2 = pi_propagator(p, h)
    y1 = (y[0] + p0[1] * omega + p0[2] * integral + p0[3] * cw + p0[4] * r0 + p0[5] * dw + p0[6] * a,
          p1[1] * omega + p1[2] * integral + p1[3] * cw + p1[4] * r0 + p1[5] * dw + p1[6] * a,
          p2[1] * omega + p2[2] * integral + p2[3] * cw + p2[4] * r0 + p2[5] * dw + p2[6] * a)
    if pi_torque_bound(p, h, y, y1, r0, a, tau_load) <= p.tau_max:
        return y1
    return _RK4_3(derivatives, p, t, u, y, h, rk4.substeps(rate_bound(p, y, 0.0), h))


_RK4_3 = rk4.unrolled("held", 3)


def outputs(p: Parameters, t: float, y: State, u: Inputs) -> dict:
    """Speed, angle and drive torque (ideal source: the profile, and the torque J alpha_ref + tau_load a perfect
    drive delivers; PI: the state and the PI law)."""
    omega_ref, alpha_ref, phi_ref = reference(p, t)
    if p.ideal_speed_source:
        return {"omega_ref": omega_ref, "omega": omega_ref, "phi": phi_ref + y[0],
                "tau_motor": p.J_rotor * alpha_ref + u.tau_load}
    return {"omega_ref": omega_ref, "phi": y[0], "omega": y[1],
            "tau_motor": pi_torque(omega_ref - y[1], y[2], p.Kp, p.Ki, p.tau_max)[0]}


def output_free_inputs(p: Parameters) -> tuple:
    """PI mode: no output depends on tau_load (it enters only domega/dt, so the outputs change with it only after the
    next step); the ideal source's tau_motor = J alpha_ref + tau_load does."""
    return () if p.ideal_speed_source else ("tau_load",)


def load_outputs(p: Parameters, t: float, y: State, u: Inputs) -> dict:
    """The outputs of :func:`outputs` that depend on tau_load: the ideal source's tau_motor; none in PI mode."""
    if p.ideal_speed_source:
        return {"tau_motor": p.J_rotor * reference(p, t)[1] + u.tau_load}
    return {}


#: a set speed [rad/s] past which the drive's advice asks whether rpm was meant (about 9500 rpm: past a Cardan
#: propshaft's usual speeds)
LARGE_SPEED = 1000.0


#: RK4 substeps a 1 ms step of the PI motor may take where its torque limit acts before :func:`advice` says that
#: the run will be slow (each costs about a microsecond)
SLOW_SUBSTEPS = 1000


def advice(p: ControllerParameters) -> list:
    """Warnings on valid parameters likely not meant: a set speed past ``LARGE_SPEED`` (rpm given as rad/s?); an
    ideal source's tau_initial (unused); a PI motor's closed loop so fast (Kp / J_rotor + sqrt(Ki / J_rotor),
    :func:`rate_bound`) that a 1 ms step takes more than ``SLOW_SUBSTEPS`` substeps where the torque limit acts
    (there the exact linear step does not hold)."""
    messages = []
    for name in ("omega_set", "omega_initial") if p.profile in (STEP, SLEW) else ("omega_set",):
        value = getattr(p, name)
        if abs(value) > LARGE_SPEED:
            messages.append(f"{name} = {value:.6g} rad/s is {value * 30.0 / math.pi:.6g} rpm; if the value was meant "
                            f"in rpm, {name} = {value * math.pi / 30.0:.6g} rad/s (the FMUs take SI units)")
    if isinstance(p, Parameters) and p.ideal_speed_source and p.tau_initial:
        messages.append(f"tau_initial = {p.tau_initial:.6g} N.m is not used: an ideal speed source delivers whatever "
                        "torque its profile takes (tau_initial starts a PI drive's integral)")
    if isinstance(p, Parameters) and not p.ideal_speed_source and p.J_rotor > 0.0:
        pole = p.Kp / p.J_rotor + math.sqrt(p.Ki / p.J_rotor)
        substeps = 1e-3 * pole / POLE_STEP
        if substeps > SLOW_SUBSTEPS:
            outcome = ("so a run may take minutes" if substeps <= rk4.MAX_SUBSTEPS else
                       f"more than the {rk4.MAX_SUBSTEPS} a step may take, so such a step is refused")
            messages.append(f"Kp = {p.Kp:.6g} N.m.s/rad and Ki = {p.Ki:.6g} N.m/rad on J_rotor = {p.J_rotor:.6g} kg.m2 "
                            f"make a closed loop as fast as {pole:.3g} 1/s (Kp / J_rotor + sqrt(Ki / J_rotor)): "
                            f"wherever the torque limit tau_max acts, each 1 ms step takes about {substeps:.3g} RK4 "
                            f"substeps to follow it, {outcome}; a PI tuned to the driveline "
                            "(its bandwidth a few times below the first torsional mode) is far slower, and an ideal "
                            "speed source (ideal_speed_source = true) costs nothing")
    return messages


def check(p: Parameters) -> list:
    """The ramp runs from rest up to omega_set >= 0; a starting torque needs an integral to hold it (Ki > 0) and
    lies within the torque limit."""
    problems = []
    if p.profile == RAMP and p.omega_set < 0.0:
        problems.append(f"omega_set = {p.omega_set!r} rad/s is outside its allowed range [0, 1e+04] rad/s for the "
                        "ramp profile (profile = 1), which runs up from rest; to run in reverse, use the ramp between "
                        "two speeds (profile = 3, omega_initial = 0, omega_set < 0) or the step profile (profile = 2)")
    if p.tau_initial and not getattr(p, "ideal_speed_source", False):
        if not p.Ki:
            problems.append(f"tau_initial = {p.tau_initial!r} N.m needs an integral to start from (Ki > 0): the "
                            "PI law with Ki = 0 gives Kp e, 0 at the reference speed (allowed with Ki = 0: only 0); "
                            "give Ki, or tau_initial = 0")
        elif abs(p.tau_initial) > p.tau_max:
            problems.append(f"tau_initial = {p.tau_initial!r} N.m is beyond the drive's torque limit (allowed range "
                            f"[-tau_max, tau_max] = [{-p.tau_max!r}, {p.tau_max!r}] N.m): a drive cannot start "
                            "delivering it")
    return problems


# --- the controller without its rotor (MotorController): a sampled speed controller ----------------------------

def controller_torque_peak(p: ControllerParameters, h: float, e0: float, a: float, integral: float) -> float:
    """max |v(s)| over 0 <= s <= h of the unclamped law v = Kp e + Ki I with the speed held, e = e0 + a s and
    I = integral + e0 s + a s^2 / 2 (dI/dt = e): v is quadratic in s, so its largest magnitude is at an end or at
    its vertex, v'(s*) = Kp a + Ki e(s*) = 0."""
    kp, ki = p.Kp, p.Ki
    v0 = kp * e0 + ki * integral
    v1 = kp * (e0 + a * h) + ki * (integral + h * (e0 + 0.5 * a * h))
    peak = max(abs(v0), abs(v1))
    if ki * a != 0.0:
        s = -(kp * a + ki * e0) / (ki * a)
        if 0.0 < s < h:
            peak = max(peak, abs(kp * (e0 + a * s) + ki * (integral + s * (e0 + 0.5 * a * s))))
    return peak


_RK4_1 = rk4.unrolled("held", 1)
#: relative margin of :func:`clamped_all_along` over the rounding of e and v at RK4's inner stages
CLAMP_MARGIN = 1e-9


def clamped_all_along(p: ControllerParameters, h: float, e0: float, a: float, integral: float, scale: float) -> bool:
    """Whether :func:`pi_torque` holds one limit with the integral frozen over the whole step, e = e0 + a s with the
    speed held: e and v = Kp e + Ki I (I constant) are linear in s, so both ends beyond the limit in the same sense
    (with ``CLAMP_MARGIN`` of scale and tau_max to spare) put every RK4 stage on that branch, dI/dt = 0 at each, and
    the step leaves I as it was: bitwise what the RK4 step gives on a piece of the profile (where a set-speed step
    falls on the step's end, RK4's last stage reads the next piece's speed; this closed form, as the unclamped one,
    keeps the piece's own)."""
    e1 = e0 + a * h
    margin, limit = CLAMP_MARGIN * scale, p.tau_max * (1.0 + CLAMP_MARGIN)
    v0, v1 = p.Kp * e0 + p.Ki * integral, p.Kp * e1 + p.Ki * integral
    return ((e0 > margin and e1 > margin and v0 > limit and v1 > limit)
            or (e0 < -margin and e1 < -margin and v0 < -limit and v1 < -limit))


class Controller:
    """The protocol of the PI speed controller without a rotor of its own: state the integral I of the speed
    error, input the measured speed omega (held over a step), dI/dt of :func:`pi_torque` with
    e = omega_ref(t) - omega."""

    Parameters = ControllerParameters
    output_jumps = staticmethod(output_jumps)
    changes_by = staticmethod(changes_by)

    class State(NamedTuple):
        """Integral of the speed error [rad]."""

        integral: float

    class Inputs(NamedTuple):
        """The measured rotor speed [rad/s], held over a step."""

        omega: float

    @staticmethod
    def initial_state(p: ControllerParameters, t: float, u: tuple) -> tuple:
        """The integral starts at :func:`start_integral`."""
        return Controller.State(start_integral(p))

    @staticmethod
    def derivatives(p: ControllerParameters, t: float, y: tuple, u: tuple) -> tuple:
        """dI/dt of :func:`pi_torque` with e = omega_ref(t) - omega."""
        return (pi_torque(reference(p, t)[0] - u.omega, y[0], p.Kp, p.Ki, p.tau_max)[1],)

    @staticmethod
    def rate_bound(p: ControllerParameters, y: tuple, omega_max: float) -> float:
        """0: one RK4 step per communication step, exact while unsaturated (e is linear in t between the
        profile's corners, omega held)."""
        return 0.0

    @staticmethod
    def integrate(p: ControllerParameters, t: float, h: float, y: tuple, u: tuple) -> tuple:
        """The FMU's step, omega held, piece by piece between the profile's corners inside (t, t + h)
        (:func:`split_at_corners`); on a piece, I(t + h) = I + e0 h + a h^2 / 2 in closed form (e = e0 + a s,
        a = alpha_ref) where |Kp e + Ki I| <= tau_max all along (:func:`controller_torque_peak`), I itself where
        the torque stays at one limit with the integral frozen (:func:`clamped_all_along`); elsewhere one
        classical RK4 step of :meth:`derivatives` (the clamp and the anti-windup), as the FMU's default. RK4
        integrates the linear e(s) exactly too: the closed forms are the same numbers to round-off (the frozen
        integral bitwise) on a piece of the profile, at a quarter of the cost."""
        if corner_inside(p, t, h):
            return split_at_corners(Controller.integrate, p, t, h, y, u)
        r0, a, _ = reference(p, t)
        e0, integral = r0 - u[0], y[0]
        if controller_torque_peak(p, h, e0, a, integral) <= p.tau_max:
            return (integral + h * (e0 + 0.5 * a * h),)
        if clamped_all_along(p, h, e0, a, integral, max(1.0, abs(r0), abs(u[0]))):
            return (integral,)
        return _RK4_1(Controller.derivatives, p, t, u, y, h, rk4.substeps(Controller.rate_bound(p, y, 0.0), h))

    @staticmethod
    def outputs(p: ControllerParameters, t: float, y: tuple, u: tuple) -> dict:
        """The reference speed and the PI law's torque at the measured speed."""
        omega_ref = reference(p, t)[0]
        return {"omega_ref": omega_ref, "tau_motor": pi_torque(omega_ref - u.omega, y[0], p.Kp, p.Ki, p.tau_max)[0]}

    @staticmethod
    def check(p: ControllerParameters) -> list:
        """:func:`check` (the profile's parameters, named as the Motor's)."""
        return check(p)

    advice = staticmethod(advice)

    #: what the Model Exchange FMU says where its event indicators chatter (``ujfmu.fmu3.base``)
    CHATTER_ADVICE = ("The PI law slides along its torque limit where it comes back to it with Ki |e| > Kp |de/dt| "
                      "(a speed step at the limit on a rigid shaft of inertia J with Ki J > Kp^2: a speed loop damped "
                      "below 0.5): the torque stays at the limit while the integral follows it. Run the Co-Simulation "
                      "FMUs there (they follow it), or tune the loop to Kp^2 >= Ki J.")
    #: names of the event indicators (FMI 3.0 Model Exchange): where the right-hand side switches
    EVENT_INDICATORS = (("upper_limit", "Kp e + Ki I - tau_max: > 0 while the torque limit +tau_max holds"),
                        ("lower_limit", "Kp e + Ki I + tau_max: < 0 while the torque limit -tau_max holds"),
                        ("speed_error", "e = omega_ref - omega while a torque limit holds, where its sign switches "
                                        "the anti-windup; 1 rad/s otherwise, where it switches nothing"))

    @staticmethod
    def event_indicators(p: ControllerParameters, t: float, y: tuple, u: tuple) -> tuple:
        """(v - tau_max, v + tau_max, e while clamped, else 1) with v = Kp e + Ki I: :func:`pi_torque` changes
        branch exactly where one of them changes sign (the clamp at +-tau_max, the conditional integration at e = 0
        while clamped). Unclamped, a zero of e switches nothing (a speed held with a ripple crosses it twice a
        period of the ripple: an event at each would stop the host's solver for nothing); the third indicator jumps
        only where the first or second changes sign, an event itself."""
        e = reference(p, t)[0] - u.omega
        v = p.Kp * e + p.Ki * y[0]
        return v - p.tau_max, v + p.tau_max, (e if abs(v) > p.tau_max else 1.0)

    @staticmethod
    def next_time_event(p: ControllerParameters, t: float) -> float | None:
        """The profile's first corner after t (:func:`profile_corners`): a time event, as omega_ref's slope (the
        ramp's start and end) or omega_ref itself (the step) jumps there; None after the last or without one."""
        for corner in p.corners:
            if corner > t:
                return corner
        return None
