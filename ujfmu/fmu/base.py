"""FMI plumbing shared by every ujfmu FMU (runs inside the FMU: standard library and pythonfmu only).

Each FMU class declares its variables once, as a tuple of :class:`Var` in ``VARIABLES``. That declaration drives
the pythonfmu registration here and, in ``ujfmu.build``, the units, ranges, output dependencies and
InitialUnknowns of modelDescription.xml and the FMU's documentation page.

Error handling (pythonfmu maps a Python exception to fmi2Fatal and ``do_step`` returning False to fmi2Discard;
it has no path to fmi2Error):
- invalid parameters or start inputs: a log message at fmi2Error naming the variable and its allowed range, then an
  exception from fmi2ExitInitializationMode, which the host receives as an error status (fmi2Fatal); the objects
  pythonfmu then releases twice are pinned first (``_PINNED_AFTER_EXCEPTION``), so freeing the instance is safe;
- an input that is non-finite or outside its range, a step size that is not finite and > 0, a step that would
  need more than rk4.MAX_SUBSTEPS substeps, or any exception while stepping: the message is logged at fmi2Error
  and the step is refused (fmi2Discard); the instance and the host process stay alive.

FMU state (canGetAndSetFMUstate, canSerializeFMUstate), data only: the values of the variables, the life-cycle flags
and the attributes each model declares in ``STATE`` (name -> kind, see ``KINDS``). Attributes that follow from the
parameters (a parameters object, cached rates) are declared in ``DERIVED``, never stored, and recomputed by
``derive()`` on restore unless they already follow from the restored parameters (a state this instance saved under
its current ``derive()``, no parameter set since: see ``_set_fmu_state``). An attribute a model sets that is in
neither makes fmi2GetFMUstate fail (and the tests), so nothing can be forgotten. fmi2GetFMUstate returns an
:class:`FmuState`; fmi2SetFMUstate restores exactly its fields, the same ones a serialized state restores. The
serialized form (``encode_state``) is a versioned header (magic, format version, model name, build digest of the
FMU's sources), JSON of plain numbers, and a SHA-256 of all of it. ``decode_state`` rejects a truncated or corrupted
blob, another format version, another FMU, another build, a wrong field set, a wrong type or length, a non-finite
number where a finite one is required, and parameters outside their ranges; it never imports, constructs or calls
anything the blob names. pythonfmu turns the rejection into fmi2Fatal with the reason in the log message; the
instance is left unchanged and usable (the objects pythonfmu releases twice are pinned, as above). docs/security.md
has the threat model.
"""

import dataclasses
import hashlib
import json
import math
import struct
import sys
import weakref
from collections.abc import Callable
from pathlib import Path

from pythonfmu import Boolean, Fmi2Causality, Fmi2Slave, Fmi2Variability, Integer, Real, String
from pythonfmu.enums import Fmi2Status
from pythonfmu.default_experiment import DefaultExperiment

from ..models.protocol import Drive
from . import rk4

_TYPES = {float: Real, int: Integer, bool: Boolean}
#: why a step is refused before initialization: fmi2DoStep before fmi2ExitInitializationMode, or after
#: fmi2SetFMUstate restored a state saved before it (which holds no model state to step from)
NOT_INITIALIZED = ("the instance is not initialized: call fmi2ExitInitializationMode before fmi2DoStep; a state "
                   "saved before it and restored by fmi2SetFMUstate has no model state to step from (restore one "
                   "saved after it, or fmi2Reset and initialize again)")
TERMINATED = ("the instance is terminated (fmi2Terminate ended its run): fmi2Reset and initialize it again, or "
              "instantiate a new one, to step again")
#: why a step is refused after fmi2SetFMUstate restored a state saved with the model initialized but not stepping:
#: after fmi2Terminate, or before fmi2ExitInitializationMode once an output read had computed the start
RESTORED_UNRUN = ("the state fmi2SetFMUstate restored was saved while no run was under way (after fmi2Terminate, "
                  "or before fmi2ExitInitializationMode): restore one saved while stepping, or fmi2Reset and "
                  "initialize again, to step again")
#: what the FMU logs when a KeyboardInterrupt was raised in its code (``ujfmu.master`` reports that failure as the
#: interrupt it is; the FMU's code imports nothing from outside the standard library, so the text is its own copy)
INTERRUPTED_IN_FMU = "KeyboardInterrupt raised in the FMU's code"
#: life-cycle attributes of UjfmuSlave that are part of the FMU state
_LIFECYCLE_KINDS = {"_stale": "bool", "_initialized": "bool", "_running": "bool", "_start_time": "float"}

#: Objects pythonfmu 0.7.0 releases twice after a Python exception (once when it turns the exception into
#: fmi2Fatal, again in fmi2FreeInstance). References held here keep them valid so the host survives.
_PINNED_AFTER_EXCEPTION = []
#: every live instance, to pin the right objects when a state blob is rejected (pythonfmu calls the class there)
_LIVE = weakref.WeakSet()


#: SI unit -> (the human unit a value in it is often given in by mistake, factor to SI)
HUMAN_UNITS = {"rad": ("deg", math.pi / 180.0), "rad/s": ("rpm", math.pi / 30.0)}
#: a value at most this factor past its range's bound is a value in the SI unit just out of range, not a unit slip
NEAR_MISS = 1.1


class Var:
    """One FMU variable: the single declaration of its name, causality, variability, unit, range and start."""

    __slots__ = ("name", "causality", "variability", "unit", "description", "start", "min", "max",
                 "depends_on", "type", "used_if", "neutral")

    def __init__(self, name, causality, unit, description, start=None, min=None, max=None,
                 variability=None, depends_on=(), type=float, used_if=None, neutral=None):
        self.name, self.causality, self.unit, self.description = name, causality, unit, description
        self.start, self.min, self.max, self.type = start, min, max, type
        self.depends_on = tuple(depends_on)
        #: an input the model reads only where this parameter is not 0 (a scenario need not feed it otherwise)
        self.used_if = used_if
        #: a parameter's value at which the model is what it was without it (a feature off; None: no such value)
        self.neutral = neutral
        if variability is None:
            variability = {"parameter": "fixed"}.get(causality, "continuous" if type is float else "discrete")
        self.variability = variability

    def range_text(self):
        """Allowed range in words, for error messages and documentation."""
        if self.type is bool:
            return "true or false"
        lo = "-inf" if self.min is None else f"{self.min:.10g}"
        hi = "+inf" if self.max is None else f"{self.max:.10g}"
        unit = "" if self.unit in (None, "1") else f" {self.unit}"
        return f"[{lo}, {hi}]{unit}"

    def check(self, value, hint=True):
        """None if value is admissible, else a message naming the variable and its allowed range (with the likely
        unit slip, ``unit_hint``, unless hint is false)."""
        if self.type is bool:
            return None
        if not math.isfinite(value):
            return f"{self.name} = {value!r} is not a finite number (allowed range {self.range_text()})"
        if not self.within(value):
            return (f"{self.name} = {value!r} is outside its allowed range {self.range_text()}"
                    + (self.unit_hint(value) if hint else ""))
        return None

    def within(self, value):
        """True if value lies in [min, max] (a missing bound is no bound)."""
        return not ((self.min is not None and value < self.min) or (self.max is not None and value > self.max))

    def unit_hint(self, value):
        """' (12 deg = 0.209 rad?)' for a rad variable, ' (1000 rpm = 104.7 rad/s?)' for a rad/s one, when value
        read as degrees or rpm (x pi/180, x pi/30) would be within range and value is more than ``NEAR_MISS`` past
        the bound it passes (a slip multiplies by 57.3 or 9.55; pi/2 rad against an 89 deg limit is not one): the
        likely slip; else ''."""
        human = HUMAN_UNITS.get(self.unit)
        if human is None or not self.within(value * human[1]):
            return ""
        bound = self.max if self.max is not None and value > self.max else self.min
        if bound is not None and abs(value) <= NEAR_MISS * abs(bound):
            return ""
        return f" ({value:.6g} {human[0]} = {value * human[1]:.4g} {self.unit}?)"


#: said with an input out of its range at a step after the first: the likelier cause than a unit slip once the run
#: is under way
UNSTABLE_INPUT = ("; an input this far out usually comes from the host's coupling going unstable (values growing "
                  "step by step): take a smaller communication step or, for a driven side heavier than its driver, "
                  "the torque-driven wiring (ujfmu README, \"Choose the wiring for the host\"). If it did not grow "
                  "step by step, the component it comes from really gives it: check that component's parameters "
                  "(e.g. a joint angle near 90 deg, whose kinematics multiply the inertia torques)")


def parameter(name, start, unit, description, min=None, max=None, type=float, variability="fixed", neutral=None):
    return Var(name, "parameter", unit, description, start, min, max, variability, type=type, neutral=neutral)


#: ranges of the drivetrain ports: +-1e4 rad/s (95,000 rpm) and +-1e7 N.m cover any real driveline and keep
#: every model's arithmetic finite
SPEED_RANGE = dict(min=-1.0e4, max=1.0e4)
TORQUE_RANGE = dict(min=-1.0e7, max=1.0e7)

#: outputs read this many times a period of an order of the input speed, or fewer, alias it (Nyquist)
MIN_SAMPLES_PER_PERIOD = 2.0
#: samples a period the remedy for an aliasing step asks for
RESOLVING_SAMPLES_PER_PERIOD = 10.0


def samples_per_period(order: int, omega: float, interval: float) -> float:
    """Samples per period of the order-th multiple of the speed omega [rad/s] read every interval [s]:
    2 pi / (order |omega| interval); inf at rest."""
    rate = order * abs(omega) * interval
    return 2.0 * math.pi / rate if rate > 0.0 else math.inf


def sampling_interval(samples: float, order: int, omega: float) -> float:
    """The interval [s] that reads the order-th multiple of the speed omega [rad/s] ``samples`` times a period (the
    inverse of :func:`samples_per_period`); inf at rest."""
    rate = samples * order * abs(omega)
    return 2.0 * math.pi / rate if rate > 0.0 else math.inf


def input_(name, start, unit, description, min=None, max=None, used_if=None):
    """An input; used_if names the parameter without which (at 0) the model does not read it."""
    return Var(name, "input", unit, description, start, min, max, used_if=used_if)


def output(name, unit, description, depends_on=()):
    """An output; depends_on names the inputs it depends on directly (its direct feedthrough)."""
    return Var(name, "output", unit, description, depends_on=depends_on)


def reference_problem(variables: dict, vrs, kinds, call: str) -> str:
    """'' where each value reference of vrs names a variable of kinds (a type or tuple of types), one a host may set
    where ``call`` sets (fmi2SetReal, ...: it has a setter), else why not, for the FMI function ``call``
    (fmi2GetReal, fmi3SetInt32, ...)."""
    for vr in vrs:
        var = variables.get(vr)
        if var is None:
            return f"{call}: no variable has value reference {vr} (modelDescription.xml lists them)"
        if not isinstance(var, kinds):
            actual = type(var).__name__
            return (f"{call}: {var.name} (value reference {vr}) is of type {actual}, not {call[7:]}: use "
                    f"{call[:7]}{actual}")
        if call[4:7] == "Set" and getattr(var, "setter", None) is None:
            return (f"{call}: {var.name} (value reference {vr}) cannot be set: its causality is "
                    f"{getattr(var.causality, 'name', var.causality)} (the FMU computes it)")
    return ""


def _checked(method: str, kind: type) -> Callable:
    """pythonfmu's ``method`` (get_integer, ...) for variables of ``kind``, its value references checked first
    (``UjfmuSlave._check_refs``)."""
    call = "fmi2" + method.title().replace("_", "")

    def access(self, vrs, *values):
        self._check_refs(vrs, kind, call)
        return getattr(Fmi2Slave, method)(self, vrs, *values)
    access.__name__ = method
    return access


class UjfmuSlave(Fmi2Slave):
    """Base of every ujfmu FMU. Subclasses set VARIABLES, DEFAULT_EXPERIMENT, and implement
    ``initialize(start_time)``, ``compute_outputs()`` and ``advance(t, h)``; ``check_parameters()`` is optional.

    Every attribute a model sets goes in one of two declarations (else saving the FMU state fails, and the tests):
    ``STATE = {"_state": "float[4]", "_started": "bool"}`` for what ``initialize`` sets and ``advance`` changes
    (saved with the FMU state; kinds in ``KINDS``), ``DERIVED = ("_p",)`` for what ``derive()`` computes from
    the parameters alone (recomputed when a state is restored). PrescribedInputSlave.STATE holds the input angle
    and history; extend it with ``{**PrescribedInputSlave.STATE, ...}``. Attributes set in ``__init__`` before
    ``UjfmuSlave.__init__`` returns are plumbing, outside the state.

    Outputs are computed lazily from the current inputs and state (``compute_outputs`` runs on the first output
    read after any input changed or a step was taken), so outputs with direct feedthrough are exact at every
    communication point whatever order the host sets inputs in.
    """

    def __init_subclass__(cls, **kwargs):
        """A model's build digest is read when its declaration is imported, while the files it covers are there
        for sure: a host may delete an FMU's extraction folder while the module stays imported (pythonfmu reuses
        an imported runtime package for a later instance extracted elsewhere)."""
        super().__init_subclass__(**kwargs)
        parts = cls.__module__.split(".")
        if len(parts) >= 3 and parts[-3] == "models":   # models/<stem>/fmu.py (not the base classes, the pass-through)
            build_digest(model_stem(cls.__module__))

    #: the log categories declared in the modelDescription, one per status the FMUs log with (warning, discard,
    #: error, fatal; :meth:`log` files an ok one, which pythonfmu would put under its undeclared
    #: ``logAll``, under the least severe of them). Not ``logAll`` itself: pythonfmu's C layer passes only messages
    #: of a category the host enabled by name, and no message of ours carries it: a host enabling it alone would see
    #: nothing
    log_categories = {f"logStatus{s}": f"Log messages with fmi2{s} status."
                      for s in ("Warning", "Discard", "Error", "Fatal")}
    PHYSICS = None  # the model's equations module, ujfmu.models.<stem>.model (documentation)
    VARIABLES = ()
    DEFAULT_EXPERIMENT = (0.0, 1.0, 1e-3)  # start, stop, step
    author = "ujfmu"
    license = "MIT"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.description = next(c.__doc__ for c in type(self).__mro__ if c.__doc__).strip().splitlines()[0]
        start, stop, step = self.DEFAULT_EXPERIMENT
        self.default_experiment = DefaultExperiment(start_time=start, stop_time=stop, step_size=step)
        self._stale = True
        self._partial = False      # stale only in the outputs of load_outputs (see _input_setter); plumbing
        self._initialized = False  # initialize() has run with the current parameters
        self._running = False      # past fmi2ExitInitializationMode
        self._terminated = False   # past fmi2Terminate: no more steps
        self._restored = False     # the last fmi2SetFMUstate restored a state into a running instance
        self._inputs = tuple(v for v in self.VARIABLES if v.causality == "input")
        self._start_time = 0.0
        self._derivation = None    # token of the derive() the DERIVED attributes come from (see _set_fmu_state)
        for var in self.VARIABLES:
            if var.causality == "output":
                setattr(self, var.name, 0.0)
                getter, setter = self._output_getter(var.name), None
            else:
                setattr(self, var.name, var.type(var.start))
                setter = (self._parameter_setter if var.causality == "parameter" else self._input_setter)
                getter, setter = None, setter(var.name, var.type)
            self.register_variable(_TYPES[var.type](
                var.name, causality=Fmi2Causality[var.causality],
                variability=Fmi2Variability[var.variability], description=var.description,
                getter=getter, setter=setter))
        # the per-step hot path: Real getters/setters by value reference, the attribute of each Real (every
        # variable is a plain attribute; an output is valid once it is not stale), input bounds (+-DBL_MAX: inf
        # fails too)
        reals = {vr: var for vr, var in self.vars.items() if isinstance(var, Real)}
        self._real_getters = {vr: var.getter for vr, var in reals.items()}
        self._real_setters = {vr: var.setter for vr, var in reals.items()   # pythonfmu gives outputs a setter too
                              if var.setter is not None and var.causality != Fmi2Causality.output}
        self._real_names = {vr: var.name for vr, var in reals.items()}
        self._real_outputs = frozenset(vr for vr, var in reals.items() if var.causality == Fmi2Causality.output)
        # the outputs a read of only which computes only those (``_read_subset``): the model's outputs that are
        # functions of the state alone (``_state_output_names``), or its light outputs (``_light_output_names``),
        # with the inputs and parameters; the state the first were last computed at (None: not since the last
        # restore), and the (state, time, inputs) the second were (``read_light_outputs``)
        subset = self._state_output_names or self._light_output_names
        self._subset_vrs = frozenset(vr for vr, var in reals.items() if var.name in subset)
        self._state_outputs_of = None
        if self._light_output_names:
            self._subset_vrs |= reals.keys() - self._real_outputs
            self._light_of = None
        big = sys.float_info.max
        self._input_bounds = tuple((v.name, -big if v.min is None else v.min, big if v.max is None else v.max, v)
                                   for v in self._inputs)
        # every attribute set so far (the variables, life-cycle flags and plumbing) plus the declared STATE and
        # DERIVED ones: a model attribute outside this set makes _capture fail, so none can be forgotten
        self._known = frozenset(self.__dict__) | {"_known"} | self.STATE.keys() | set(self.DERIVED)
        _LIVE.add(self)

    def log(self, msg, status=Fmi2Status.warning, category=None, debug=None):
        """pythonfmu's log with every '%' doubled: an FMI 2.0 logger message is a printf format (fmi2CallbackLogger),
        which a host expands (fmpy's simulate_fmu, a C host's vsnprintf), so a literal '%' in a figure or in
        the host's own instance name would read as a conversion: garbage, or a crash on '%s'. An ok message goes
        under logStatusWarning (``log_categories``)."""
        if category is None and status == Fmi2Status.ok:
            category = "logStatusWarning"
        super().log(msg.replace("%", "%%"), status, category)

    def _output_getter(self, name):
        def get():
            if self._stale:
                try:
                    if not self._initialized:  # an output read before fmi2ExitInitializationMode
                        invalid = self._invalid()
                        if invalid:
                            raise ValueError(invalid)
                        self._start()
                        self._initialized = True
                    if self._partial:
                        self.compute_load_outputs()
                    else:
                        self.compute_outputs()
                except (Exception, KeyboardInterrupt) as exc:   # a Ctrl-C too: pythonfmu frees what it raises twice
                    self._raise_to_host(f"{self.modelName} '{self.instance_name}': cannot compute {name}: "
                                        f"{INTERRUPTED_IN_FMU if isinstance(exc, KeyboardInterrupt) else exc}")
                self._stale = self._partial = False
            return getattr(self, name)
        return get

    def get_real(self, vrs):
        """fmi2GetReal without pythonfmu's per-variable type dispatch (its own version reports a wrong type): stale
        outputs among vrs are computed first (through an output's getter, which names it in an error), then every
        value is read from the instance's attributes."""
        try:
            if self._stale and not (self._partial and self._load_reads is not None
                                    and self._load_reads.isdisjoint(vrs)):
                if self._subset_vrs and vrs and self._subset_vrs.issuperset(vrs):
                    self._read_subset(vrs)
                else:
                    outputs = self._real_outputs
                    for vr in vrs:
                        if vr in outputs:
                            self._real_getters[vr]()
                            break
            names, values = self._real_names, self.__dict__
            return [values[names[vr]] for vr in vrs]
        except KeyError:
            self._check_refs(vrs, Real, "fmi2GetReal")
            return super().get_real(vrs)

    def set_real(self, vrs, values):
        try:
            setters = self._real_setters
            for vr, value in zip(vrs, values):
                setters[vr](value)
        except KeyError:
            for vr in vrs:
                if vr in self._real_outputs:
                    self._raise_to_host(f"{self.modelName} '{self.instance_name}': {self._real_names[vr]} is an "
                                        "output: the FMU computes it, a host reads it (fmi2GetReal)")
            self._check_refs(vrs, Real, "fmi2SetReal")
            super().set_real(vrs, values)

    def _check_refs(self, vrs, kind, call):
        """Refuse (fmi2Fatal, the cause logged) a value reference ``reference_problem`` names: pythonfmu's own
        refusal is an exception it releases twice, which crashed the host at a second one."""
        problem = reference_problem(self.vars, vrs, kind, call)
        if problem:
            self._raise_to_host(f"{self.modelName} '{self.instance_name}': {problem}")

    get_integer, set_integer = _checked("get_integer", Integer), _checked("set_integer", Integer)
    get_boolean, set_boolean = _checked("get_boolean", Boolean), _checked("set_boolean", Boolean)
    get_string, set_string = _checked("get_string", String), _checked("set_string", String)

    # --- FMU state (fmi2GetFMUstate / SetFMUstate / Serialize; canGetAndSetFMUstate in the modelDescription) ---
    @classmethod
    def state_kinds(cls, initialized):
        """Field name -> kind of the FMU state: variables and life-cycle flags, plus STATE once initialized."""
        kinds = {v.name: v.type.__name__ for v in cls.VARIABLES}
        kinds.update(_LIFECYCLE_KINDS)
        if initialized:
            kinds.update(cls.STATE)
        return kinds

    @classmethod
    def _capture_plan(cls, initialized):
        """The :class:`_CapturePlan` of ``state_kinds(initialized)``, built once per class: what ``_capture`` and
        ``_set_fmu_state`` apply at every save and restore."""
        plans = cls.__dict__.get("_CAPTURE_PLANS")
        if plans is None:
            plans = {flag: _CapturePlan(cls, cls.state_kinds(flag)) for flag in (False, True)}
            cls._CAPTURE_PLANS = plans
        return plans[initialized]

    def _capture(self):
        """The current FMU state, each value normalized to its kind (a tuple of floats for a float[n]), the fields
        in ``state_kinds`` order; an initialized one carries the token of the current derivation."""
        attributes = self.__dict__
        if not attributes.keys() <= self._known:
            undeclared = attributes.keys() - self._known
            raise ValueError(f"attributes {sorted(undeclared)} are neither in STATE nor in DERIVED")
        initialized = bool(self._initialized)
        fields = self._capture_plan(initialized).fields(self)
        return FmuState(type(self), fields, self._derivation if initialized else None)

    def _get_fmu_state(self):
        try:
            return self._capture()
        except Exception as exc:   # a model that does not declare its state: an error status, never a crash
            self._raise_to_host(f"{self.modelName} '{self.instance_name}': cannot save the FMU state: {exc}")

    def _set_fmu_state(self, state):
        """Restore a state of this FMU (values are immutable: one saved state can be restored many times).

        The DERIVED attributes are recomputed from the restored parameters (``derive()``) unless the state carries
        the token of the derivation in place now: ``_derive`` makes a new token at every ``derive()``, a parameter
        set through FMI drops it (``_parameter_setter``), a restore keeps it only when the state carries it, and a
        state carries the token in place when it was saved. So while a token is in place the parameters are those
        it was derived from, and a state carrying it holds the same parameters: the DERIVED attributes already
        follow from them. A deserialized state carries none."""
        if not isinstance(state, FmuState) or state.origin != (type(self).__module__, type(self).__name__):
            self._raise_to_host(f"{self.modelName} '{self.instance_name}': fmi2SetFMUstate was given a state that "
                                "is not one of this FMU's; the instance is unchanged")
        was_running = self._running
        if self._capture_plan(True).plain:
            self.__dict__.update(state.fields)
        else:
            for key, value in state.fields.items():
                setattr(self, key, value)
        self._partial = False
        self._state_outputs_of = None
        if "_light_of" in self.__dict__:   # a restored state's outputs are those it was saved with, whatever the memo
            self._light_of = None
        self._restored = was_running
        if self._terminated:   # a restored state is read, not stepped, after fmi2Terminate (FMI's state machine)
            self._running = False
        if not self._initialized:
            self._derivation = None
        elif state.derivation is None or state.derivation is not self._derivation:
            self._derive()

    def _derive(self):
        """``derive()``, and a new token for the derivation now in place (see ``_set_fmu_state``)."""
        self.derive()
        self._derivation = object()

    @staticmethod
    def _fmu_state_to_bytes(state):
        return encode_state(state)

    @classmethod
    def _fmu_state_from_bytes(cls, data):
        """fmi2DeSerializeFMUstate: pythonfmu calls this on the class, so a rejection pins the objects of every
        live instance of the class (see _PINNED_AFTER_EXCEPTION) and logs the reason to the instance when it is
        the only one (pythonfmu's own fmi2Fatal message does not always carry it: docs/security.md)."""
        try:
            return decode_state(cls, bytes(data))
        except Exception as exc:    # StateError; anything else is a bug, but must not reach pythonfmu unpinned
            reason = exc if isinstance(exc, StateError) else repr(exc)
            message = (f"{cls.__name__}: FMU state rejected, the instance is unchanged: {reason} (said by every live "
                       "instance of this FMU: the wrapper deserializes a state without naming the instance)")
        callers = [inst for inst in list(_LIVE) if type(inst) is cls]
        for inst in callers:
            _PINNED_AFTER_EXCEPTION.extend((inst, inst, cls, inst.log_queue))
            if len(callers) == 1:
                inst.log(message, Fmi2Status.error)
        _PINNED_AFTER_EXCEPTION.append(cls)
        raise ValueError(message)

    def _raise_to_host(self, message):
        """Log at error level, pin what pythonfmu will release twice, and raise (the host gets fmi2Fatal)."""
        self.log(message, Fmi2Status.error)
        _PINNED_AFTER_EXCEPTION.extend((self, self, type(self), self.log_queue))
        raise ValueError(message)

    def _input_setter(self, name, cast):
        """The setter of input ``name``: an input the outputs do not depend on (``_output_free``) leaves them valid;
        one of ``_load_inputs`` set while they are valid, or stale only in the outputs of ``compute_load_outputs``,
        leaves them stale only there (``_partial``); any other input makes all of them stale."""
        def set_(value):
            value = cast(value)
            if value == getattr(self, name):   # unchanged (a constant load, a held speed): outputs stay valid
                return
            setattr(self, name, value)
            if name not in self._output_free:
                self._partial = name in self._load_inputs and self._running and (self._partial or not self._stale)
                self._stale = True
            if not self._running:
                self._initialized = False
        return set_

    def _parameter_setter(self, name, cast):
        """The setter of parameter ``name``: as an input's, and the DERIVED attributes no longer count as following
        from the parameters (a later restore recomputes them)."""
        set_value = self._input_setter(name, cast)

        def set_(value):
            if self._running and cast(value) != getattr(self, name):   # a fixed parameter (FMI 2.0, 2.2.7)
                self._raise_to_host(f"{self.modelName} '{self.instance_name}': parameter {name} is fixed: it is set "
                                    "before fmi2ExitInitializationMode (or after fmi2Reset), not while stepping; "
                                    f"it stays {getattr(self, name)!r}")
            set_value(value)
            self._derivation = None
        return set_

    # --- hooks for the models ---
    #: names of outputs that are functions of the model state alone (no input): a read of only these while the
    #: outputs are stale computes only them (``_read_subset``); a host reads them first in a step
    _state_output_names = ()

    #: names of outputs that cost a fraction of the others (a rotor's motion without its joint's kinematics): a read
    #: of only these, inputs and parameters while the outputs are stale computes only them (``read_light_outputs``),
    #: the others staying stale; a model has these or ``_state_output_names``, not both
    _light_output_names = ()

    def _read_subset(self, vrs):
        """Make the outputs among vrs (all in ``_subset_vrs``) valid (default: all outputs, as any read does)."""
        outputs = self._real_outputs
        for vr in vrs:
            if vr in outputs:
                self._real_getters[vr]()
                break

    #: model attributes that evolve and are saved with the FMU state: name -> kind ("float", "float|None", "int",
    #: "bool", "float[n]"); set by initialize(), changed by advance()
    STATE = {}
    #: model attributes computed from the parameters by derive(), recomputed when a state is restored
    DERIVED = ()
    #: names of the inputs the outputs do not depend on (a change leaves them valid); set by derive()
    _output_free = frozenset()
    #: names of the inputs only the outputs of ``compute_load_outputs`` depend on; set by derive()
    _load_inputs = frozenset()
    #: value references of the outputs ``compute_load_outputs`` computes, where the model names them (a read of
    #: none of them while only those are stale computes nothing: the others are valid); None: any read does
    _load_reads = None

    def derive(self):
        """Set the DERIVED attributes from the parameters (runs before initialize and after a state restore)."""

    def check_parameters(self):
        """Model-specific consistency checks; return a list of messages (empty when valid)."""
        return []

    def initialize(self, start_time):
        raise NotImplementedError

    def compute_outputs(self):
        raise NotImplementedError

    def compute_load_outputs(self):
        """The outputs that depend on the ``_load_inputs``, when only those changed since the outputs were last
        computed (default: all of them)."""
        self.compute_outputs()

    def advance(self, t, h):
        raise NotImplementedError

    # --- FMI life cycle ---
    def setup_experiment(self, start_time, stop_time=None, tolerance=None):
        self._start_time = start_time

    def _problems(self, causalities=("parameter", "input")):
        """{causality: messages} for every parameter or input outside its range, else {'parameter': the model's
        own checks}; empty when all is well."""
        problems = {c: [m for m in (v.check(getattr(self, v.name)) for v in self.VARIABLES if v.causality == c) if m]
                    for c in causalities}
        problems = {c: ms for c, ms in problems.items() if ms}
        own = [] if problems else list(self.check_parameters())
        return problems or ({"parameter": own} if own else {})

    def _invalid(self, causalities=("parameter", "input")):
        """'' if the parameters and inputs are valid, else 'invalid parameters: ...; invalid inputs: ...' naming each
        invalid one with its allowed range (inputs named as inputs)."""
        return "; ".join(f"invalid {c}s: " + "; ".join(ms) for c, ms in self._problems(causalities).items())

    def _start(self):
        self._derive()
        self.initialize(self._start_time)

    def exit_initialization_mode(self):
        if self._running:   # a state saved while stepping, restored in initialization mode: it is the state now
            return
        invalid = self._invalid()
        if invalid:
            self._raise_to_host(f"{self.modelName} '{self.instance_name}': {invalid}")
        self._start()
        self._initialized = self._running = self._stale = True
        self._partial = False
        for message in self.parameter_advice():
            self.log(f"{self.modelName} '{self.instance_name}': {message}", Fmi2Status.warning)

    def parameter_advice(self):
        """Warnings on valid parameters that are likely not what was meant (the model's ``advice``)."""
        return []

    def _input_problem(self, var, value, current_time, step_size):
        """Why an input out of its range refuses the step: at the first step the likely unit slip (a host's table in
        rpm or deg); later a coupling going unstable first (``UNSTABLE_INPUT``), the slip after it."""
        if current_time <= self._start_time + 0.5 * step_size or not math.isfinite(value):
            return var.check(value)
        slip = var.unit_hint(value)
        return var.check(value, hint=False) + UNSTABLE_INPUT + (
            f"; or, if the host gives this input in another unit: {slip.strip()[1:-1]}" if slip else "")

    #: where the last step ended (ModelSlave: the time of its state; None: not kept) and whether a host's step from
    #: elsewhere has been said (:meth:`_say_time_jump`; True: not watched)
    _time, _clock_said = None, True

    def _say_time_jump(self, current_time, step_size):
        """Log once, as a warning, a step that does not start at the time of the FMU's state (:meth:`do_step` calls
        it beyond the rounding of a host's time arithmetic, 1e-9 of the time): a step back or a jump without
        restoring a saved FMU state, or after restoring one saved at another time. The FMI standard leaves the time
        axis to the host, so the step is taken (from the state where it is, over step_size, the host's time from
        then on), but the run is not what the host's time axis says it is."""
        last, self._clock_said = self._time, True
        kind = "back" if current_time < last else "forward"
        self.log(f"{self.modelName} '{self.instance_name}': a step starts at t = {current_time:.10g} s, {kind} from "
                 f"the time of the FMU's state ({last:.10g} s: where the last step ended, or a restored FMU state was "
                 f"saved): the FMU steps its state at {last:g} s over {step_size:g} s and takes the host's time from "
                 f"there (time-dependent inputs, such as a Motor's profile, follow it), so the run skips or repeats "
                 f"{abs(current_time - last):.6g} s of this model's motion. Check the host's time axis: each step "
                 "starts where the last ended, or after restoring the FMU state saved there. (Said once per "
                 "instance.)", Fmi2Status.warning)

    def terminate(self):
        """fmi2Terminate: the outputs stay readable, a later fmi2DoStep is refused (:data:`TERMINATED`)."""
        self._running, self._terminated = False, True

    def do_step(self, current_time, step_size):
        try:
            if not self._running:
                raise ValueError(TERMINATED if self._terminated else RESTORED_UNRUN
                                 if self._restored and self._initialized else NOT_INITIALIZED)
            if not (step_size > 0.0 and math.isfinite(step_size)):
                raise ValueError(f"communication step size = {step_size!r} must be finite and > 0")
            values = self.__dict__
            for name, lo, hi, var in self._input_bounds:
                if not lo <= values[name] <= hi:   # NaN and inf fail too
                    raise ValueError(self._input_problem(var, values[name], current_time, step_size))
            t0 = self._time   # one line: a host's rounding (t0 != current_time) costs no more lines or calls
            if not self._clock_said and t0 != current_time and abs(current_time - t0) > 1e-9 * (abs(t0) + step_size):
                self._say_time_jump(current_time, step_size)
            self.advance(current_time, step_size)
            self._stale, self._partial = True, False
            return True
        except KeyboardInterrupt:   # a Ctrl-C in its code: the host stops (fatal), what pythonfmu frees twice pinned
            self._raise_to_host(f"{self.modelName} '{self.instance_name}': step at t = {current_time!r} "
                                f"interrupted ({INTERRUPTED_IN_FMU})")
        except Exception as exc:  # reported to the host, never raised into it
            self.log(f"{self.modelName} '{self.instance_name}': step at t = {current_time!r} refused: {exc}",
                     Fmi2Status.error)
            return False


class ModelSlave(UjfmuSlave):
    """An FMU over a model that implements the protocol of ``ujfmu.models.protocol``: a subclass declares MODEL (the
    model module), VARIABLES and DEFAULT_EXPERIMENT, nothing else. This class does the rest, once for every model:

    - the parameters object ``MODEL.Parameters`` from the FMU's parameters (by name), and ``MODEL.check`` on it;
    - the state: ``MODEL.initial_state`` at the current inputs until the first step (the warm start: a host may
      set the inputs after initialization), then integrated, or held while ``MODEL.kinematic(p)``;
    - a step: classical RK4 (``rk4.unrolled``) with ``rk4.substeps`` from ``MODEL.rate_bound``, the inputs
      held (a prescribed input shaft extrapolated, see PrescribedInputSlave), or the model's own ``integrate``
      where it has one; then the finite check and
      ``MODEL.check_state`` of the new state;
    - the outputs: ``MODEL.outputs`` assigned by name, recomputed on the first read after a step or a change of an
      input outside ``MODEL.output_free_inputs(p)``; where only the ``LOAD_INPUTS`` (tau_load; a torque-driven
      FMU's torques) changed since they were computed and the model has ``load_outputs``, only those (the others
      do not depend on them); a read of only the model's ``STATE_OUTPUTS`` computes only those
      (``MODEL.state_outputs``, once per state), and a read of only its ``LIGHT_OUTPUTS`` only those
      (``MODEL.light_outputs``, again only where the state, time or inputs changed).

    Subclasses provide ``model_inputs()`` (the model's inputs now) and may replace ``rk4_step`` (the RK4 substeps
    of one step, inputs held) or ``integrate`` (the whole step) and extend ``initialize``/``advance`` for what their
    inputs need (PrescribedInputSlave: the input shaft's angle, extrapolated over the step).
    """

    MODEL = None
    STATE = {"_time": "float", "_started": "bool", "_aliasing_said": "bool",
             "_state_advice_said": "bool", "_clock_said": "bool"}   # plus "_y", the model state
    #: h |omega_in| at and above which a host that reads the outputs every step h aliases the model's
    #: ``EXCITATION_ORDER`` (at most MIN_SAMPLES_PER_PERIOD reads a period), or its ``excitation_order(p)`` at these
    #: parameters where it has one (:meth:`derive`); inf: none
    _aliasing_reach = math.inf
    _excitation_order = None
    #: how the RK4 stages call the model (``rk4._KINDS``); ``_rk4``, set in __init_subclass__, integrates a step
    RK4_KIND = "held"
    #: the model's own ``integrate(p, t, h, y, u)`` where it has one (the protocol's optional whole-step integrator)
    _own_step = None
    #: the model's own ``integrate_with_history(p, t, h, y, u, history)`` where it has one (the protocol's option)
    _history_step = None
    #: the model's ``check_state(p, y)`` where it has one (the protocol's option)
    _check_state = None
    #: the model's ``state_advice(p, h, y, u)`` where it has one (the protocol's option: warnings on a state reached
    #: by a step of h under the inputs u that is valid but likely not meant; said once per instance)
    _state_advice = None
    #: the model's ``outputs(p, t, y, u)``, its ``state_outputs(p, t, y)`` and ``light_outputs(p, t, y, u)`` where it
    #: has them (the protocol's options: the outputs it names in ``STATE_OUTPUTS`` and ``LIGHT_OUTPUTS``)
    _outputs = _state_outputs = _light_outputs = None
    DERIVED = ("_p", "_output_free", "_kinematic", "_load_inputs", "_load_reads", "_excitation_order",
               "_aliasing_reach")
    #: the inputs ``MODEL.load_outputs`` covers (the outputs that depend on them are all in it)
    LOAD_INPUTS = ("tau_load",)

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        model = cls.__dict__.get("MODEL")
        if model is not None:   # a model module, or a variant's protocol class inside one (documented: the module)
            cls.PHYSICS = sys.modules[model.__module__] if isinstance(model, type) else model
            cls.STATE = {**cls.STATE, "_y": f"float[{len(model.State._fields)}]"}
            cls._rk4 = staticmethod(rk4.unrolled(cls.RK4_KIND, len(model.State._fields)))
            if hasattr(model, "integrate"):   # the model integrates its own steps
                cls._own_step = staticmethod(model.integrate)
            if hasattr(model, "check_state"):
                cls._check_state = staticmethod(model.check_state)
            if hasattr(model, "state_advice"):
                cls._state_advice = staticmethod(model.state_advice)
            cls._outputs = staticmethod(model.outputs)
            cls._excitation_order = getattr(cls.PHYSICS, "EXCITATION_ORDER", None)
            if hasattr(model, "state_outputs"):
                cls._state_outputs = staticmethod(model.state_outputs)
                cls._state_output_names = tuple(model.STATE_OUTPUTS)
            if hasattr(model, "light_outputs"):
                if hasattr(model, "state_outputs"):
                    raise TypeError(f"{cls.__name__}: a model declares STATE_OUTPUTS or LIGHT_OUTPUTS, not both")
                cls._light_outputs = staticmethod(model.light_outputs)
                cls._light_output_names = tuple(model.LIGHT_OUTPUTS)
            if hasattr(model, "integrate_with_history"):   # a multistep integrator: its history is FMU state
                cls._history_step = staticmethod(model.integrate_with_history)
                cls.STATE = {**cls.STATE, "_history": f"float[{len(model.NO_HISTORY)}]"}

    def parameters(self):
        """The FMU's parameters as the model's Parameters."""
        return model_parameters(self.MODEL, self)

    def check_parameters(self):
        return self.MODEL.check(self.parameters())

    def parameter_advice(self):
        return getattr(self.MODEL, "advice", _no_advice)(self._p)

    def derive(self):
        self._p = self.parameters()
        self._output_free = frozenset(getattr(self.MODEL, "output_free_inputs", _no_inputs)(self._p))
        loads = set(self.LOAD_INPUTS) if hasattr(self.MODEL, "load_outputs") else set()
        self._load_inputs = frozenset(loads & {v.name for v in self.VARIABLES if v.causality == "input"}
                                      - self._output_free)
        names = getattr(self.MODEL, "load_output_names", None)
        self._load_reads = None
        if names is not None and self._load_inputs:   # value references: the VARIABLES' order (UjfmuSlave.__init__)
            vr_of = {var.name: vr for vr, var in enumerate(self.VARIABLES)}
            self._load_reads = frozenset(vr_of[name] for name in names(self._p))
        self._kinematic = bool(getattr(self.MODEL, "kinematic", _never)(self._p))
        order = getattr(self.PHYSICS, "EXCITATION_ORDER", None)
        if order and hasattr(self.PHYSICS, "excitation_order"):
            order = self.PHYSICS.excitation_order(self._p)
        self._excitation_order = order
        self._aliasing_reach = sampling_interval(MIN_SAMPLES_PER_PERIOD, order, 1.0) if order else math.inf

    def initialize(self, start_time):
        self._time, self._started, self._aliasing_said, self._state_advice_said = start_time, False, False, False
        self._clock_said = False
        self._y = tuple(self.MODEL.initial_state(self._p, start_time, self.model_inputs()))
        if self._history_step is not None:
            self._history = self.MODEL.NO_HISTORY

    def model_inputs(self):
        """The model's inputs (its Inputs) now, from the FMU's input variables."""
        raise NotImplementedError

    def current_state(self, u):
        """The model state now: after the first step the integrated (or, kinematic, held) one, before it
        initial_state at the current inputs u (the warm start)."""
        if self._started:
            return self._y
        return tuple(self.MODEL.initial_state(self._p, self._time, u))

    def output_inputs(self):
        """The model's inputs the outputs are computed at (default: ``model_inputs()``)."""
        return self.model_inputs()

    def compute_outputs(self, outputs=None, u=None):
        """The output variables from ``MODEL.outputs`` (or the function outputs given, of the same arguments) at the
        current time, state and inputs (u, else ``output_inputs``); returns the inputs."""
        if u is None:
            u = self.output_inputs()
        vars(self).update((outputs or self._outputs)(self._p, self._time,
                                                     self._y if self._started else self.current_state(u), u))
        return u

    def _read_subset(self, vrs):
        """The outputs of a read of only ``_subset_vrs``: the light outputs where the model has them
        (:meth:`read_light_outputs`), else ``MODEL.state_outputs`` at the current state, once per state (the other
        outputs stay stale); before the first step, every output (the state then follows the inputs: the warm
        start)."""
        if self._light_outputs is not None:
            self.read_light_outputs(vrs)
            return
        y = self._y if self._running and self._started else None
        if y is None:
            self._real_getters[vrs[0]]()
        elif self._state_outputs_of is not y:
            try:
                vars(self).update(self._state_outputs(self._p, self._time, y))
            except Exception as exc:
                self._raise_to_host(f"{self.modelName} '{self.instance_name}': cannot compute "
                                    f"{self._real_names[vrs[0]]}: {exc}")
            self._state_outputs_of = y

    def read_light_outputs(self, vrs):
        """``MODEL.light_outputs`` at the current time, state and inputs (``compute_outputs``; the other outputs
        stay stale), again only where one of the three changed since (``_light_of``); nothing for a read of inputs
        and parameters alone; before the first step, every output."""
        if self._real_outputs.isdisjoint(vrs):
            return
        if not (self._running and self._started):
            UjfmuSlave._read_subset(self, vrs)
            return
        try:
            u = self.output_inputs()
            seen = self._light_of
            if seen is not None and seen[0] is self._y and seen[1] == self._time and seen[2] == u:
                return
            self.compute_outputs(self._light_outputs, u)
        except (Exception, KeyboardInterrupt) as exc:   # as an output's getter
            name = next(self._real_names[vr] for vr in vrs if vr in self._real_outputs)
            self._raise_to_host(f"{self.modelName} '{self.instance_name}': cannot compute {name}: "
                                f"{INTERRUPTED_IN_FMU if isinstance(exc, KeyboardInterrupt) else exc}")
        self._light_of = self._y, self._time, u

    def compute_load_outputs(self):
        """``MODEL.load_outputs``: the outputs that depend on the ``LOAD_INPUTS``, at the current time, state and
        inputs (``output_inputs``)."""
        u = self.output_inputs()
        vars(self).update(self.MODEL.load_outputs(self._p, self._time, self.current_state(u), u))

    def advance(self, t, h):
        """Step the state from t to t + h (:meth:`step_state`, or held while kinematic); returns the inputs
        (``model_inputs()``) held over the step (None for a kinematic model after its first step: nothing used
        them)."""
        if self._kinematic:
            u = None
            if not self._started:
                u = self.model_inputs()
                self._y, self._started = self.current_state(u), True
            self._time = t + h
            return u
        u = self.model_inputs()
        self.step_state(t, h, u)
        return u

    def step_state(self, t, h, u):
        """The state from t to t + h under the inputs u (:meth:`integrate`), checked finite and by the model's
        ``check_state`` (a refusal), its ``state_advice`` said once (a warning), and the time."""
        try:
            y = self.integrate(t, h, self._y if self._started else self.current_state(u), u)
        except rk4.TooManySubsteps as exc:   # which parameters make the rate, where the model can say
            sources = getattr(self.MODEL, "rate_sources", None)
            if sources is None or not sources(self._p):
                raise
            raise ValueError(f"{exc}; the parameters to check, by the bound of the natural rate of each part of "
                             "the model at these parameters, the fastest first: "
                             + ", ".join(f"{what} {rate:.3g} 1/s"
                                         for what, rate in sorted(sources(self._p), key=lambda s: -s[1]))) from None
        if not math.isfinite(sum(y)) and not all(map(math.isfinite, y)):   # a sum is finite unless one is not
            raise ValueError(f"the state became non-finite over the step ({y!r})")
        if self._check_state is not None:
            problems = self._check_state(self._p, y)
            if problems:
                raise ValueError("; ".join(problems))
        if self._state_advice is not None and not self._state_advice_said:
            said = self.state_advice_text(t + h, h, y, u)
            if said:
                self.log(said, Fmi2Status.warning)
        self._y, self._started, self._time = y, True, t + h

    def state_advice_text(self, t, h, y, u):
        """The model's ``state_advice`` on the state y at time t (reached by a step of h under the inputs u) as
        one message, the instance marked as having said it; None where it says nothing."""
        advice = self._state_advice(self._p, h, y, u)
        if not advice:
            return None
        self._state_advice_said = True
        return (f"{self.modelName} '{self.instance_name}': at t = {t:g} s " + "; ".join(advice)
                + " (Said once per instance.)")

    def say_aliasing(self, h, omega):
        """Log once, as a warning, that outputs read every step of h alias the model's ``EXCITATION_ORDER`` at the
        input speed omega [rad/s] (the caller checks h |omega| >= ``_aliasing_reach``): a host plotting or storing
        them at its communication points sees a false waveform (at a step of a whole number of the order's periods,
        one phase of it: a constant), though the state is integrated as accurately as at any step."""
        self._aliasing_said = True
        order, omega = self._excitation_order, abs(omega)
        reads = f"{samples_per_period(order, omega, h):.3g}"
        reads = "once" if reads == "1" else "twice" if reads == "2" else f"{reads} times"
        self.log(f"{self.modelName} '{self.instance_name}': at t = {self._time:g} s a communication step of {h:g} s "
                 f"reads the outputs {reads} a period of the input speed's "
                 f"{order}x order ({order * omega / (2.0 * math.pi):.4g} Hz at {omega:.6g} rad/s), at most "
                 f"{MIN_SAMPLES_PER_PERIOD:g}: read at the communication points they alias it (a step of a whole "
                 f"number of its periods reads one phase of it, a constant); a step of at most "
                 f"{sampling_interval(RESOLVING_SAMPLES_PER_PERIOD, order, omega):.3g} s reads it "
                 f"{RESOLVING_SAMPLES_PER_PERIOD:g} times a period. The integration within a step is unaffected. "
                 f"(Said once per instance.)", Fmi2Status.warning)

    def integrate(self, t, h, y, u):
        """The state y at t advanced to t + h by the model's own ``integrate_with_history`` (its history advanced
        with it) or ``integrate``, else ``rk4_step``."""
        if self._history_step is not None:
            y, self._history = self._history_step(self._p, t, h, y, u, self._history)
            return tuple(y)
        if self._own_step is not None:
            return tuple(self._own_step(self._p, t, h, y, u))
        return self.rk4_step(t, h, y, u)

    def rk4_step(self, t, h, y, u):
        """RK4 substeps (``substeps``) of ``MODEL.derivatives``, the inputs u (``model_inputs()``) held."""
        return self._rk4(self.MODEL.derivatives, self._p, t, u, y, h, self.substeps(h, y, u))

    def substeps(self, h, y, u, omega_max=None):
        """RK4 substeps for a step of h from state y under the inputs u: ``rk4.substeps`` of ``MODEL.rate_bound``
        at omega_max, the bound of the input speeds over the step (default ``speed_bound``)."""
        if omega_max is None:
            omega_max = self.speed_bound(h, u)
        return rk4.substeps(self.MODEL.rate_bound(self._p, y, omega_max), h)

    def speed_bound(self, h, u):
        """Bound [rad/s] of the input speeds over the next step of h from the inputs u now (0: the model has no
        input speed)."""
        return 0.0


#: a NamedTuple of inputs from a tuple of its fields, without the Python frame of its generated ``__new__``
_new_inputs = tuple.__new__


def model_parameters(model, fmu):
    """model.Parameters from the FMU's variables of the same names."""
    names = [f.name for f in dataclasses.fields(model.Parameters) if f.init]
    return model.Parameters(**{name: getattr(fmu, name) for name in names})


def _never(p):
    return False


def drive_derivatives(model) -> Callable:
    """The ``drive_derivatives(p, t, y, phi, omega, alpha, tau_load)`` of a model whose inputs are a Drive: its
    own (the protocol's optional plain-float form), else its ``derivatives`` at ``Drive(phi, omega, alpha,
    tau_load)``."""
    own = getattr(model, "drive_derivatives", None)
    if own is not None:
        return own
    derivatives = model.derivatives

    def at_drive(p, t, y, phi, omega, alpha, tau_load):
        return derivatives(p, t, y, Drive(phi, omega, alpha, tau_load))
    return at_drive


def _no_inputs(p):
    return ()


def _no_advice(p):
    return []


#: ``PrescribedInputSlave.input_acceleration`` takes the speed's curvature for a corner (an acceleration that jumped
#: from flat) where the acceleration changed over the last step by more than KINK of |s1| + |s0| while the largest
#: acceleration before it, each step's weighed by DECAY per step since, is below CORNER of that change
KINK, CORNER, DECAY = 0.9, 0.1, 0.9


class PrescribedInputSlave(ModelSlave):
    """Base of the drivetrain FMUs whose input shaft follows ``omega_in`` (a prescribed motion); the model's inputs
    are ``ujfmu.models.protocol.Drive`` (angle, speed, acceleration of the input shaft, load torque).

    Over a communication step h the input angle is phi(t) = phi + omega_in t + alpha t^2 / 2, alpha the backward
    difference of omega_in over the previous step (0 before the first), or its second-order estimate where the FMU
    declares ACCELERATION_ORDER = 2 (``input_acceleration``): exact for constant speed and constant
    acceleration. The angle is summed with Kahan's compensation, so after 10^6 steps its round-off is a few ulps
    of the angle, not 10^6 of them. The outputs phi_in and alpha_in are the shaft's angle and acceleration. Outputs
    read after a step before omega_in is set again are at the input motion the step ended with
    (``output_inputs``).
    """

    #: before the first step: the outputs at model_inputs() (``output_inputs``)
    _input_set, _alpha_step = True, 0.0
    #: the model's ``speed_jump`` (None: it has none)
    _speed_jump = None
    STATE = {**ModelSlave.STATE, "_phi_in": "float", "_phi_in_carry": "float", "_omega_prev": "float|None",
             "_h_prev": "float", "_omega_prev2": "float|None", "_h_prev2": "float", "_accel_peak": "float",
             "_alpha_step": "float", "_input_set": "bool"}
    RK4_KIND = "drive"
    #: 1: alpha the backward difference of omega_in over the last step; 2: the second-order (BDF2) slope at t_k
    ACCELERATION_ORDER = 1

    def initialize(self, start_time):
        self.start_input(self.phi_in_start)
        super().initialize(start_time)

    def start_input(self, phi_start):
        self._phi_in, self._phi_in_carry = phi_start, 0.0
        self._omega_prev, self._h_prev = None, 0.0     # omega_in at the previous communication point
        self._omega_prev2, self._h_prev2 = None, 0.0   # and at the one before
        self._accel_peak = -1.0   # the largest |slope| before the last one, decayed (-1: none yet, no corner)
        self._alpha_step, self._input_set = 0.0, True   # the last step's alpha; omega_in set since that step

    def input_acceleration(self):
        """alpha at t_k: the backward difference s1 = (w_k - w_k-1)/h (0 before the first step); with
        ACCELERATION_ORDER 2, from the third point on, the slope at t_k of the parabola through w_k, w_k-1, w_k-2
        (BDF2, (3 w_k - 4 w_k-1 + w_k-2) / 2h = s1 + (s1 - s0) / 2 for equal steps), where the speed's curvature
        is smooth: the parabola's term is left out at a corner from flat, where the acceleration changed over the
        last step by more than ``KINK`` of |s1| + |s0| while every acceleration before, weighed by ``DECAY`` per step
        since (``_accel_peak``), is below ``CORNER`` of that change. There the acceleration jumped at the last
        communication point (a set-point step, a drive braking at its limit from a steady speed): the parabola
        through the corner had overshot the new acceleration by half its jump, and a torque J alpha with it, at
        any step; s1 is exact on the constant acceleration after it. A smooth speed's acceleration has been as large
        as its change within the last steps (of 20000 random ramp-plus-swing speeds sampled 12-60 times a period, 2
        meet both), and so has a growing step-rate oscillation's (its stability with BDF2 is
        unchanged: docs/cosimulation.md). Not a corner: a jump inside a step (the next point still overshoots by up
        to half of it), or between two large accelerations. An input unchanged since the last point (a constant
        speed, a host that holds it) gives 0 either way; outputs read before the host sets it after a step are at
        the step's own alpha (``output_inputs``)."""
        if self._omega_prev is None:
            return 0.0
        slope = (self.omega_in - self._omega_prev) / self._h_prev
        if self.ACCELERATION_ORDER == 1 or self._omega_prev2 is None or slope == 0.0:
            return slope
        h1, h2 = self._h_prev, self._h_prev2
        before = (self._omega_prev - self._omega_prev2) / h2
        jump = abs(slope - before)
        if jump > KINK * (abs(slope) + abs(before)) and 0.0 <= self._accel_peak < CORNER * jump:
            return slope
        return slope + h1 * (slope - before) / (h1 + h2)

    #: the input shaft's outputs every such FMU declares (``compute_outputs`` sets them; an attribute the FMU does
    #: not declare could not be saved with its state, fmi2GetFMUstate)
    INPUT_SHAFT_OUTPUTS = ("phi_in", "alpha_in")

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        model = cls.__dict__.get("MODEL")
        if model is not None:
            cls._drive_derivatives = staticmethod(drive_derivatives(model))
            jump = getattr(model, "speed_jump", None)
            cls._speed_jump = None if jump is None else staticmethod(jump)
            if cls._light_output_names:   # compute_outputs sets the input shaft's outputs with any others
                cls._light_output_names += tuple(n for n in cls.INPUT_SHAFT_OUTPUTS if n not in cls._light_output_names)
        declared = {v.name for v in cls.__dict__.get("VARIABLES", ()) if v.causality == "output"}
        missing = [name for name in cls.INPUT_SHAFT_OUTPUTS if declared and name not in declared]
        if missing:
            raise TypeError(f"{cls.__name__}: a PrescribedInputSlave declares the outputs {', '.join(missing)} "
                            "(the input shaft's angle [rad] and acceleration [rad/s2], which it computes with every "
                            "output): add output(...) for each to VARIABLES, as the CardanJoint does")

    def model_inputs(self):
        return _new_inputs(Drive, (self._phi_in, self.omega_in, self.input_acceleration(), self.tau_load))

    def output_inputs(self):
        """``model_inputs()``, but between a step and the host's next setting of omega_in (a host that reads its
        outputs first: fmpy's ``simulate_fmu``, libcosim) the input motion at the step's end as the step
        extrapolated it: speed omega_in + alpha h at the step's alpha, not the held speed with alpha 0 (which
        would drop the inertia torque J alpha from tau_in)."""
        if self._input_set:
            return _new_inputs(Drive, (self._phi_in, self.omega_in, self.input_acceleration(), self.tau_load))
        alpha = self._alpha_step
        return _new_inputs(Drive, (self._phi_in, self.omega_in + alpha * self._h_prev, alpha, self.tau_load))

    def _input_setter(self, name, cast):
        """omega_in's setter also ends the outputs' reading at the last step's end motion (``output_inputs``): the
        outputs become stale, even if the value is unchanged."""
        set_value = super()._input_setter(name, cast)
        if name != "omega_in":
            return set_value

        def set_(value):
            if not self._input_set:
                self._input_set, self._stale, self._partial = True, True, False
            set_value(value)
        return set_

    def rk4_step(self, t, h, y, u):
        """The RK4 substeps with the input shaft extrapolated from u over the step (angle quadratic, speed linear
        in time: Eq. above) and tau_load held, through the model's ``drive_derivatives``."""
        return self._rk4(self._drive_derivatives, self._p, t, y, h, self.substeps(h, y, u), u.phi, u.omega, u.alpha,
                         u.tau_load)

    def speed_bound(self, h, u):
        return max(abs(u.omega), abs(u.omega + u.alpha * h))

    def compute_outputs(self, outputs=None, u=None):
        """ModelSlave's (at ``output_inputs``; at the state with the model's ``speed_jump`` to the omega_in set since
        the last step, :meth:`jumped`), and the input shaft's phi_in and alpha_in."""
        if u is None:
            u = self.output_inputs()
        if self._started:
            y = self._y if self._speed_jump is None or not self._input_set else self.jumped(self._y, u[1])
        else:
            y = self.current_state(u)
        vars(self).update((outputs or self._outputs)(self._p, self._time, y, u))
        self.phi_in, self.alpha_in = u[0], u[2]
        return u

    def jumped(self, y: tuple, omega: float) -> tuple:
        """y after the model's ``speed_jump`` from the speed the last step extrapolated the input to (omega_in + alpha
        h of that step) to omega; y itself before the first step or where the two are equal."""
        prev = self._omega_prev
        if prev is None:
            return y
        end = prev + self._alpha_step * self._h_prev
        return y if omega == end else tuple(self._speed_jump(self._p, y, end, omega))

    def advance(self, t, h):
        """ModelSlave's step (:meth:`step_state` at ``model_inputs()``, or held while kinematic), then the input
        angle over it (Kahan-summed) and the speed history."""
        omega, alpha = self.omega_in, self.input_acceleration()
        if self._kinematic:
            u = ModelSlave.advance(self, t, h)
        else:
            if self._speed_jump is not None and self._started:
                self._y = self.jumped(self._y, omega)
            u = _new_inputs(Drive, (self._phi_in, omega, alpha, self.tau_load))
            self.step_state(t, h, u)
        if h * abs(omega) >= self._aliasing_reach and not self._aliasing_said:
            self.say_aliasing(h, omega)
        increment = h * (omega + 0.5 * alpha * h) - self._phi_in_carry
        total = self._phi_in + increment
        self._phi_in_carry = (total - self._phi_in) - increment
        self._phi_in = total
        if self.ACCELERATION_ORDER == 2 and self._omega_prev2 is not None:   # the corner rule's decayed peak
            before = abs(self._omega_prev - self._omega_prev2) / self._h_prev2
            self._accel_peak = max(before, DECAY * self._accel_peak)
        self._omega_prev2, self._h_prev2 = self._omega_prev, self._h_prev
        self._omega_prev, self._h_prev = omega, h
        self._alpha_step, self._input_set = alpha, False
        return u


# --- FMU state: in memory and serialized ---------------------------------------------------------------------------
#: kinds of state values: "float" (finite), "float|None", "int", "bool", "float[n]" (a tuple of n finite floats);
#: the variables use their own type, and an input may hold any float (the host may set one; steps refuse it)
KINDS = ("float", "float|None", "int", "bool", "float[n]")
STATE_MAGIC = b"UJFMU-STATE\n"
STATE_FORMAT_VERSION = 1
_MAX_STATE_BYTES = 1 << 20
_DIGEST = 32


class StateError(ValueError):
    """A serialized FMU state that this FMU does not accept."""


class FmuState:
    """An FMU state: the model's name and its fields (name -> immutable plain value); in memory, also the token of
    the derivation the saving instance had in place (``UjfmuSlave._set_fmu_state``), never serialized."""

    __slots__ = ("origin", "fields", "derivation")

    def __init__(self, cls, fields, derivation=None):
        self.origin, self.fields, self.derivation = (cls.__module__, cls.__name__), fields, derivation


class _CapturePlan:
    """How the fields of one ``state_kinds`` of an FMU class are read and normalized at a save.

    ``per_field``: (name, normalizer of its kind) per field, in ``state_kinds`` order. ``plain``: every field is an
    ordinary instance attribute (no data descriptor of that name on the class, no ``__setattr__`` of its own), so
    reading and writing the instance's ``__dict__`` is reading and writing the attribute; ``fields`` then reads the
    values from it (a field missing there is read again as an attribute, field by field: the same values, or the
    same error)."""

    __slots__ = ("per_field", "plain")

    def __init__(self, cls, kinds):
        self.per_field = tuple((name, _NORMALIZERS.get(kind) or _normalize_vector) for name, kind in kinds.items())
        self.plain = cls.__setattr__ is object.__setattr__ and not any(
            hasattr(type(klass.__dict__[name]), "__set__")
            for name in kinds for klass in cls.__mro__ if name in klass.__dict__)

    def fields(self, inst):
        """The fields of inst, normalized, in ``state_kinds`` order."""
        if self.plain:
            attributes = inst.__dict__
            try:
                return {name: normalize(attributes[name]) for name, normalize in self.per_field}
            except KeyError:
                pass
        return {name: normalize(getattr(inst, name)) for name, normalize in self.per_field}


def _normalize(kind, value):
    if kind.startswith("float["):
        return _normalize_vector(value)
    return _NORMALIZERS.get(kind, _same)(value)


def _normalize_vector(value):
    return tuple(map(float, value))


def _same(value):
    return value


def _optional_float(value):
    return None if value is None else float(value)


#: kind -> its normalizer (float[n]: _normalize_vector)
_NORMALIZERS = {"float": float, "float|None": _optional_float, "int": _same, "bool": _same}


_BUILD = {}


def model_stem(module: str) -> str:
    """The model folder of an FMU class declared in module ``ujfmu.models.<stem>.fmu`` (or the same below an FMU's
    runtime package)."""
    parts = module.split(".")
    if len(parts) < 3 or parts[-3] != "models":
        raise ValueError(f"{module} is not a model's FMU declaration (models/<stem>/fmu.py)")
    return parts[-2]


_ROOT = Path(__file__).resolve().parent.parent   # ujfmu, or an FMU's runtime package


def runtime_files(stem: str, root: Path = _ROOT) -> list:
    """Paths, relative to the runtime package root, of everything an FMU of model ``stem`` ships: the shared FMI
    plumbing (``fmu/``, ``models/protocol.py``) and its own model folder's equations and declaration
    (``models/<stem>/``)."""
    shared = sorted(p.name for p in (root / "fmu").glob("*.py"))
    return ([f"fmu/{name}" for name in shared] + ["models/__init__.py", "models/protocol.py"]
            + [f"models/{stem}/{name}" for name in ("__init__.py", "model.py", "fmu.py")])


def sources_digest(stem: str, root: Path = _ROOT) -> str:
    """SHA-256 (hex, 16 digits) of the runtime sources of model ``stem`` as they are now: exactly the files its
    FMU ships (``runtime_files``)."""
    digest = hashlib.sha256()
    for rel in runtime_files(stem, root):
        digest.update(f"{rel}\0".encode() + (root / rel).read_bytes() + b"\0")
    return digest.hexdigest()[:16]


def build_digest(stem: str) -> str:
    """The sources digest of this build of model ``stem``, read once: a state is restored only by the build that
    saved it."""
    if stem not in _BUILD:
        _BUILD[stem] = sources_digest(stem)
    return _BUILD[stem]


def encode_state(state):
    """Serialized state: MAGIC | u16 format version | u8 length + model name | u8 length + build digest |
    u32 length + JSON of the fields (sorted keys, floats written exactly) | SHA-256 of everything before it."""
    payload = json.dumps(state.fields, sort_keys=True, separators=(",", ":")).encode()
    return frame_state(state.origin[1].encode(), build_digest(model_stem(state.origin[0])).encode(), payload)


def frame_state(model, build, payload):
    """The serialized state holding payload (bytes) for the model and build named (bytes)."""
    body = (STATE_MAGIC + struct.pack(">HB", STATE_FORMAT_VERSION, len(model)) + model
            + struct.pack(">B", len(build)) + build + struct.pack(">I", len(payload)) + payload)
    return body + hashlib.sha256(body).digest()


class _Reader:
    def __init__(self, data):
        self.data, self.pos = data, 0

    def take(self, n, what):
        if self.pos + n > len(self.data):
            raise StateError(f"truncated: {len(self.data)} bytes end inside the {what}")
        chunk = self.data[self.pos:self.pos + n]
        self.pos += n
        return chunk

    def unpack(self, fmt, what):
        return struct.unpack(fmt, self.take(struct.calcsize(fmt), what))[0]


def _no_duplicates(pairs):
    keys = [k for k, _ in pairs]
    if len(set(keys)) != len(keys):
        raise StateError("a field appears twice")
    return dict(pairs)


def decode_state(cls, data):
    """The FmuState of cls serialized in data, or StateError saying why not (see encode_state)."""
    if len(data) > _MAX_STATE_BYTES:
        raise StateError(f"{len(data)} bytes is more than any state of this FMU ({_MAX_STATE_BYTES})")
    r = _Reader(data)
    if r.take(len(STATE_MAGIC), "magic") != STATE_MAGIC:
        raise StateError("not a ujfmu FMU state (wrong magic bytes)")
    version = r.unpack(">H", "header")
    if version != STATE_FORMAT_VERSION:
        raise StateError(f"format version {version}; this FMU reads version {STATE_FORMAT_VERSION}")
    model = r.take(r.unpack(">B", "header"), "header")
    build = r.take(r.unpack(">B", "header"), "header")
    payload = r.take(r.unpack(">I", "header"), "fields")
    digest = r.take(_DIGEST, "checksum")
    if r.pos != len(data):
        raise StateError(f"{len(data) - r.pos} bytes after the checksum")
    if hashlib.sha256(data[:-_DIGEST]).digest() != digest:
        raise StateError("checksum mismatch: the state is corrupted")
    if model != cls.__name__.encode():
        raise StateError(f"saved by FMU {model.decode(errors='replace')!r}, this is {cls.__name__!r}")
    this_build = build_digest(model_stem(cls.__module__))
    if build != this_build.encode():
        raise StateError(f"saved by another build of {cls.__name__} (source digest {build.decode(errors='replace')}, "
                         f"this build {this_build}): restore it with the FMU file that saved it")
    try:
        fields = json.loads(payload.decode("utf-8"), object_pairs_hook=_no_duplicates)
    except (ValueError, RecursionError) as exc:
        raise StateError(f"unreadable fields: {exc}") from None
    if not isinstance(fields, dict):
        raise StateError("the fields are not a JSON object")
    return FmuState(cls, check_fields(cls, fields))


def _kind_error(kind, value, finite=True):
    """None if value is of kind (JSON-decoded: lists for float[n]), else what is wrong."""
    if kind.startswith("float["):
        n = int(kind[6:-1])
        if not (isinstance(value, (list, tuple)) and len(value) == n):
            return f"expected {n} numbers, got {type(value).__name__}"
        return next((e for e in (_kind_error("float", x) for x in value) if e), None)
    if kind == "float|None":
        return None if value is None else _kind_error("float", value)
    expected = {"float": float, "int": int, "bool": bool}[kind]
    if type(value) is not expected:
        return f"expected {kind}, got {type(value).__name__}"
    if finite and kind == "float" and not math.isfinite(value):
        return f"{value!r} is not finite"
    return None


def check_fields(cls, fields):
    """The fields of a state of cls with sequences as tuples, or StateError naming the first wrong one; parameters
    of an initialized state must be in range, and derive() must accept them."""
    initialized = fields.get("_initialized")
    if type(initialized) is not bool:
        raise StateError("field _initialized missing or not a bool")
    if fields.get("_running") is True and not initialized:
        raise StateError("_running without _initialized")
    kinds = cls.state_kinds(initialized)
    if fields.keys() != kinds.keys():
        missing, extra = sorted(kinds.keys() - fields.keys()), sorted(fields.keys() - kinds.keys())
        raise StateError(f"wrong field set: missing {missing}, unexpected {extra[:5]}")
    inputs = {v.name for v in cls.VARIABLES if v.causality == "input"}
    for name, kind in kinds.items():
        error = _kind_error(kind, fields[name], finite=name not in inputs)
        if error:
            raise StateError(f"field {name}: {error}")
    fields = {k: _normalize(kind, fields[k]) for k, kind in kinds.items()}
    if initialized:
        probe = cls.__new__(cls)    # no __init__: a bare object of this class holding the restored values
        probe.__dict__.update(fields)
        try:
            invalid = probe._invalid(("parameter",))
            if not invalid:
                probe.derive()
        except Exception as exc:
            invalid = f"invalid parameters: derived quantities fail: {exc!r}"
        if invalid:
            raise StateError(invalid)
    return fields
