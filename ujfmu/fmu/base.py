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

FMU state (canGetAndSetFMUstate, canSerializeFMUstate): everything that evolves, i.e. the variables, the
life-cycle flags and every attribute a model sets after construction, deep-copied (pickled when serialized).
"""

import copy
import math
import pickle
import sys

from pythonfmu import Boolean, Fmi2Causality, Fmi2Slave, Fmi2Variability, Integer, Real
from pythonfmu.enums import Fmi2Status
from pythonfmu.default_experiment import DefaultExperiment

_TYPES = {float: Real, int: Integer, bool: Boolean}
#: life-cycle attributes of UjfmuSlave that are part of the FMU state
_LIFECYCLE = ("_stale", "_initialized", "_running", "_start_time")

#: Objects pythonfmu 0.7.0 releases twice after a Python exception (once when it turns the exception into
#: fmi2Fatal, again in fmi2FreeInstance). References held here keep them valid so the host survives.
_PINNED_AFTER_EXCEPTION = []


_IMMUTABLE = (float, int, bool, str, type(None))


def _snapshot(value):
    """value itself when it cannot change (numbers, strings, tuples of them), else a deep copy."""
    if type(value) in _IMMUTABLE:
        return value
    if type(value) in (tuple, list) and all(type(v) in _IMMUTABLE or (type(v) is tuple and all(
            type(w) in _IMMUTABLE for w in v)) for v in value):
        return value if type(value) is tuple else list(value)
    return copy.deepcopy(value)


class Var:
    """One FMU variable: the single declaration of its name, causality, variability, unit, range and start."""

    __slots__ = ("name", "causality", "variability", "unit", "description", "start", "min", "max",
                 "depends_on", "type")

    def __init__(self, name, causality, unit, description, start=None, min=None, max=None,
                 variability=None, depends_on=(), type=float):
        self.name, self.causality, self.unit, self.description = name, causality, unit, description
        self.start, self.min, self.max, self.type = start, min, max, type
        self.depends_on = tuple(depends_on)
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

    def check(self, value):
        """None if value is admissible, else a message naming the variable and its allowed range."""
        if self.type is bool:
            return None
        if not math.isfinite(value):
            return f"{self.name} = {value!r} is not a finite number (allowed range {self.range_text()})"
        if (self.min is not None and value < self.min) or (self.max is not None and value > self.max):
            return f"{self.name} = {value!r} is outside its allowed range {self.range_text()}"
        return None


def parameter(name, start, unit, description, min=None, max=None, type=float, variability="fixed"):
    return Var(name, "parameter", unit, description, start, min, max, variability, type=type)


#: ranges of the drivetrain ports: +-1e4 rad/s (95,000 rpm) and +-1e7 N.m cover any real driveline and keep
#: every model's arithmetic finite
SPEED_RANGE = dict(min=-1.0e4, max=1.0e4)
TORQUE_RANGE = dict(min=-1.0e7, max=1.0e7)


def input_(name, start, unit, description, min=None, max=None):
    return Var(name, "input", unit, description, start, min, max)


def output(name, unit, description, depends_on=()):
    """An output; depends_on names the inputs it depends on directly (its direct feedthrough)."""
    return Var(name, "output", unit, description, depends_on=depends_on)


class UjfmuSlave(Fmi2Slave):
    """Base of every ujfmu FMU. Subclasses set VARIABLES, DEFAULT_EXPERIMENT, and implement
    ``initialize(start_time)``, ``compute_outputs()`` and ``advance(t, h)``; ``check_parameters()`` is optional.

    Outputs are computed lazily from the current inputs and state (``compute_outputs`` runs on the first output
    read after any input changed or a step was taken), so outputs with direct feedthrough are exact at every
    communication point whatever order the host sets inputs in.
    """

    PHYSICS = None  # the ujfmu.physics module holding the model's equations (documentation)
    #: attributes that initialize() builds and nothing changes in place afterwards (derived parameters): FMU
    #: states share them instead of copying them
    SHARED_STATE = frozenset({"_p", "_frame"})
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
        self._initialized = False  # initialize() has run with the current parameters
        self._running = False      # past fmi2ExitInitializationMode
        self._inputs = tuple(v for v in self.VARIABLES if v.causality == "input")
        self._start_time = 0.0
        for var in self.VARIABLES:
            if var.causality == "output":
                setattr(self, var.name, 0.0)
                getter, setter = self._output_getter(var.name), None
            else:
                setattr(self, var.name, var.type(var.start))
                getter, setter = None, self._input_setter(var.name, var.type)
            self.register_variable(_TYPES[var.type](
                var.name, causality=Fmi2Causality[var.causality],
                variability=Fmi2Variability[var.variability], description=var.description,
                getter=getter, setter=setter))
        # the per-step hot path: Real getters/setters by value reference, input bounds (+-DBL_MAX: inf fails too)
        reals = {vr: var for vr, var in self.vars.items() if isinstance(var, Real)}
        self._real_getters = {vr: var.getter for vr, var in reals.items()}
        self._real_setters = {vr: var.setter for vr, var in reals.items() if var.setter is not None}
        big = sys.float_info.max
        self._input_bounds = tuple((v.name, -big if v.min is None else v.min, big if v.max is None else v.max, v)
                                   for v in self._inputs)
        # FMU state = the variables, the life-cycle flags, and every attribute the model adds after this point
        # (its integrator state, derived parameters, input history): nothing model-specific to forget
        self._plumbing = frozenset(self.__dict__) - {v.name for v in self.VARIABLES} - set(_LIFECYCLE) | {"_plumbing"}

    def _output_getter(self, name):
        def get():
            if self._stale:
                try:
                    if not self._initialized:  # an output read before fmi2ExitInitializationMode
                        problems = self._problems()
                        if problems:
                            raise ValueError("invalid parameters: " + "; ".join(problems))
                        self.initialize(self._start_time)
                        self._initialized = True
                    self.compute_outputs()
                except Exception as exc:
                    self._raise_to_host(f"{self.modelName} '{self.instance_name}': cannot compute {name}: {exc}")
                self._stale = False
            return getattr(self, name)
        return get

    def get_real(self, vrs):
        """fmi2GetReal without pythonfmu's per-variable type dispatch (its own version reports a wrong type)."""
        try:
            getters = self._real_getters
            return [getters[vr]() for vr in vrs]
        except KeyError:
            return super().get_real(vrs)

    def set_real(self, vrs, values):
        try:
            setters = self._real_setters
            for vr, value in zip(vrs, values):
                setters[vr](value)
        except KeyError:
            super().set_real(vrs, values)

    # --- FMU state (fmi2GetFMUstate / SetFMUstate / Serialize; canGetAndSetFMUstate in the modelDescription) ---
    def _get_fmu_state(self):
        """A copy of everything that evolves: variables, life-cycle flags and the model's own attributes
        (immutable values and the SHARED_STATE objects shared, anything else deep-copied)."""
        shared = self.SHARED_STATE
        return {k: v if k in shared else _snapshot(v) for k, v in self.__dict__.items() if k not in self._plumbing}

    def _set_fmu_state(self, state):
        shared = self.SHARED_STATE
        for key, value in state.items():   # a copy again: one saved state can be restored many times
            setattr(self, key, value if key in shared else _snapshot(value))

    @staticmethod
    def _fmu_state_to_bytes(state):
        return pickle.dumps(state, protocol=pickle.HIGHEST_PROTOCOL)

    @staticmethod
    def _fmu_state_from_bytes(data):
        return pickle.loads(bytes(data))

    def _raise_to_host(self, message):
        """Log at error level, pin what pythonfmu will release twice, and raise (the host gets fmi2Fatal)."""
        self.log(message, Fmi2Status.error)
        _PINNED_AFTER_EXCEPTION.extend((self, self, type(self), self.log_queue))
        raise ValueError(message)

    def _input_setter(self, name, cast):
        def set_(value):
            value = cast(value)
            if value == getattr(self, name):   # unchanged (a constant load, a held speed): outputs stay valid
                return
            setattr(self, name, value)
            self._stale = True
            if not self._running:
                self._initialized = False
        return set_

    # --- hooks for the models ---
    def check_parameters(self):
        """Model-specific consistency checks; return a list of messages (empty when valid)."""
        return []

    def initialize(self, start_time):
        raise NotImplementedError

    def compute_outputs(self):
        raise NotImplementedError

    def advance(self, t, h):
        raise NotImplementedError

    # --- FMI life cycle ---
    def setup_experiment(self, start_time, stop_time=None, tolerance=None):
        self._start_time = start_time

    def _problems(self):
        """Messages for every parameter or input outside its range, else the model's own checks."""
        problems = [m for m in (v.check(getattr(self, v.name)) for v in self.VARIABLES
                                if v.causality in ("parameter", "input")) if m]
        return problems or self.check_parameters()

    def exit_initialization_mode(self):
        problems = self._problems()
        if problems:
            self._raise_to_host(f"{self.modelName} '{self.instance_name}': invalid parameters: " + "; ".join(problems))
        self.initialize(self._start_time)
        self._initialized = self._running = self._stale = True

    def do_step(self, current_time, step_size):
        try:
            if not (step_size > 0.0 and math.isfinite(step_size)):
                raise ValueError(f"communication step size = {step_size!r} must be finite and > 0")
            for name, lo, hi, var in self._input_bounds:
                if not lo <= getattr(self, name) <= hi:   # NaN and inf fail too
                    raise ValueError(var.check(getattr(self, name)))
            self.advance(current_time, step_size)
            self._stale = True
            return True
        except Exception as exc:  # reported to the host, never raised into it
            self.log(f"{self.modelName} '{self.instance_name}': step at t = {current_time!r} refused: {exc}",
                     Fmi2Status.error)
            return False


class PrescribedInputSlave(UjfmuSlave):
    """Base of the drivetrain FMUs whose input shaft follows ``omega_in`` (a prescribed motion).

    Over a communication step h the input angle is phi(t) = phi + omega_in t + alpha t^2 / 2, alpha the backward
    difference of omega_in over the previous step (0 before the first): exact for constant speed and constant
    acceleration. The angle is summed with Kahan's compensation, so after 10^6 steps its round-off is a few ulps
    of the angle, not 10^6 of them.
    """

    def start_input(self, phi_start):
        self._phi_in, self._phi_in_carry = phi_start, 0.0
        self._omega_prev, self._h_prev = None, 0.0   # omega_in at the previous communication point

    def input_acceleration(self):
        return 0.0 if self._omega_prev is None else (self.omega_in - self._omega_prev) / self._h_prev

    def advance_input(self, h, alpha):
        increment = h * (self.omega_in + 0.5 * alpha * h) - self._phi_in_carry
        total = self._phi_in + increment
        self._phi_in_carry = (total - self._phi_in) - increment
        self._phi_in = total
        self._omega_prev, self._h_prev = self.omega_in, h
