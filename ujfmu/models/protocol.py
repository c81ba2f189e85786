"""The protocol every model implements, and that the shared FMU base (ujfmu.fmu.base) drives.

Standard library only: this module runs inside every FMU. A model's ``model.py`` is a module with:

``Parameters``
    a dataclass whose field names are the FMU's parameter names (derived constants the equations use are
    ``init=False`` fields set in ``__post_init__``); built from the FMU's parameters by name.
``State``
    a NamedTuple of the integrated variables (no fields: a model without dynamics of its own).
``initial_state(p, t, u) -> State``
    the state at time t [s] and inputs ``u`` of the start; the FMU re-evaluates it at the current inputs until
    its first step (the warm start: a host may set the inputs after initialization).
``derivatives(p, t, y, u) -> tuple``
    dy/dt at time t [s], state y and inputs u.
``outputs(p, t, y, u) -> dict``
    the FMU's outputs, by output name, at time t, state y and inputs u.
``check(p) -> list``
    the messages for parameter combinations that are invalid (each parameter's own range is checked from the
    FMU declaration before).
``rate_bound(p, y, omega_max) -> float``
    an upper bound [1/s] of the fastest rate of y over a step whose input speeds stay within omega_max [rad/s]:
    the RK4 substeps are ``ujfmu.fmu.rk4.RATE_STEP / rate_bound`` long.

A model without a state of its own (a kinematic joint, a load law) takes :class:`NoState`,
:func:`kinematic_always`, :func:`no_state`, :func:`no_derivatives` and :func:`no_rate` below as its ``State``,
``kinematic``, ``initial_state``, ``derivatives`` and ``rate_bound``.

Optional: ``kinematic(p) -> bool`` (default False; True: the state is not integrated but held from the first
step on, the outputs following the inputs alone), ``advice(p) -> list`` (warnings on valid parameters that are
likely not what was meant, logged at initialization and printed by ``ujfmu run``; default none),
``free_output_inertia(p) -> float | None`` (the inertia [kg.m2] a load on the output shaft accelerates on its own, behind
the model's compliance; default None, where the output follows the input's kinematics: tooling compares a Load's
torque with it, ``Scenario.load_chatter``) and ``check_state(p, y) -> list``
(messages when a state reached by a step is outside the model's validity, which refuse the step; default none),
``state_advice(p, h, y, u) -> list`` (warnings on a state y reached by a step of h from the inputs u that is valid
but likely not what was meant, logged once per instance; default none), ``rate_sources(p) -> list`` ((what, rate
[1/s]) of the model's parts, naming the parameters that set each rate: a step refused for its substeps lists them,
the fastest first; default none) and
``output_free_inputs(p) -> tuple`` (names of FMU inputs that neither ``outputs`` nor ``initial_state`` depend on at
these parameters, e.g. a load torque that only enters the derivatives: a change of them leaves the outputs valid,
so the FMU does not recompute them when a host sets them after reading the outputs; default none), for a model
whose inputs are a :class:`Drive`, ``drive_derivatives(p, t, y, phi, omega, alpha, tau_load) -> tuple`` (the same
numbers as ``derivatives(p, t, y, Drive(phi, omega, alpha, tau_load))`` from plain floats: the FMU calls it at
every RK4 stage, where building a Drive costs as much as a small model's equations; default built from
``derivatives``) and ``integrate(p, t, h, y, u) -> tuple`` (the state y at time t
advanced over a step of h from the inputs u at its start, a Drive extrapolated as the FMU does, by the model's own
integrator, substep rule included; default the FMU's RK4 substeps from ``rate_bound``; a torque-driven variant whose
input acceleration needs its full derivatives may add ``integrate_from(p, t, h, y, u, k1)``, the same step from the
rates ``k1 = derivatives(p, t, y, u)`` at its start, which its FMU evaluates once for its speed check), or
``integrate_with_history(p, t, h, y, u, history) -> (state, history)`` with ``NO_HISTORY`` (a multistep
integrator: its history, a tuple of floats of NO_HISTORY's length, is FMU state, NO_HISTORY after initialization),
and ``load_outputs(p, t, y, u) -> dict`` (the outputs that depend on the input tau_load, for a torque-driven variant
on either of its inputs tau_in and tau_load, the same numbers as ``outputs`` gives for them; every other output must
not depend on those inputs: when a host sets them after reading the outputs, the FMU recomputes only these; default
all of ``outputs``) with, optionally, ``load_output_names(p) -> tuple`` (their names at these parameters: a read of
none of them then computes nothing, as the others are still valid), and ``STATE_OUTPUTS`` with
``state_outputs(p, t, y) -> dict`` (names of outputs that depend on
no input, e.g. a torque-driven variant's speeds, which its host reads before it sets the torques, and their values,
the same numbers as ``outputs`` gives for them: a read of only these computes only them; default all of ``outputs``),
``LIGHT_OUTPUTS`` with ``light_outputs(p, t, y, u) -> dict`` (names of outputs that cost a fraction of the others, e.g.
a rotor's motion and input torque without its joint's kinematics, and their values, the same numbers as ``outputs``
gives for them: a read of only these computes only them, the others staying stale; default all of ``outputs``; not with
``load_outputs``, whose host reads before it sets the load inputs: a light read there leaves every output to compute
after them), and ``EXCITATION_ORDER`` (a module constant: the highest order of the input speed the outputs carry at full
size, e.g. a joint's 2x; a run whose record samples it at most twice a period fails, ``ujfmu.scenario_run``, and the FMU
warns a host whose step does so, ``ujfmu.fmu.base``) with, optionally, ``excitation_order(p) -> int`` (that order at
these parameters, 0 for none: straight joints carry no 2x) and ``excited_orders(p) -> tuple`` (the orders themselves,
e.g. a joint's 2x without a 1x; default 1 to that order: `ujfmu modes` lists their crossings), ``output_jumps(p) ->
tuple`` (the times [s] at which the outputs jump, e.g. a speed profile's step or a load step: an iterating master holds
its torn inputs at their start values over a step that ends at one, where its blend would take the jump into that step;
default none), ``changes_by(p, t) -> bool`` (the outputs at time t differ from those at 0 at the same state and inputs,
e.g. a speed profile that moved: the FMI 3.0 FMUs cannot see a start time other than 0 before their first step, so a
Co-Simulation run from a start where this holds is refused; default False), for a model whose inputs are a
:class:`Drive`, ``speed_jump(p, y, w_from, w_to) -> tuple`` (the state after the host sets the input shaft from w_from,
the speed the last step extrapolated it to, to its new omega_in w_to: an energy audit's input work takes the impulse's
work on the input inertia there, which no torque output carries; default the state unchanged), and ``LATERAL_STATES``
(names of ``State`` fields of bending motion, e.g. a disc's displacements and velocities: `ujfmu modes` calls a mode
lateral, torsional or lateral-torsional by its participation in them; default none).

The inputs ``u`` are the model's own NamedTuple ``Inputs``; a model whose input shaft follows a prescribed speed
(``omega_in``) uses :class:`Drive`, which the base extrapolates over a step (angle quadratic, speed linear in time:
``ujfmu.fmu.rk4``); a torque-driven variant, whose input shaft is a state, uses :class:`Torques`, held over a step.

A model module may hold a second model, a variant with another causality at its ports, as a class whose
attributes are the names above (e.g. ``TorqueDriven`` in ``cardan_joint/model.py``): the FMU of the variant
declares that class as its MODEL.
"""

import math
from typing import NamedTuple, Protocol


class Drive(NamedTuple):
    """Inputs of a model whose input shaft follows a prescribed motion: the shaft's angle [rad], speed [rad/s] and
    acceleration [rad/s2] (estimated from omega_in's history: the backward difference, or to second order where
    the FMU says so), and the load torque [N.m] (held over a step)."""

    phi: float
    omega: float
    alpha: float
    tau_load: float


class Torques(NamedTuple):
    """Inputs of a torque-driven model, whose input shaft is a state: the driving torque on the input shaft
    [N.m] and the load torque [N.m], both held over a step."""

    tau_in: float
    tau_load: float


def torque_driven_outputs(speed_driven: dict, y: tuple, alpha: float) -> dict:
    """The outputs of a torque-driven model: its input shaft's angle y[0], speed y[1] and acceleration alpha from
    its state and equation of motion, then the speed-driven model's outputs ``speed_driven`` at that motion, whose
    tau_in (the torque the input shaft demands) is ``tau_input_shaft`` here (tau_in is the driving torque input)."""
    out = {"phi_in": y[0], "omega_in": y[1], "alpha_in": alpha, "tau_input_shaft": speed_driven.pop("tau_in")}
    out.update(speed_driven)
    return out


#: the least inertia [kg.m2] on a torque-driven model's free input shaft (as the FMUs' smallest inertias): its
#: equation of motion divides by it, and a denormal's reciprocal overflows
MIN_SHAFT_INERTIA = 1e-9


def shaft_inertia_problems(names: str, inertia: float, shaft: str) -> list:
    """The message of a torque-driven model's check when the inertia [kg.m2] on its free input shaft (the sum
    ``names``) is below ``MIN_SHAFT_INERTIA``: the shaft's equation of motion divides by it."""
    if inertia >= MIN_SHAFT_INERTIA:
        return []
    return [f"{names} = {inertia!r} kg.m2 must be at least {MIN_SHAFT_INERTIA:g} (allowed range "
            f"[{MIN_SHAFT_INERTIA:g}, 2e+06] kg.m2): the {shaft} needs an inertia to integrate"]


#: a Hooke joint angle [rad] beyond which a model's advice asks whether degrees were meant (45 deg: the speed ratio
#: then swings between 0.71 and 1.41 already)
LARGE_JOINT_ANGLE = math.radians(45.0)

#: the relative size of a speed-ratio swing (a joint at angle b: about b^2 / 2) below which the order it makes is
#: not there for a record to sample (``excitation_order``: 1e-9, as the order checks' significance floor)
NEGLIGIBLE_SWING = 1e-9

#: a host's communication times (k h, t + h) miss an instant meant to be on its grid by the rounding of the
#: arithmetic (1.05 arrives as 1.0499999999999998 at h = 1e-3): an instant within this fraction of the larger of
#: 1 s and itself counts as reached (:func:`reached`), far below any step
TIME_ROUNDING = 1e-9


def reached(t: float, instant: float) -> bool:
    """Whether the time t has reached instant, up to a host's rounding (``TIME_ROUNDING``)."""
    return t >= instant - TIME_ROUNDING * max(1.0, abs(instant))


def joint_angle_advice(name: str, angle: float) -> list:
    """A warning for a joint angle [rad] beyond ``LARGE_JOINT_ANGLE``, valid but far past a driveline's usual
    few to 30 degrees, and, for a number of at most four decimals (one typed, not converted from degrees: 80 deg is
    1.396263... rad), what it is if it was meant in degrees."""
    if abs(angle) <= LARGE_JOINT_ANGLE:
        return []
    typed = abs(angle * 1e4 - round(angle * 1e4)) < 1e-6   # a few decimals: typed
    return [f"{name} = {angle:.6g} rad is {math.degrees(angle):.4g} deg, past the {math.degrees(LARGE_JOINT_ANGLE):g} "
            f"deg of an unusually steep joint (its speed ratio swings between {math.cos(angle):.3g} and "
            f"{1.0 / math.cos(angle):.3g})"
            + (f"; if the value was meant in degrees, {name} = {math.radians(angle):.6g} rad (the FMUs take SI units)"
               if typed else "")]


def phase_angle_advice(name: str, angle: float) -> list:
    """A warning for a phase angle [rad] that is a whole number of radians from 1 on (3.0, 90.0): valid, but what a
    phase given in degrees looks like, where a phase meant in radians is 0 or a fraction of pi; and what it is if
    the number was meant in degrees."""
    if angle == 0.0 or abs(angle) < 1.0 or angle != round(angle):
        return []
    return [f"{name} = {angle:g} rad is {math.degrees(angle):.4g} deg; if the value was meant in degrees, {name} = "
            f"{math.radians(angle):.6g} rad (the FMUs take SI units)"]


# --- the protocol functions of a kinematic model without a state of its own (State has no fields) -------------

class NoState(NamedTuple):
    """``State``: no integrated variables."""


def kinematic_always(p) -> bool:
    """``kinematic``: the outputs follow the inputs alone."""
    return True


def no_state(p, t: float, u) -> NoState:
    """``initial_state``: the empty state."""
    return NoState()


def no_derivatives(p, t: float, y: tuple, u) -> tuple:
    """``derivatives``: nothing to integrate."""
    return ()


def no_rate(p, y: tuple, omega_max: float) -> float:
    """``rate_bound``: no rate, one substep."""
    return 0.0


class Model(Protocol):
    """What the FMU base needs from a model module (see the module docstring)."""

    Parameters: type
    State: type
    Inputs: type

    def initial_state(self, p, t: float, u) -> tuple: ...

    def derivatives(self, p, t: float, y: tuple, u) -> tuple: ...

    def outputs(self, p, t: float, y: tuple, u) -> dict: ...

    def check(self, p) -> list: ...

    def rate_bound(self, p, y: tuple, omega_max: float) -> float: ...
