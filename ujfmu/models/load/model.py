"""Driven load: resisting torque tau = T(t)*s(omega) + c1*omega + c2*omega*|omega|_s + T_active
+ T_h*cos(order_h*phi + phase_h).

T(t) = T0, changed by T_change from t_change on: at once (ramp_time = 0, a load step) or linearly over ramp_time
(:func:`level`). The last term is a torque periodic in the driven shaft's angle phi (an input: its phi_out), order_h
times a revolution: a propeller's blade rate (order_h the number of blades), an engine's firing order, an implement's
strokes (:func:`harmonic`). T_active is a torque that keeps its sign whatever the direction of rotation (a
gradient, a hoisted weight): it resists one direction and drives the other, and turns a shaft that nothing holds
backwards from rest.

s(omega) = omega/sqrt(omega^2 + omega_s^2) is a smooth sign and |omega|_s = sqrt(omega^2 + omega_s^2) a smooth
absolute value, so the law is infinitely differentiable through omega = 0 and odd in omega (the torque always
opposes the motion). For |omega| >> omega_s it is Coulomb T0*sign(omega), viscous c1*omega and fan/propeller
c2*omega^2 (the fan load M_u = c*omega_5^2 of [Brutti1999]: Carlo Brutti, Ettore Pennestri, Marco Evangelos
Biancolini, "On the Dynamics of the Transmission with a Double Cardan Joint", Proceedings of the Tenth World
Congress on the Theory of Machines and Mechanisms (IFToMM), Oulu, Finland, 1999). Standard library only: runs
inside the Load FMU.
"""

import math
from dataclasses import dataclass
from typing import NamedTuple

from ..protocol import NoState, kinematic_always, no_derivatives, no_rate, no_state, reached


def load_torque(omega: float, t0: float, c1: float, c2: float, omega_smooth: float) -> float:
    """Resisting torque [N.m] at speed omega [rad/s]; positive opposes positive rotation."""
    mag = math.sqrt(omega * omega + omega_smooth * omega_smooth)
    return t0 * omega / mag + c1 * omega + c2 * omega * mag


# --- the model protocol (ujfmu.models.protocol) -----------------------------------------------------------------

@dataclass(slots=True)
class Parameters:
    """The Load FMU's parameters (names as declared there)."""

    T0: float
    c1: float
    c2: float
    omega_smooth: float
    T_change: float = 0.0
    t_change: float = 0.0
    ramp_time: float = 0.0
    T_h: float = 0.0
    order_h: float = 1.0
    phase_h: float = 0.0
    T_active: float = 0.0


def harmonic(p: Parameters, phi: float) -> float:
    """The torque periodic in the driven shaft's angle phi [rad]: T_h cos(order_h phi + phase_h) [N.m], zero mean
    over a revolution for a whole order_h >= 1."""
    return p.T_h * math.cos(p.order_h * phi + p.phase_h) if p.T_h else 0.0


def level(p: Parameters, t: float) -> float:
    """T(t) [N.m]: T0 before t_change, T0 + T_change from t_change + ramp_time on, linear between (a step at
    t_change where ramp_time = 0); an instant counts as reached up to a host's rounding of its times
    (``protocol.reached``: a step meant at a communication point happens there)."""
    if not p.T_change or not reached(t, p.t_change):
        return p.T0
    if not reached(t, p.t_change + p.ramp_time):
        return p.T0 + p.T_change * (t - p.t_change) / p.ramp_time
    return p.T0 + p.T_change


def corners(p: Parameters) -> tuple:
    """The times where T(t) jumps or changes its slope (:func:`level`), in order; none without a change."""
    if not p.T_change:
        return ()
    return (p.t_change,) if p.ramp_time == 0.0 else (p.t_change, p.t_change + p.ramp_time)


def changes_by(p: Parameters, t: float) -> bool:
    """The torque at time t differs from that at 0 at the same speed: T(t) != T(0)."""
    return level(p, t) != level(p, 0.0)


def output_jumps(p: Parameters) -> tuple:
    """The times where the torque jumps: a load step's t_change (ramp_time = 0); none for a ramp or no change."""
    return (p.t_change,) if p.T_change and p.ramp_time == 0.0 else ()


def next_time_event(p: Parameters, t: float) -> float | None:
    """The first corner of T(t) after t (:func:`corners`): a time event for a Model Exchange host, whose solver
    stops there instead of stepping across the jump; None after the last."""
    for corner in corners(p):
        if corner > t:
            return corner
    return None


State = NoState   # the torque follows the speed


class Inputs(NamedTuple):
    """Speed [rad/s] and angle [rad] of the driven shaft."""

    omega: float
    phi: float = 0.0


kinematic, initial_state, derivatives, rate_bound = kinematic_always, no_state, no_derivatives, no_rate


def outputs(p: Parameters, t: float, y: State, u: Inputs) -> dict:
    """The resisting torque at the input speed, angle and time (:func:`load_torque` at T(t), :func:`level`, plus
    :func:`harmonic`)."""
    return {"tau": load_torque(u.omega, level(p, t), p.c1, p.c2, p.omega_smooth) + p.T_active + harmonic(p, u.phi)}


def advice(p: Parameters) -> list:
    """Warnings on valid parameters likely not meant: a negative coefficient turns its part of the law from a
    resisting torque into a driving one (T0, or T0 + T_change, below 0: the load pushes the shaft on; c1 or c2 below
    0: it feeds the motion energy in proportion to the speed, a negative damping that can run the driveline away)."""
    messages = []
    for name, value in (("T0", p.T0), ("T0 + T_change", p.T0 + p.T_change), ("c1", p.c1), ("c2", p.c2)):
        if value < 0.0 and not (name == "T0 + T_change" and (not p.T_change or p.T0 < 0.0)):
            messages.append(f"{name} = {value:.6g} is negative: that part of the load drives the shaft instead of "
                            "resisting it (tau > 0 opposes positive rotation)"
                            + (", a negative damping that feeds energy into the motion and can run it away"
                               if name in ("c1", "c2") else ", in whichever direction it turns (a negative friction, "
                               "reversing with the speed; a torque of one sign in either direction, a gradient's or a "
                               "weight's, is T_active)")
                            + "; set it >= 0 for a resisting load")
    if p.T_h and p.order_h != int(p.order_h):
        messages.append(f"order_h = {p.order_h:g} is not a whole number: the periodic torque repeats over "
                        f"{_revolutions(p.order_h)} revolutions (a four-stroke engine's half orders), which the "
                        "running-speed order analysis of sweeps, steady windows and [reference.orders] does not "
                        "resolve (it fits whole orders of one revolution and reports such a response as not steady); "
                        "the time response is right")
    return messages


def _revolutions(order: float) -> str:
    """The revolutions over which a torque of this order repeats: the least n with n * order whole (up to 1000),
    else 'many'."""
    for n in range(1, 1001):
        if abs(n * order - round(n * order)) < 1e-9 * max(1.0, n * order):
            return str(n)
    return "many"


def check(p: Parameters) -> list:
    return []
