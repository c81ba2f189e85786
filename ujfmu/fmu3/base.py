"""FMI 3.0 plumbing over a ujfmu model (runs inside the FMU: standard library and pythonfmu3 only).

An FMI 3.0 FMU of model M (the FMU class of ``ujfmu/models/<stem>/fmu.py``: its ``VARIABLES`` declaration over
the equations of its ``model.py``) is a
pythonfmu3 slave that holds one bare instance of M, the *core*, and forwards every FMI call to the same methods
the FMI 2.0 FMU runs: parameters and inputs are checked by ``Var.check`` and M's own checks, outputs are computed
lazily by ``compute_outputs``, a Co-Simulation step is M's ``do_step`` (its own RK4 substeps), and the FMU state
is M's data-only state (``ujfmu.fmu.base.encode_state``/``decode_state``: a versioned, checksummed blob of JSON
numbers, never executed). So the two FMI versions of one model give the same numbers.

Model Exchange (``ModelExchangeFmu``) is offered for the models whose equations are derivatives of a state at
the current inputs: the torque-driven variants (driving torque in, input shaft speed out, the input shaft with
the driver's rotor inertia as a state), the MotorController (its PI integral) and the Load (no state). The
continuous states are the core's model state (``STATES`` names them, with nominals by unit); their derivatives
are the model's ``derivatives`` (ujfmu.models.protocol), so ME and CS share the equations, CS integrating them
with RK4 inside the step and ME leaving it to the host's solver. A model whose right-hand side switches declares
``EVENT_INDICATORS`` and ``event_indicators`` (the MotorController: its torque limit), offered as local variables
``z.<name>`` and through fmi3GetEventIndicators.

Error handling (pythonfmu3 0.3.4, like pythonfmu 0.7.0, turns a Python exception into fmi3Fatal and then
releases the instance, its class and its log queue, and releases them again in fmi3FreeInstance; it has no path
to fmi3Error): invalid parameters fail fmi3ExitInitializationMode with a logged error naming the parameter and
its range (status fmi3Fatal; the objects released twice are pinned first, so the host survives and may free the
instance); a bad input, step size or diverging step refuses fmi3DoStep with fmi3Discard and a logged error, the
instance staying usable; in Model Exchange a non-finite or out-of-range input gives NaN derivatives and a logged
error naming it (the host's solver stops there). Unlike pythonfmu 0.7.0, pythonfmu3 passes error messages to the
host's logger also with logging off.
"""

import math
import re
import weakref

from pythonfmu3 import (Boolean, DefaultExperiment, Enumeration, Float64, Fmi3Causality, Fmi3SlaveBase, Fmi3Status,
                        Int32, Int64, String, UInt64)
from pythonfmu3 import Fmi3StepResult, Fmi3Variability
from pythonfmu3.cosimulation import CoSimulation
from pythonfmu3.modelexchange import Fmi3UpdateDiscreteStatesResult, ModelExchange

from ..fmu import base as fmu_base
from ..models.protocol import TIME_ROUNDING

_TYPES = {float: Float64, int: Int32, bool: Boolean}
#: objects pythonfmu3 releases twice after a Python exception; references held here keep them valid
_PINNED_AFTER_EXCEPTION = []
_LIVE = weakref.WeakSet()


# --- Model Exchange: the continuous states of each model that offers it --------------------------------------------
class ContinuousStates:
    """The continuous states of a model's core: names and units, get/set, derivatives at the current inputs."""

    names = ()   # ((name, unit, description), ...)

    def get(self, core) -> list:
        return []

    def set(self, core, values) -> None:
        pass

    def derivatives(self, core) -> list:
        return []

    def set_time(self, core, time: float) -> None:
        """The core's time (outputs may depend on it: the Load's T(t))."""
        core._time = time

    def nominals(self) -> list:
        """The states' nominal magnitudes (NOMINALS by unit): a host's solver scales its absolute tolerance by
        them, so the disc displacements (tens of micrometres) are resolved as finely as the angles."""
        return [NOMINALS.get(unit, 1.0) for _, unit, _ in self.names]


#: refusals of the derivatives logged in full for each reason (``get_continuous_state_derivatives``)
REFUSALS_LOGGED = 3
#: events in a row each at most ZENO_SPACING max(1, |t|) s after the one before: the right-hand side switches back
#: and forth at one instant (a chattering switch), which a solver would locate for ever; the FMU ends the run there
ZENO_EVENTS, ZENO_SPACING = 50, 1e-6
#: an event indicator within this of zero at an event is the one the event is at (``_chattering``)
ZENO_NEAR = 1e-6
#: nominal magnitude of a continuous state by unit (1 for the others): a disc-centre displacement of a Jeffcott
#: rotor is of the order of 1e-4 m and its velocity of 1e-2 m/s (fmi3GetNominalsOfContinuousStates, and the
#: states' ``nominal`` in the modelDescription)
NOMINALS = {"m": 1.0e-4, "m/s": 1.0e-2}


class ModelStates(ContinuousStates):
    """The state of a core over a model of the protocol (ujfmu.models.protocol): the core's model state (the
    initial state at the current inputs until the first step or until the host sets it) and the model's
    ``derivatives`` at the core's time and current inputs."""

    def __init__(self, names):
        self.names = names

    def get(self, core):
        return list(core.current_state(core.model_inputs()))

    def set(self, core, values):
        core._y, core._started = tuple(float(v) for v in values), True

    def derivatives(self, core):
        u = core.model_inputs()
        return list(core.MODEL.derivatives(core._p, core._time, core.current_state(u), u))

    def indicators(self, core) -> list:
        """The model's event indicators (``MODEL.event_indicators``, none without) at the current state and inputs."""
        function = getattr(core.MODEL, "event_indicators", None)
        if function is None:
            return []
        u = core.model_inputs()
        return list(function(core._p, core._time, core.current_state(u), u))


_JOINT = (("phi1", "rad", "Input shaft angle"), ("omega1", "rad/s", "Input shaft speed"))
#: model name -> its continuous states, for the models offered as Model Exchange
STATES = {
    "CardanJointTorqueDriven": ModelStates(_JOINT),
    "DoubleCardanDrivelineTorqueDriven": ModelStates(_JOINT + (
        ("phi4", "rad", "Output shaft angle (flexible shaft; 0 with a rigid one)"),
        ("omega4", "rad/s", "Output shaft speed (flexible shaft; 0 with a rigid one)"),
        ("phi", "rad", "Dynamic misalignment angle (flexible shaft; 0 with a rigid one)"),
        ("dphi", "rad/s", "Rate of the dynamic misalignment (flexible shaft; 0 with a rigid one)"))),
    "TwinJeffcottRotorTorqueDriven": ModelStates((
        ("phi_in", "rad", "Gearbox flange (input) angle"), ("omega_in", "rad/s", "Gearbox flange (input) speed"),
        ("theta1", "rad", "Disc 1 angle"), ("omega1", "rad/s", "Disc 1 speed"),
        ("X1", "m", "Disc 1 centre displacement X"), ("dX1", "m/s", "Disc 1 centre velocity X"),
        ("Y1", "m", "Disc 1 centre displacement Y"), ("dY1", "m/s", "Disc 1 centre velocity Y"),
        ("theta2", "rad", "Disc 2 angle"), ("omega2", "rad/s", "Disc 2 speed"),
        ("X2", "m", "Disc 2 centre displacement X"), ("dX2", "m/s", "Disc 2 centre velocity X"),
        ("Y2", "m", "Disc 2 centre displacement Y"), ("dY2", "m/s", "Disc 2 centre velocity Y"),
        ("dissipated_energy", "J", "Energy dissipated by the dampers since the start"),
        ("input_work", "J", "Work into the rotor through the input shaft end since the start"))),
    "RingCouplingTorqueDriven": ModelStates((
        ("phi1", "rad", "Shaft 1 angle"), ("omega1", "rad/s", "Shaft 1 speed"),
        ("phi2", "rad", "Shaft 2 angle"), ("omega2", "rad/s", "Shaft 2 speed"))),
    "MotorController": ModelStates((("integral", "rad", "Integral of the speed error"),)),
    "Load": ContinuousStates(),
}


def state_variables(model) -> tuple:
    """The Model Exchange variables of model (a ujfmu.fmu class), after its VARIABLES: ``x.<name>`` (local,
    continuous) and ``der(x.<name>)``, as (Var, name of the state it is the derivative of, or None)."""
    states = STATES.get(model.__name__)
    if states is None:
        return ()
    xs = tuple((fmu_base.Var(f"x.{n}", "local", unit, f"Continuous state: {d}"), None) for n, unit, d in states.names)
    ders = tuple((fmu_base.Var(f"der(x.{n})", "local", _per_second(unit), f"Time derivative of x.{n}"), f"x.{n}")
                 for n, unit, _ in states.names)
    return xs + ders


def _per_second(unit):
    return {"rad": "rad/s", "rad/s": "rad/s2", "m": "m/s", "m/s": "m/s2", "J": "W"}[unit]


def event_indicator_variables(model) -> tuple:
    """The event indicators of model (a ujfmu.fmu class) that offers Model Exchange: local continuous variables
    ``z.<name>`` (its MODEL's EVENT_INDICATORS), as (Var, None)."""
    if model.__name__ not in STATES:
        return ()
    return tuple((fmu_base.Var(f"z.{n}", "local", "N.m" if "limit" in n else "rad/s", f"Event indicator: {d}"), None)
                 for n, d in getattr(model.MODEL, "EVENT_INDICATORS", ()))


def fmi3_variables(model) -> tuple:
    """Every variable of the FMI 3.0 FMU of model in value-reference order (value reference = position + 1; 0 is
    the independent variable time), as
    (Var, derivative-of name or None): the model's VARIABLES, then its Model Exchange states and derivatives."""
    return tuple((v, None) for v in model.VARIABLES) + state_variables(model) + event_indicator_variables(model)


#: FMI 2.0 names the shared core's messages use, as FMI 3.0 spells them (:func:`fmi3_names`)
_FMI3_SPELLING = {"GetReal": "GetFloat64", "SetReal": "SetFloat64", "FMUstate": "FMUState",
                  "DeSerialize": "Deserialize"}


def fmi3_names(message: str) -> str:
    """message with each FMI 2.0 function or status name (fmi2DoStep, fmi2SetFMUstate, fmi2GetReal, fmi2Discard...)
    written as FMI 3.0 names it: the core's messages are shared with the FMI 2.0 FMUs."""
    def fmi3(match):
        name = match.group(1)
        for old, new in _FMI3_SPELLING.items():
            name = name.replace(old, new)
        return "fmi3" + name
    return re.sub(r"\bfmi2(\w+)", fmi3, message)


# --- the FMU -------------------------------------------------------------------------------------------------------
def _checked(method: str, kinds, call: str):
    """pythonfmu3's ``method`` (get_int32, ...) for variables of kinds, its value references checked first
    (``Fmi3Model._check_refs``)."""
    def access(self, vrs, *values):
        self._check_refs(vrs, kinds, call)
        return getattr(Fmi3SlaveBase, method)(self, vrs, *values)
    access.__name__ = method
    return access


class Fmi3Model(Fmi3SlaveBase, CoSimulation):
    """FMI 3.0 Co-Simulation FMU of the ujfmu model ``MODEL`` (see the module docstring)."""

    MODEL = None

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        model = self.MODEL
        self.time = 0.0
        self.modelName = model.__name__
        self.description = next(c.__doc__ for c in model.__mro__ if c.__doc__).strip().splitlines()[0]
        self.author, self.license = model.author, model.license
        start, stop, step = model.DEFAULT_EXPERIMENT
        self.default_experiment = DefaultExperiment(start_time=start, stop_time=stop, step_size=step)
        self._core = core = model.__new__(model)
        core.instance_name, core.modelName, core.log_queue = self.instance_name, model.__name__, self.log_queue
        core.log = self._log_from_core
        core._stale, core._initialized, core._running, core._start_time = True, False, False, 0.0
        core._partial = False
        core._subset_vrs, core._state_outputs_of = frozenset(), None   # UjfmuSlave.get_real's, which this FMU bypasses
        core._derivation, core._terminated, core._restored = None, False, False
        core._inputs = tuple(v for v in model.VARIABLES if v.causality == "input")
        for var in model.VARIABLES:
            setattr(core, var.name, 0.0 if var.causality == "output" else var.type(var.start))
        big = 1.7976931348623157e308
        core._input_bounds = tuple((v.name, -big if v.min is None else v.min, big if v.max is None else v.max, v)
                                   for v in core._inputs)
        core._known = frozenset(core.__dict__) | {"_known"} | model.STATE.keys() | set(model.DERIVED)
        self._states = STATES.get(model.__name__, ContinuousStates())
        self.vars.clear()
        self.vars[0] = time = Float64("time", causality=Fmi3Causality.independent,
                                      variability=Fmi3Variability.continuous, getter=lambda: self.time)
        time.value_reference = 0
        for var, derivative_of in fmi3_variables(model):
            self._register(var, derivative_of)
        self._getters = {vr: v.getter for vr, v in self.vars.items() if isinstance(v, Float64)}
        self._setters = {vr: v.setter for vr, v in self.vars.items() if isinstance(v, Float64) and v.setter}
        self._stepped = False   # no fmi3DoStep yet (the first one sets the start time)
        _LIVE.add(self)

    def _register(self, var, derivative_of):
        vr = len(self.vars)
        core = self._core
        getter, setter = None, None
        if var.causality == "output":
            getter = self._guarded(core._output_getter(var.name))
        elif var.causality == "local":
            getter = self._state_getter(var.name)
        else:
            if var.causality == "parameter":   # refuses a change while stepping (the core logged why)
                setter = self._guarded(core._parameter_setter(var.name, var.type))
            else:
                setter = core._input_setter(var.name, var.type)
            getter = lambda name=var.name: getattr(core, name)   # noqa: E731
        kwargs = dict(causality=Fmi3Causality[var.causality], variability=Fmi3Variability[var.variability],
                      description=var.description, getter=getter, setter=setter)
        if var.type is float:
            kwargs["unit"] = var.unit
            if derivative_of is not None:
                kwargs["derivative"] = next(r for r, v in self.vars.items() if v.name == derivative_of)
        if var.causality in ("parameter", "input"):
            kwargs["start"] = var.start
        variable = _TYPES[var.type](var.name, **kwargs)
        variable.value_reference = vr   # from 1 in declaration order (0 is the time)
        self.vars[vr] = variable

    def _state_getter(self, name):
        indicators = [f"z.{n}" for n, _ in getattr(self.MODEL.MODEL, "EVENT_INDICATORS", ())]
        if name in indicators:
            i = indicators.index(name)
            return lambda: self._continuous(self._states.indicators)[i]
        index = [f"x.{n}" for n, _, _ in self._states.names]
        if name in index:
            i = index.index(name)
            return lambda: self._continuous(self._states.get)[i]
        i = index.index(name[4:-1])
        return lambda: self.get_continuous_state_derivatives()[i]   # the same checks, NaN where they refuse

    # --- logging and errors ---
    def _log_from_core(self, message, status=Fmi3Status.ok, *args, **kwargs):
        self.log(fmi3_names(message), Fmi3Status(int(status)))

    def _pin(self):
        _PINNED_AFTER_EXCEPTION.extend((self, self, type(self), self.log_queue))

    def _raise_to_host(self, message):
        self.log(message, Fmi3Status.error)
        self._pin()
        raise ValueError(message)

    def _guarded(self, function):
        """function, with the objects pythonfmu3 releases twice pinned if it raises (the core logged why)."""
        def call(*args):
            try:
                return function(*args)
            except Exception:
                self._pin()
                raise
        return call

    # --- values ---
    def get_float64(self, vrs):
        try:
            getters = self._getters
            return [getters[vr]() for vr in vrs]
        except KeyError:
            self._check_refs(vrs, Float64, "fmi3GetFloat64")
            return super().get_float64(vrs)

    def set_float64(self, vrs, values):
        try:
            setters = self._setters
            for vr, value in zip(vrs, values):
                setters[vr](value)
        except KeyError:
            for vr in vrs:
                variable = self.vars.get(vr)
                if variable is not None and variable.causality == Fmi3Causality.output:
                    self._raise_to_host(f"{self._core.modelName} '{self._core.instance_name}': {variable.name} is "
                                        "an output: the FMU computes it, a host reads it (fmi3GetFloat64)")
            self._check_refs(vrs, Float64, "fmi3SetFloat64")
            super().set_float64(vrs, values)

    def _check_refs(self, vrs, kinds, call):
        """Refuse (fmi3Fatal, the cause logged) a value reference ``fmu_base.reference_problem`` names: pythonfmu3's
        own refusal is an exception it releases twice, which crashed the host at a second one."""
        problem = fmu_base.reference_problem(self.vars, vrs, kinds, call)
        if problem:
            self._raise_to_host(f"{self._core.modelName} '{self._core.instance_name}': {problem}")

    get_int32, set_int32 = _checked("get_int32", Int32, "fmi3GetInt32"), _checked("set_int32", Int32, "fmi3SetInt32")
    get_int64, set_int64 = (_checked("get_int64", (Enumeration, Int64), "fmi3GetInt64"),
                            _checked("set_int64", (Enumeration, Int64), "fmi3SetInt64"))
    get_uint64, set_uint64 = _checked("get_uint64", UInt64, "fmi3GetUInt64"), _checked("set_uint64", UInt64,
                                                                                       "fmi3SetUInt64")
    get_boolean, set_boolean = (_checked("get_boolean", Boolean, "fmi3GetBoolean"),
                                _checked("set_boolean", Boolean, "fmi3SetBoolean"))
    get_string, set_string = _checked("get_string", String, "fmi3GetString"), _checked("set_string", String,
                                                                                       "fmi3SetString")

    # --- life cycle ---
    def exit_initialization_mode(self):
        self._guarded(self._core.exit_initialization_mode)()

    def terminate(self):
        self._core.terminate()

    def do_step(self, current_time, step_size):
        core = self._core
        if not self._stepped and core._running and current_time != core._start_time:
            # pythonfmu3 0.3.4 does not pass fmi3EnterInitializationMode's startTime on: the first step's time is it
            core._start_time = current_time
            core._start()
        self._stepped = True
        ok = core.do_step(current_time, step_size)
        if ok:
            self.time = current_time + step_size
        return Fmi3StepResult() if ok else Fmi3StepResult(status=Fmi3Status.discard)

    # --- FMU state: the core's data-only state ---
    def _get_fmu_state(self):
        return self._guarded(self._core._get_fmu_state)()

    def _set_fmu_state(self, state):
        self._guarded(self._core._set_fmu_state)(state)
        self._last_event = None   # a restored state's events are counted anew (``_chattering``)
        # a state saved before the first step is restored as one: the next step still sets the start time
        self._stepped = bool(getattr(self._core, "_started", True))
        self.time = getattr(self._core, "_time", self.time)   # the independent variable the state was saved at

    @staticmethod
    def _fmu_state_to_bytes(state):
        return fmu_base.encode_state(state)

    @classmethod
    def _fmu_state_from_bytes(cls, data):
        """fmi3DeserializeFMUState (pythonfmu3 calls it on the class): a rejected blob pins the objects of every
        live instance of the class and logs the reason to each."""
        try:
            return fmu_base.decode_state(cls.MODEL, bytes(data))
        except Exception as exc:
            reason = exc if isinstance(exc, fmu_base.StateError) else repr(exc)
            message = (f"{cls.MODEL.__name__}: FMU state rejected, the instance is unchanged: {reason} (said by every "
                       "live instance of this FMU: the wrapper deserializes a state without naming the instance)")
        for inst in [i for i in list(_LIVE) if type(i) is cls]:
            inst._pin()
            inst.log(message, Fmi3Status.error)
        _PINNED_AFTER_EXCEPTION.append(cls)
        raise ValueError(message)

    # --- Model Exchange ---
    def _continuous(self, what):
        """what(core) once the core is initialized (else a ValueError naming the invalid parameters)."""
        core = self._core
        if not core._initialized:
            invalid = core._invalid()
            if invalid:
                self._raise_to_host(f"{core.modelName} '{self.instance_name}': {invalid}")
            core._start()
            core._initialized = True
        return what(core)

    def get_number_of_continuous_states(self):
        return len(self._states.names)

    def get_continuous_states(self):
        return [float(x) for x in self._continuous(self._states.get)]

    def set_continuous_states(self, values):
        self._continuous(lambda core: self._states.set(core, values))
        self._core._stale, self._core._partial = True, False

    def get_continuous_state_derivatives(self):
        """The state derivatives; NaN for each, with the reason logged at error level, when the inputs are
        non-finite or out of range or the equations fail (pythonfmu3 0.3.4 crashes the host on an exception here:
        its C layer prints and clears the error before it checks for one). A host's solver then stops on them."""
        core = self._core
        try:
            for name, lo, hi, var in core._input_bounds:
                if not lo <= getattr(core, name) <= hi:   # NaN and inf fail too
                    raise ValueError(var.check(getattr(core, name)))
            if not core._initialized:
                invalid = core._invalid()
                if invalid:
                    raise ValueError(invalid)
            rates = [float(x) for x in self._continuous(self._states.derivatives)]
            if not all(math.isfinite(x) for x in rates):
                raise ValueError(f"they are not finite ({rates!r}): check the inputs and parameters")
            top = fmu_base.SPEED_RANGE["max"]
            for (name, unit, _), x in zip(self._states.names, self._continuous(self._states.get)):
                if not math.isfinite(x):
                    raise ValueError(f"the state {name} = {x!r} is not finite")
                if unit == "rad/s" and not abs(x) <= top:   # the speed range a Co-Simulation step keeps to
                    raise ValueError(f"the state {name} = {x!r} rad/s is outside the speed range [-{top:g}, {top:g}] "
                                     "rad/s the FMU is made for: the torques outrun the inertias (check tau_in, "
                                     "tau_load and J_drive)")
            if core._state_advice is not None and not core._state_advice_said:   # as a Co-Simulation step says it
                u = core.model_inputs()
                said = core.state_advice_text(self.time, 0.0, core.current_state(u), u)
                if said:
                    self.log(said, Fmi3Status.warning)
            return rates
        except Exception as exc:
            # a solver retries a refused evaluation many times, between successes (54 to 170 lines had buried the
            # first): each reason (its words, numbers aside) REFUSALS_LOGGED times in full, then once that it recurs
            reason = re.sub(r"[-+]?[0-9][0-9.e+-]*|nan|inf", "#", str(exc))
            refusals = self.__dict__.setdefault("_refusals", {})
            refusals[reason] = refusals.get(reason, 0) + 1
            if refusals[reason] <= REFUSALS_LOGGED:
                self.log(f"{core.modelName} '{self.instance_name}': derivatives at t = {self.time!r} refused: {exc}",
                         Fmi3Status.error)
            elif refusals[reason] == REFUSALS_LOGGED + 1:
                self.log(f"{core.modelName} '{self.instance_name}': derivatives at t = {self.time!r} refused again "
                         "for a reason logged above; it is not logged again", Fmi3Status.error)
            return [math.nan] * len(self._states.names)

    def set_time(self, time):
        if not math.isfinite(time):
            self._raise_to_host(f"{self._core.modelName} '{self.instance_name}': fmi3SetTime({time!r}) refused: "
                                f"the time must be finite; the time stays at {self.time!r}")
        self.time = time
        self._states.set_time(self._core, self._evaluation_time(time))
        self._core._stale, self._core._partial = True, False

    def _evaluation_time(self, time: float) -> float:
        """time, or just before it where a time event of the model (``MODEL.next_time_event``) falls at it and
        fmi3UpdateDiscreteStates has not yet been called there: FMI 3.0's left limit in Continuous-Time Mode (a
        profile's step or a load step had been taken at fmi3SetTime, before the host's event mode)."""
        function = getattr(self.MODEL.MODEL, "next_time_event", None)
        if function is None:
            return time
        rounding = 2.0 * TIME_ROUNDING * max(1.0, abs(time))
        handled = self.__dict__.get("_handled")
        if handled is not None and abs(handled - time) <= rounding:
            return time
        at = self._continuous(lambda core: function(core._p, time - rounding))
        return at - rounding if at is not None and at <= time + rounding else time

    def get_number_of_event_indicators(self):
        return len(getattr(self.MODEL.MODEL, "EVENT_INDICATORS", ())) if self.MODEL.__name__ in STATES else 0

    def get_event_indicators(self):
        """The event indicators; NaN (with the reason logged) instead of an exception, as for the derivatives."""
        try:
            return [float(z) for z in self._continuous(self._states.indicators)]
        except Exception as exc:
            self.log(f"{self._core.modelName} '{self.instance_name}': event indicators at t = {self.time!r} refused: "
                     f"{exc}", Fmi3Status.error)
            return [math.nan] * self.get_number_of_event_indicators()

    def get_nominals_of_continuous_states(self, size):
        return self._states.nominals()[:size]


class ModelExchangeFmu(Fmi3Model, ModelExchange):
    """FMI 3.0 Co-Simulation and Model Exchange FMU of the ujfmu model ``MODEL``."""

    def get_continuous_state_derivatives(self):
        return Fmi3Model.get_continuous_state_derivatives(self)

    def update_discrete_states(self):
        """No discrete states; the next time event where the model has one after the current time
        (``MODEL.next_time_event(p, t)``: the MotorController's profile corner), so a host's solver stops there
        instead of stepping across a jump of the right-hand side."""
        result = Fmi3UpdateDiscreteStatesResult()
        if self._chattering():
            result.terminateSimulation = True
            return result
        self._handled = self.time   # the events at this time are taken: the outputs are their right limits now
        self._states.set_time(self._core, self.time)
        self._core._stale, self._core._partial = True, False
        function = getattr(self.MODEL.MODEL, "next_time_event", None)
        if function is not None:
            at = self._continuous(lambda core: function(core._p, self.time))
            if at is not None:
                result.nextEventTimeDefined, result.nextEventTime = True, float(at)
        return result

    def _chattering(self) -> bool:
        """True (the reason logged at error level) where this event, at one of the model's event indicators (within
        ``ZENO_NEAR`` of zero: a host takes every FMU through Event Mode at another's event too), is the
        ``ZENO_EVENTS``-th such in a row, each within ``ZENO_SPACING`` max(1, |t|) after the one before (a call at
        the same instant, a host's event iteration, is not another event): the model's right-hand side switches
        back and forth there (the MotorController's PI law sliding along its torque limit), which Model Exchange
        cannot follow, as the sliding motion needs the inputs' derivatives, which it does not pass."""
        declared = getattr(self.MODEL.MODEL, "EVENT_INDICATORS", ())
        if not declared:
            return False
        values = self._continuous(self._states.indicators)
        (name, meaning), z = min(zip(declared, values), key=lambda pair: abs(pair[1]))
        if not abs(z) <= ZENO_NEAR:
            return False
        t, last, count = self.time, self.__dict__.get("_last_event"), self.__dict__.get("_close_events", 0)
        if t == last:
            return False
        count = count + 1 if last is not None and t - last <= ZENO_SPACING * max(1.0, abs(t)) else 1
        if count == 1:
            self._close_from = t
        self._last_event, self._close_events = t, count
        if count < ZENO_EVENTS:
            return False
        self.log(f"{self._core.modelName} '{self.instance_name}': {count} events within "
                 f"{t - self._close_from:.3g} s up to t = {t!r}: the equations switch back and forth "
                 f"at z.{name} ({meaning}) without time advancing, which Model Exchange cannot follow (the motion "
                 "along the switch needs the inputs' derivatives, which it does not pass); the simulation ends here. "
                 + getattr(self.MODEL.MODEL, "CHATTER_ADVICE", ""), Fmi3Status.error)
        return True


def fmi3_class(model) -> type:
    """The FMI 3.0 FMU class of model (a ujfmu.fmu class): Co-Simulation, plus Model Exchange where STATES has
    its continuous states."""
    base = ModelExchangeFmu if model.__name__ in STATES else Fmi3Model
    return type(f"{model.__name__}Fmi3", (base,), {"MODEL": model, "__doc__": model.__doc__})
