"""Fixed-step co-simulation master on fmpy's FMU2Slave, explicit or implicit coupling (docs/cosimulation.md).

Set-up and transfer (both schemes):

1. Instantiate every component, set its parameters in initialization mode, exit initialization mode.
2. At every communication point t_k, transfer the connections in a topological order of the direct-feedthrough
   graph read from each modelDescription (ModelStructure/Outputs dependencies): a connection leaving output
   ``A.y`` is transferred only after every input of A that y depends on has been set. Outputs with direct
   feedthrough (the joint's omega_out and tau_in, the load's tau) are therefore consistent with their inputs at
   t_k, with no one-step lag. A cycle in that graph (an algebraic loop) is an error.

Explicit: record, step every FMU from t_k to t_k + h with its inputs held, transfer, repeat. The held torn
inputs (the driver's tau_load) lag by a step: unstable at any h when the driven inertia reflected to the driver
exceeds the driver's own.

Implicit (default): the torn inputs held over [t_k, t_k+1] are iterated to u = theta G(t_k+1; u) +
(1 - theta) G(t_k) by a quasi-Newton method (finite-difference interface Jacobian, Broyden updates), the
components owning them rolled back with fmi2GetFMUstate/fmi2SetFMUstate; theta is the least blend in
[1/2, THETA] whose inertia amplification, read from the interface Jacobian, stays within (1 - THETA)/THETA
(``blend_weight``); see ``Cosimulation._implicit_step``.

Both watch the torn connections for a diverging coupling (``CouplingInstabilityError``), account the energy
residual of every power bond (``Cosimulation.bond_energies``) and keep the recorded results up to a failure
(``CosimulationError.partial``), watching a block of steps at a time (``watch_block``, ``energy_block``) with the
outcome of a watch after every step.
"""

import atexit
import contextlib
import dataclasses
import difflib
import math
import numbers
import os
import re
import shutil
import signal
import tempfile
import threading
import time
import warnings
import zipfile
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi1 import calloc, free
from ctypes import PyDLL, addressof, byref, c_double, c_size_t, c_void_p, memmove, sizeof
from fmpy.fmi2 import (FMU2Slave, fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE,
                       fmi2CallbackFunctions, fmi2CallbackLoggerTYPE, fmi2FMUstate, fmi2Real, fmi2ValueReference)

from .fmu.base import INTERRUPTED_IN_FMU


#: coupling schemes (docs/cosimulation.md): "implicit" iterates the torn inputs to convergence at every step
COUPLINGS = ("implicit", "explicit")
DEFAULT_COUPLING = "implicit"
#: implicit coupling: a torn input has converged when |G(u) - u| <= RTOL * (largest |value| so far) + ATOL
COUPLING_RTOL, COUPLING_ATOL = 3e-4, 1e-9
#: a step whose residual will not fall below tol (G(u) jumps: a torque limit switching inside the step) is taken
#: at its best iterate if that is within STALL_FACTOR * tol
STALL_FACTOR = 100.0

#: implicit coupling: quasi-Newton iterations per step before the interface Jacobian is rebuilt by finite
#: differences, and rebuilds per step before the step is declared not converging
MAX_ITERATIONS, MAX_REBUILDS = 6, 2
#: implicit coupling: Illinois steps on one torn input's bracketed root where the quasi-Newton ones stall
#: (``Cosimulation._bracketed_root``)
BRACKET_ITERATIONS = 60
#: implicit coupling: the torn inputs are held at theta G(t_k+1) + (1 - theta) G(t_k), theta in [1/2, THETA]: the
#: least blend whose inertia amplification stays within AMPLIFICATION_BOUND = (1 - THETA)/THETA, the bound
#: THETA guarantees for any inertia ratio (``blend_weight``, docs/cosimulation.md)
THETA = 0.6
AMPLIFICATION_BOUND = (1.0 - THETA) / THETA


#: instability detection: a torn connection whose step-to-step change alternates in sign for at least
#: GROWTH_STEPS steps while growing GROWTH_FACTOR-fold, to at least GROWTH_FLOOR of its largest |value|; a step
#: refused after 2 or more alternations growing 1.5-fold each is blamed on the coupling too
GROWTH_STEPS, GROWTH_FACTOR, GROWTH_FLOOR = 3, 8.0, 1e-3
#: a jump of an output (``_output_jumps``) at most this relative distance from a step's end is at its end
JUMP_ROUNDING = 1e-9
#: a change smaller than this, in the connection's SI unit (N.m, rad/s, rad, N, m), is round-off, never the start
#: of a divergence: an unloaded constant-velocity driveline's tau_in is 1e-15 N.m of alternating noise about 0, and a
#: real divergence passes this within a few steps
NOISE_FLOOR = 1e-9
#: steps are watched this many at a time (``watch_block``), and before any failure is reported: a divergence is
#: reported at the step it began, the steps taken after it are dropped
WATCH_BLOCK = 1024
#: chatter: a connection on a loop whose change keeps reversing its sign, each reversal by at least CHATTER_SHARE of
#: its largest |value|: an oscillation at the step rate that does not die out (a switching component faster than
#: the step, e.g. a Load's friction torque smoothed over a band of speed that one step jumps across), which no
#: model's own dynamics can show at that step. A score counts +1 per such reversal (against the last change that
#: large), -CHATTER_BREAK per large change in the same direction and -CHATTER_FADE per smaller change (floored at
#: 0); chatter once it reaches CHATTER_STEPS. The loop's slower motion breaks the alternation every few steps (a
#: Load's chatter reverses at 9 steps in 10, or holds its saturated torque every third step: +1.5 in 3 steps);
#: a sampled oscillation of 4 or more samples a period loses at least 1 a period
CHATTER_STEPS, CHATTER_SHARE, CHATTER_BREAK, CHATTER_FADE = 20, 0.1, 3, 0.5
#: a reversal counts toward chatter only where it is at least this share of the last large change: one that dies
#: out faster than 5% a step is a stable alternation (a sampled PI at Kp h / J = 1.9, its pole at -0.9), which the
#: models can have at this step, not a chatter
CHATTER_SUSTAIN = 0.95
#: implicit coupling: the iterated torn values carry step-to-step noise of a few coupling tolerances; growth of an
#: alternating change is measured from at least this many tolerances (not from a change that happens to be ~0
#: where a torque ripple turns)
IMPLICIT_NOISE_TOLERANCES = 10.0
#: a refused step is blamed on the coupling too when, in the last step, a torn connection's change reversed its
#: sign while growing GROWTH_FACTOR-fold (a divergence too fast for two alternations), or a power bond's energy
#: residual exceeded ENERGY_RATIO times the energy it transmitted while growing GROWTH_FACTOR-fold
ENERGY_RATIO = 1.0
#: units of the two halves of a power bond (docs/cosimulation.md, "Energy on the power bonds")
SPEED_UNIT, TORQUE_UNIT = "rad/s", "N.m"


#: the ``ujfmu`` command's Ctrl-C while a co-simulation is open: STOP[0] asks every stepping loop to raise
#: KeyboardInterrupt at its next communication step, between FMU calls (an interrupt raised inside an FMU's own
#: Python code, which runs from instantiation to freeing, is caught there and reported as the FMU's fatal error, so a
#: sweep took it for a failed point and went on); OPEN[0] counts the co-simulations open now (``ujfmu.cli``'s handler
#: stops at once when none is)
STOP, OPEN = [False], [0]
#: True once a handler raised KeyboardInterrupt at once while a co-simulation was open: where that was in code run
#: inside an FMU's call that ``in_fmu_code`` does not know, the call fails, and the master reports the failure as the
#: interrupt it is (``Cosimulation._failure``)
RAISED_IN_RUN = [False]
#: communication steps a run may take at most (1e9 steps of 25 us are seven hours, and a record of them 8 GB a signal)
MAX_STEPS = 1e9


def _stop_at_next_step(signum, frame) -> None:
    """SIGINT while a co-simulation steps from Python (``Cosimulation.advance`` installs it where Python's own
    handler is in place): ask the stepping loop to raise KeyboardInterrupt at its next communication step (STOP),
    between FMU calls, so a caller's ``except CosimulationError`` does not take it for a failed step and no FMU
    sees the interrupt in its own code; a second Ctrl-C raises at once."""
    if OPEN[0] and not STOP[0]:
        STOP[0] = True
        return
    raise_at_once(frame)


def raise_at_once(frame=None) -> None:
    """Raise KeyboardInterrupt now (a handler's second Ctrl-C, frame the one the signal found running), but not
    inside an FMU's code (``in_fmu_code``), where it would escape into pythonfmu, which then frees the instance twice
    (a segfault later): there STOP stays set and the run stops as the FMU's call returns, at its communication
    step."""
    if OPEN[0] and in_fmu_code(frame):
        STOP[0] = True
        return
    RAISED_IN_RUN[0] = RAISED_IN_RUN[0] or bool(OPEN[0])
    raise KeyboardInterrupt


#: modules whose Python code runs inside an FMU's call: the runtime package a ujfmu FMU ships
#: (``ujfmu_<model>_<digest>``), pythonfmu's own methods, and the import system while pythonfmu loads that package
_FMU_CODE = ("ujfmu_", "pythonfmu", "importlib")


def in_fmu_code(frame) -> bool:
    """True where frame, or a frame that called it, runs Python code inside an FMU's call (``_FMU_CODE``), not the
    ``ujfmu`` package's."""
    while frame is not None:
        if frame.f_globals.get("__name__", "").startswith(_FMU_CODE):
            return True
        frame = frame.f_back
    return False


def _defer_interrupt(signum, frame) -> None:
    """SIGINT while FMUs are loaded, set up, freed or integrated (``deferred_interrupt``): ask the code around to
    stop where it can (STOP); a second Ctrl-C raises at once."""
    if not STOP[0]:
        STOP[0] = True
        return
    raise_at_once(frame)


@contextlib.contextmanager
def deferred_interrupt():
    """While in place (in the main thread, where Python's own SIGINT handler is), a Ctrl-C sets STOP instead of
    raising inside an FMU's code, which had left a process broken: a chdir of fmpy's loader not undone, an FMU's
    fatal Python error, a crash at the next garbage collection (a notebook user's Interrupt kernel)."""
    previous = None
    if (threading.current_thread() is threading.main_thread()
            and signal.getsignal(signal.SIGINT) is signal.default_int_handler):
        previous = signal.signal(signal.SIGINT, _defer_interrupt)
    try:
        yield
    finally:
        if previous is not None:
            signal.signal(signal.SIGINT, previous)


class CosimulationError(RuntimeError):
    """A co-simulation could not be set up, an FMU refused a call, or the coupling went unstable; carries the
    FMUs' log messages, and ``partial`` (the recorded results up to the failure, a structured array) once
    ``Cosimulation.run`` has them."""

    partial = None


class Interrupted(KeyboardInterrupt):
    """A Ctrl-C (or the ``ujfmu`` command's SIGTERM) stopped a run at a communication step: a KeyboardInterrupt,
    so that ``except CosimulationError`` does not take it for a failure, with the results recorded up to that step
    in ``partial`` once ``Cosimulation.run`` has them (None where it was raised before any)."""

    partial = None


class RunStopped(CosimulationError):
    """The progress callback returned False (as fmpy's ``step_finished`` can): the run stopped there, its results
    up to that step in ``partial``."""


class CouplingInstabilityError(CosimulationError):
    """The coupling went unstable: the message names the connection, the step, the growth and the remedy."""


class HeldInputWarning(UserWarning):
    """Inputs no connection feeds and no component parameter sets: held at their declared start values."""


class FmuWarning(UserWarning):
    """A warning an FMU logged (its message, from ``Cosimulation.log``): e.g. parameters that are valid but likely
    not what was meant, or outputs read too seldom for the input speed's orders."""


@dataclass
class Component:
    """One FMU instance of a co-simulation: its name (connections and recorded signals say 'name.variable'), the
    FMU file's path, and the values of its parameters and of any unconnected input it holds ({name: value}, SI)."""

    name: str
    fmu: Path
    parameters: dict = field(default_factory=dict)


@dataclass
class Connection:
    """An output of one component feeding an input of another, each 'component.variable' (same unit and type)."""

    source: str   # "component.output"
    target: str   # "component.input"


@dataclass
class BondEnergy:
    """The energy account of one power bond: a speed connection and a torque connection between the same two
    components in opposite directions. ``residual`` is the net of the energy residual (ECCO's: what two sides
    holding their inputs over each step would disagree on) over the run, ``residual_abs`` the sum of its magnitudes
    per step, ``transmitted`` the sum of the magnitudes of the energy the speed's side exchanged through the bond
    [J]. A quality figure of the step and scheme; not the energy the coupling created, as our FMUs do not hold
    their inputs so (docs/cosimulation.md, "Energy on the power bonds")."""

    speed: Connection
    torque: Connection
    residual: float = 0.0
    residual_abs: float = 0.0
    transmitted: float = 0.0
    note: str = ""   # what the figure means for this bond, where not a coupling error (set by the caller)

    @property
    def components(self) -> tuple:
        return self.speed.source.split(".", 1)[0], self.speed.target.split(".", 1)[0]

    @property
    def relative(self) -> float:
        """sum |residual per step| / transmitted energy (nan when nothing was transmitted)."""
        return self.residual_abs / self.transmitted if self.transmitted > 0.0 else math.nan

    def __str__(self):
        a, b = self.components
        text = (f"coupling energy {a} <-> {b} ({self.speed.source} x {self.torque.source}): net "
                f"{self.residual:+.4g} J, sum |per step| {self.residual_abs:.4g} J")
        if self.transmitted > 0.0 and self.relative <= 1.0:
            text += (f" = {100.0 * self.relative:.3g}% of the {self.transmitted:.4g} J transmitted (sum |power| dt, "
                     "both ways)")
        elif self.transmitted > 0.0:   # a run of a step or two, a shaft at rest: no share to speak of
            text += (f", more than the {self.transmitted:.4g} J transmitted (sum |power| dt, both ways): the run "
                     "moved too little power through the bond for a share")
        return text + (f" ({self.note})" if self.note else "")


@dataclass
class HeldInput:
    """An input no connection feeds: held at ``value`` (its start value, or the value the component's parameters
    give it) over the whole run."""

    component: str
    name: str
    value: float
    unit: str = ""

    def __str__(self):
        return f"{self.component}.{self.name} = {self.value:g}" + (f" {self.unit}" if self.unit else "")



_STATUS = ["ok", "warning", "discard", "error", "fatal", "pending"]


def is_ideal_speed_source(model_name: str, value) -> bool:
    """A Motor FMU whose ideal_speed_source parameter is value (a bool, or as modelDescription.xml writes it) is an
    ideal speed source: its speed follows its profile whatever torque acts on it."""
    return model_name == "Motor" and (value is True or str(value).lower() in ("true", "1"))


class FmuInstance:
    """One FMU instance over fmpy's FMU2Slave: variables by name, FMU log messages collected in ``log``."""

    def __init__(self, component, unzip_dir, model_description, log):
        self.name = component.name
        self.parameters = component.parameters
        self.md = model_description
        self.variables = {v.name: v for v in model_description.modelVariables}
        self._log = log

        def logger(env, instance, status, category, message):
            # an FMI 2.0 message is a printf format: without arguments, '%%' is a literal '%'
            log.append(f"[{_STATUS[status] if 0 <= status < 6 else status}] {instance.decode()}: "
                       f"{message.decode(errors='replace').replace('%%', '%')}")

        self._callbacks = fmi2CallbackFunctions()
        self._callbacks.logger = fmi2CallbackLoggerTYPE(logger)
        self._callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        self._callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        self.slave = FMU2Slave(guid=model_description.guid, unzipDirectory=unzip_dir,
                               modelIdentifier=model_description.coSimulation.modelIdentifier,
                               instanceName=component.name)
        self.slave.instantiate(callbacks=self._callbacks, loggingOn=True)  # else pythonfmu drops errors too
        self.instantiated = True

    def raw(self, function):
        """The FMU's C function itself (no status check, no call logging), for the stepping loop."""
        return self.slave._functions[function]

    def bare(self, function):
        """The FMU's C function for the stepping loop: no argument conversion (no argtypes: every argument must be
        a ctypes object of the declared C type, c_size_t for sizes, c_double for reals, ctypes arrays for
        pointers) and called with the GIL held (as through ctypes.PyDLL), so that pythonfmu's wrapper, which takes
        the GIL at every call, finds it taken instead of having it handed back. Together they cut the Python
        overhead of a call to about a third."""
        dll = PyDLL(None, handle=self.slave.dll._handle)
        return dll._FuncPtr((function, dll))

    def input_dependencies(self, name):
        """Names of the inputs a variable depends on directly: an output's declared dependencies (all inputs if
        undeclared), an input itself, nothing for a parameter."""
        var = self.variables.get(name)
        if var is None:
            self.vr(name)
        if var.causality == "input":
            return [name]
        if var.causality != "output":
            return []
        declared = next((u.dependencies for u in self.md.outputs if u.variable.name == name), None)
        candidates = self.md.modelVariables if declared is None else declared   # undeclared: every input
        return [v.name for v in candidates if v.causality == "input"]

    def stateless_inputs(self) -> set:
        """Inputs that reach no state of this instance with its parameters, only outputs that depend on them directly
        (declared): an ideal speed source's tau_load (a Motor with ideal_speed_source: its speed follows its
        profile whatever torque acts on it). A value held into one over a step moves nothing."""
        start = self.variables.get("ideal_speed_source")
        value = self.parameters.get("ideal_speed_source", start.start if start is not None else None)
        return {"tau_load"} if is_ideal_speed_source(self.md.modelName, value) else set()

    def vr(self, name):
        try:
            return self.variables[name].valueReference
        except KeyError:
            close = difflib.get_close_matches(name, list(self.variables), n=1)
            raise CosimulationError(f"component '{self.name}' ({self.md.modelName}) has no variable '{name}'"
                                    + (f" (did you mean '{self.name}.{close[0]}'?)" if close else "")
                                    + f"; it has: {', '.join(self.variables)}") from None

    def set_value(self, name, value):
        """Set a variable by name to a value of its declared type (``typed_value``)."""
        var = self.variables.get(name)
        if var is None:
            self.vr(name)
        value = typed_value(self, var, value)
        if var.type == "Real":
            self.slave.setReal([var.valueReference], [value])
        elif var.type in ("Integer", "Enumeration"):
            self.slave.setInteger([var.valueReference], [value])
        elif var.type == "Boolean":
            self.slave.setBoolean([var.valueReference], [value])
        else:
            self.slave.setString([var.valueReference], [value])

    def get(self, *names):
        """Real values by name."""
        return self.slave.getReal([self.vr(n) for n in names])

    def set(self, **values):
        for name, value in values.items():
            self.set_value(name, value)

    def initialize(self, parameters=None, start_time=0.0):
        self.slave.setupExperiment(startTime=start_time)
        self.slave.enterInitializationMode()
        for name, value in (parameters or {}).items():
            self.vr(name)
            self.set_value(name, value)
        self.slave.exitInitializationMode()

    def free(self):
        if self.instantiated:
            self.instantiated = False
            try:
                self.slave.terminate()
            except Exception:
                pass
            self.slave.freeInstance()
            # no freeLibrary: unloading one pythonfmu binary while the interpreter keeps running other pythonfmu
            # instances can crash them; extract() below reuses one folder per FMU file, so nothing piles up


_EXTRACTED = {}
#: a temporary folder of FMUs a ujfmu process made (:func:`temporary_folder`): ``<prefix><pid>_<random>``
_OWN_FOLDER = re.compile(r"(ujfmu_fmu_|ujfmu_worker_fmus_)(\d+)_\w+")
#: the file in such a folder that its process holds locked (flock) for its lifetime: the lock, not the process id,
#: tells a folder in use (a process id means nothing across containers sharing /tmp or hosts sharing a TMPDIR)
OWNER_FILE = ".ujfmu-owner"
#: an unlocked owner file younger than this [s] may be its process's, between creating and locking it
OWNER_GRACE = 60.0
#: {folder: its open owner file} of this process's folders (their locks last as long as the files stay open)
_OWNED = {}


def temporary_folder(prefix: str) -> Path:
    """A new temporary folder named prefix, this process's id, '_' and a random part, its owner file locked for
    this process's lifetime; the first in a process removes those that ended processes left
    (:func:`remove_abandoned_folders`)."""
    if not _OWNED:
        remove_abandoned_folders()
    folder = Path(tempfile.mkdtemp(prefix=f"{prefix}{os.getpid()}_"))
    owner = open(folder / OWNER_FILE, "w")
    try:
        import fcntl
        fcntl.flock(owner, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except (ImportError, OSError):   # no flock (Windows), or a file system without locks: never removed by others
        pass
    _OWNED[str(folder)] = owner
    return folder


def remove_folder(folder: str | os.PathLike) -> None:
    """Remove a folder of :func:`temporary_folder` and let go of its owner file."""
    owner = _OWNED.pop(str(folder), None)
    if owner is not None:
        owner.close()
    shutil.rmtree(folder, ignore_errors=True)


def remove_abandoned_folders(root: str | os.PathLike | None = None) -> list:
    """Remove the FMU folders (``_OWN_FOLDER``) in root (default: the system's temporary folder) that a ujfmu
    process of this user left behind when it ended without its exit handlers (``kill -9``, ``os._exit``, a dask
    worker stopped by its cluster): those whose owner file (``OWNER_FILE``) no process holds locked any more, and
    older than ``OWNER_GRACE``. A folder without an owner file (an older ujfmu's, another program's) is kept, as
    is every folder where files cannot be locked (Windows). Returns the folders removed."""
    removed = []
    try:
        import fcntl
        entries = list(os.scandir(Path(root or tempfile.gettempdir())))
    except (ImportError, OSError):
        return removed
    for entry in entries:
        if _OWN_FOLDER.fullmatch(entry.name) is None:
            continue
        try:
            if not entry.is_dir(follow_symlinks=False) or entry.stat(follow_symlinks=False).st_uid != os.getuid():
                continue
            owner = open(os.path.join(entry.path, OWNER_FILE))
        except OSError:   # gone meanwhile, or no owner file
            continue
        with owner:
            try:
                if time.time() - os.fstat(owner.fileno()).st_mtime < OWNER_GRACE:
                    continue
                fcntl.flock(owner, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError:   # locked: its process runs (here, in another container, on another host)
                continue
            shutil.rmtree(entry.path, ignore_errors=True)
            removed.append(Path(entry.path))
    return removed


def made_here(folder: str | os.PathLike) -> bool:
    """Whether this process made the folder (:func:`temporary_folder`: its name holds the process id): a process
    forked from one that had extracted FMUs inherits their folders, which the parent still uses."""
    match = _OWN_FOLDER.fullmatch(Path(folder).name)
    return match is not None and int(match.group(2)) == os.getpid()


def _remove_extracted() -> None:
    """At exit: remove the FMU folders this process extracted (:func:`made_here`; not a forking parent's)."""
    for folder, _ in list(_EXTRACTED.values()):
        if made_here(folder):
            remove_folder(folder)


def extracted(fmu):
    """(unzip folder, model description) of an FMU file, extracted once per process and file version.

    Every instance of an FMU then loads the same binary (the loader counts references) instead of a fresh copy
    from a fresh folder, which a sweep of thousands of co-simulations in one worker process would pile up. The
    folders are removed when the process exits, or, where it ended without its exit handlers, by the next process
    that extracts an FMU (:func:`temporary_folder`)."""
    path = Path(fmu).resolve()
    stat = path.stat()
    key = (str(path), stat.st_size, stat.st_mtime_ns)
    if key not in _EXTRACTED:
        if not _EXTRACTED:
            atexit.register(_remove_extracted)
        folder = str(temporary_folder("ujfmu_fmu_"))
        try:
            _EXTRACTED[key] = (extract(str(path), unzipdir=folder), read_model_description(str(path)))
        except (zipfile.BadZipFile, zlib.error) as exc:   # its directory reads, a member not (a byte changed)
            remove_folder(folder)
            from .build import build_hint
            raise CosimulationError(f"{path} is damaged ({exc}): rebuild it ({build_hint(path.parent)})") from exc
        except BaseException:   # not an FMU (or not one we read): nothing of it is kept
            remove_folder(folder)
            raise
    return _EXTRACTED[key]


def _feedthrough_order(connections, instances):
    """Connections sorted so that each is transferred after the inputs its source output depends on."""
    def deps_of(comp, output):
        inst = instances[comp]
        if inst.variables.get(output) is None or inst.variables[output].causality != "output":
            inst.vr(output)
            raise CosimulationError(f"'{comp}.{output}' is not an output of {inst.md.modelName}")
        return inst.input_dependencies(output)

    feeding = {c.target: c for c in connections}
    order, state = [], {}

    def visit(conn, path):
        key = conn.target
        if state.get(key) == "done":
            return
        if state.get(key) == "active":
            loop = " -> ".join(c.source + " -> " + c.target for c in path)
            raise CosimulationError(f"algebraic loop through direct feedthrough: {loop}")
        state[key] = "active"
        comp, output = conn.source.split(".", 1)
        for inp in deps_of(comp, output):
            upstream = feeding.get(f"{comp}.{inp}")
            if upstream is not None:
                visit(upstream, path + [upstream])
        state[key] = "done"
        order.append(conn)

    for conn in connections:
        visit(conn, [conn])
    return order


class Cosimulation:
    """A running co-simulation: FMUs instantiated and initialized, connections planned; ``advance`` steps it.

    The stepping loop calls the FMUs' fmi2DoStep/GetReal/SetReal directly (fmpy's FMU2Slave loads them) on value
    buffers allocated once, so a communication point costs the FMI calls themselves and little else: a
    connection is one fmi2GetReal into a buffer and one fmi2SetReal from that same buffer, and recorded signals
    ride along on those reads where the feedthrough order allows (else one fmi2GetReal per component). Use as a
    context manager, or call ``close``.
    """

    def __init__(self, components, connections, step_size, record, start_time=0.0, coupling=DEFAULT_COUPLING):
        if not (step_size > 0.0 and math.isfinite(step_size)):
            raise CosimulationError(f"communication step size {step_size!r} must be finite and > 0")
        if coupling not in COUPLINGS:
            raise CosimulationError(f"coupling = {coupling!r} is not one of {', '.join(COUPLINGS)}")
        self.coupling = coupling
        self.iterations = 0          # implicit coupling: evaluations of the torn inputs' fixed point, in all
        self.jacobian_builds = 0     # implicit coupling: finite-difference interface Jacobians
        self.stalled_steps = 0       # implicit coupling: steps taken at their best iterate (see STALL_FACTOR)
        self.stalled_worst = 0.0     # and their largest residual, in tolerances
        self.open_loop = False       # implicit coupling found no connection moving with the torn inputs
        self.step_size, self.time, self.steps_done = step_size, start_time, 0
        self.rows_done = 0           # rows recorded by the last advance
        self._watch_buffer, self._held_rows = None, []   # the steps not yet watched (``advance``)
        self.start_time = start_time
        self.log = []
        self.instances = {}
        OPEN[0] += 1
        self._open = True
        self._warned = 0             # log entries already raised as FmuWarning
        self._warned_texts = set()   # the texts raised
        self.warned = []             # and in order: the run's FMU warnings (``cosimulate``'s diagnostics)
        asked = STOP[0]
        self.interrupted_while_closing = False   # a Ctrl-C while the FMUs were freed (``close``)
        RAISED_IN_RUN[0] = False
        try:
            with deferred_interrupt():   # a Ctrl-C meanwhile stops the run at its first step (``advance``)
                self._setup(components, connections, record)
        except CosimulationError as exc:
            self.close()
            STOP[0] = STOP[0] and asked   # a Ctrl-C during a setup that failed: this setup's, not the next run's
            if self._interrupted_in_fmu():
                raise self._failure("") from exc
            raise
        except Exception as exc:
            self.close()
            STOP[0] = STOP[0] and asked
            raise self._failure(f"{exc}") from exc
        self._warn_fmu_warnings()

    def _warn_fmu_warnings(self):
        """An ``FmuWarning`` for each warning the FMUs logged since the last call, each text once per run (an FMU
        says a warning once, but the implicit scheme's rollback restores its state from before it, and the retried
        step says it again)."""
        new, self._warned = self.log[self._warned:], len(self.log)
        said = self._warned_texts
        for entry in new:
            if entry.startswith("[warning]") and entry not in said:
                said.add(entry)
                self.warned.append(entry)
                warnings.warn(entry, FmuWarning, stacklevel=3)

    def _setup(self, components, connections, record):
        components, connections, record = _checked_setup(components, connections, record)
        for comp in components:
            if not Path(comp.fmu).is_file():
                raise CosimulationError(f"component '{comp.name}': FMU file {comp.fmu} not found "
                                        "(run `ujfmu build` first)")
            unzip_dir, md = extracted(comp.fmu)
            if md.fmiVersion.startswith("3"):
                from .fmi3_host import FmuInstance3 as instance   # FMI 3.0 Co-Simulation (ujfmu build --fmi 3)
            else:
                instance = FmuInstance
            self.instances[comp.name] = instance(comp, unzip_dir, md, self.log)
        check_wiring(connections, self.instances)
        for comp in components:
            self.instances[comp.name].initialize(comp.parameters, self.start_time)

        # The plan of a communication point, in feedthrough order: a connection is one fmi2SetReal of a value an
        # fmi2GetReal of its source read. An output joins the component's previous read when no input it depends on
        # was set since (one speed fed to three couplings is read once; a torque-driven joint's omega_in and
        # omega_out are read together). A component's recorded signals ride along on
        # the last read of it made after every input they depend on is set, else they get a fmi2GetReal of their
        # own after the transfers (in read()). Every value lives in one buffer, the scratch row, so recording a
        # communication point is one copy of it.
        ordered = _feedthrough_order(connections, self.instances)
        gets, sets, sequence, open_get, set_at = [], [], [], {}, {}

        def read_at(comp, name):
            """(read, position) of output comp.name; open_get: component -> (its last read, inputs set since)."""
            if comp not in open_get or open_get[comp][1] & set(self.instances[comp].input_dependencies(name)):
                open_get[comp] = (len(gets), set())
                sequence.append(("get", len(gets)))
                gets.append((comp, []))
            vrs, vr = gets[open_get[comp][0]][1], self.instances[comp].vr(name)
            if vr not in vrs:
                vrs.append(vr)
            return open_get[comp][0], vrs.index(vr)

        for conn in ordered:
            (src, out), (dst, inp) = conn.source.split(".", 1), conn.target.split(".", 1)
            g, pos = read_at(src, out)
            set_at[(dst, inp)] = len(sequence)
            sequence.append(("set", len(sets)))
            sets.append((dst, self.instances[dst].vr(inp), g, pos))
            if dst in open_get:
                open_get[dst][1].add(inp)
        transferred = [len(vrs) for _, vrs in gets]   # the values connections need: a prefix of each read
        self.columns, readers, places = [], [], []
        for comp_name in dict.fromkeys(name.split(".", 1)[0] for name in record):
            names = [name for name in record if name.split(".", 1)[0] == comp_name]
            if comp_name not in self.instances:
                raise CosimulationError(f"recorded signal '{names[0]}': no component '{comp_name}'")
            inst = self.instances[comp_name]
            vrs = [inst.vr(n.split(".", 1)[1]) for n in names]
            ready = max((set_at.get((comp_name, d), -1) for n in names
                         for d in inst.input_dependencies(n.split(".", 1)[1])), default=-1)
            host = next((i for kind, i in reversed(sequence[ready + 1:])
                         if kind == "get" and gets[i][0] == comp_name), None)
            if host is None:
                host = len(gets) + len(readers)
                readers.append((comp_name, []))
            group = gets[host][1] if host < len(gets) else readers[-1][1]
            for vr in vrs:
                if vr not in group:
                    group.append(vr)
                places.append((host, group.index(vr)))
            self.columns += names
        offsets = [0]
        for _, vrs in gets + readers:
            offsets.append(offsets[-1] + len(vrs))
        self._scratch = (fmi2Real * max(1, offsets[-1]))()
        self._scratch_view = np.frombuffer(self._scratch, dtype=np.float64)
        self._record_index = np.array([offsets[g] + pos for g, pos in places], dtype=np.intp)

        def segment(offset, n):
            return (fmi2Real * n).from_buffer(self._scratch, sizeof(fmi2Real) * offset)

        def bare_get(comp, vrs, offset):
            inst = self.instances[comp]
            return (inst.bare("fmi2GetReal"), c_void_p(inst.slave.component), _vrs(*vrs), c_size_t(len(vrs)),
                    segment(offset, len(vrs)))

        # a communication point: (C function, component, value references, count, values) calls in order
        self._ops, self._op_names = [], []
        for kind, i in sequence:
            if kind == "get":
                comp, vrs = gets[i]
                self._ops.append(bare_get(comp, vrs, offsets[i]))
                self._op_names.append(f"reading {comp} (value references {vrs})")
            else:
                dst, vr, g, pos = sets[i]
                inst = self.instances[dst]
                self._ops.append((inst.bare("fmi2SetReal"), c_void_p(inst.slave.component), _vrs(vr), c_size_t(1),
                                  segment(offsets[g] + pos, 1)))
                self._op_names.append(f"transfer {ordered[i].source} -> {ordered[i].target}")
        # the same without the recorded signals riding along, for the steps that record nothing
        self._lean_ops = [op if kind == "set" else op[:3] + (c_size_t(transferred[i]),) + op[4:]
                          for op, (kind, i) in zip(self._ops, sequence)]
        self._readers = [bare_get(comp, vrs, offsets[len(gets) + i]) for i, (comp, vrs) in enumerate(readers)]
        # per connection, in feedthrough order: (get, source, its vr, 1, value, set, target, its vr, connection),
        # value the one-value view of the scratch row where the connection's value is read to
        self._transfers, views, columns = [], [], []
        for conn, (dst, vr, g, pos) in zip(ordered, sets):
            src = self.instances[conn.source.split(".", 1)[0]]
            value = segment(offsets[g] + pos, 1)
            columns.append(offsets[g] + pos)
            views.append(np.frombuffer(value, dtype=np.float64))
            self._transfers.append((src.raw("fmi2GetReal"), src.slave.component, _vrs(gets[g][1][pos]), 1, value,
                                    self.instances[dst].raw("fmi2SetReal"), self.instances[dst].slave.component,
                                    _vrs(vr), conn))
        self._bare_steppers = [(inst.bare("fmi2DoStep"), c_void_p(inst.slave.component), name)
                               for name, inst in self.instances.items()]
        self._steppers = [(inst.raw("fmi2DoStep"), inst.slave.component, name)
                          for name, inst in self.instances.items()]
        self._plan_tearing(views)
        # the scratch row's columns of the watched connections and of the bonds' speeds and torques
        self._watch_columns = np.array([columns[i] for i in self._watched], dtype=np.intp)
        self._communicate()
        self._fresh = True
        # per watched connection (torn first): [last value, last change, alternations, |change| when they began,
        # max |value|, the change before the last, chatter score, steps and reversals since the score left 0,
        # the last change above NOISE_FLOOR]
        self._growth = [[g, 0.0, 0, 0.0, abs(g), 0.0, 0, 0, 0, 0.0]
                        for g in (float(views[i][0]) for i in self._watched)]
        self._plan_bonds(views)
        self._bond_columns = tuple(np.array([columns[bond[k]] for bond in self._bonds], dtype=np.intp)
                                   for k in (0, 1)) if self._bonds else ()
        self.held_inputs = held_inputs(self.instances, connections, {c.name: c.parameters for c in components})
        # the times where a component's outputs jump: the implicit steps ending there hold the torn values
        self._jumps = tuple(sorted({t for c in components for t in _output_jumps(self.instances[c.name].md,
                                                                                 c.parameters)}))
        given = {(c.name, name) for c in components for name in c.parameters}
        unstated = [h for h in self.held_inputs if (h.component, h.name) not in given]
        if unstated:
            warnings.warn(f"input(s) not connected, held at their start values over the whole run: "
                          f"{', '.join(map(str, unstated))}; connect them, or give each a value in the component's "
                          "parameters to hold it deliberately", HeldInputWarning, stacklevel=4)

    def _plan_tearing(self, views):
        """Torn inputs for implicit coupling: inputs on a loop of connections on which no connected output of
        their component depends directly.

        Such an input reaches the connected outputs only through the component's state (the motor's tau_load
        through its speed), and they lead back to the input's source, so the value held over [t_k, t_k+1] is
        the coupling approximation of a closed loop; an input with direct feedthrough to a connected output is
        made consistent at every communication point by the ordered transfer, and one on no loop (a speed fed
        forward) or that reaches no state (an ideal speed source's tau_load: the loop is open) has nothing to
        iterate. The components owning torn inputs are rolled back and restepped while the torn values are
        iterated; the others step once per communication step.
        """
        fed_through = {name: set() for name in self.instances}
        feeds = {name: set() for name in self.instances}
        for transfer in self._transfers:
            comp, out = transfer[-1].source.split(".", 1)
            fed_through[comp].update(self.instances[comp].input_dependencies(out))
            feeds[comp].add(transfer[-1].target.split(".", 1)[0])

        def reaches(start, goal):
            seen, todo = set(), [start]
            while todo:
                comp = todo.pop()
                if comp == goal:
                    return True
                if comp not in seen:
                    seen.add(comp)
                    todo.extend(feeds[comp])
            return False

        def stateless(i):
            """The connection feeds an input that reaches no state (``FmuInstance.stateless_inputs``): a value held
            there moves nothing, so it closes no loop a step could hold back (an ideal speed source's torque)."""
            comp, inp = self._transfers[i][-1].target.split(".", 1)
            return inp in self.instances[comp].stateless_inputs()

        self._tears = []
        for i, transfer in enumerate(self._transfers):
            comp, inp = transfer[-1].target.split(".", 1)
            if (inp not in fed_through[comp] and reaches(comp, transfer[-1].source.split(".", 1)[0])
                    and not stateless(i)):
                self._tears.append(i)
        # watched for divergence and chatter (``watch_step``): the torn connections, then, for chatter only, one
        # connection on a loop for each pair of components that no watched connection joins yet (a chatter runs
        # through every connection of its loop), the last in transfer order: the one that closes the loop, its
        # value held over the next step, but for one into an input that reaches no state (a fast change there is
        # its source's own response, e.g. a joint's 2x torque read near twice a period into an ideal source)
        pairs = {frozenset(self._where(self._transfers[i][-1])) for i in self._tears}
        self._watched = list(self._tears)
        for i in reversed(range(len(self._transfers))):
            pair = frozenset(self._where(self._transfers[i][-1]))
            if pair not in pairs and reaches(*self._where(self._transfers[i][-1])[::-1]) and not stateless(i):
                pairs.add(pair)
                self._watched.append(i)
        rolled = dict.fromkeys(self._transfers[i][-1].target.split(".", 1)[0] for i in self._tears)
        self._rolled = [(self.instances[name], name) for name in rolled]
        # per rolled-back component: (fmi2GetFMUstate, fmi2SetFMUstate, fmi2FreeFMUstate, component, name), the
        # stepping loop's fast path (FmuInstance.bare: ctypes arguments only)
        self._state_ops = [(*(inst.bare(f"fmi2{op}FMUstate") for op in ("Get", "Set", "Free")),
                            c_void_p(inst.slave.component), name) for inst, name in self._rolled]
        # their saved states, one slot each reused every step (NULL again after each fmi2FreeFMUstate), and the
        # slots' addresses for fmi2GetFMUstate and fmi2FreeFMUstate
        self._states = [fmi2FMUstate() for _ in self._rolled]
        self._state_refs = [byref(state) for state in self._states]
        self._rolled_steppers = [s for s in self._bare_steppers if s[2] in rolled]
        self._fixed_steppers = [s for s in self._bare_steppers if s[2] not in rolled]
        # per torn connection: (fmi2SetReal of its target, target, its vr, 1, the value), bare as above
        self._tear_sets = [(self.instances[self._transfers[i][-1].target.split(".", 1)[0]].bare("fmi2SetReal"),
                            c_void_p(self._transfers[i][6]), self._transfers[i][7], c_size_t(1), self._transfers[i][4])
                           for i in self._tears]
        # the torn connections' values (one-value ctypes arrays in the scratch row: v[0] is a Python float); the
        # implicit loop works on lists of floats, numpy costing a microsecond per operation on these 1-2 values
        self._tear_values = [self._transfers[i][4] for i in self._tears]
        self._tear_scale = [0.0] * len(self._tears)
        # inverse interface Jacobian (dr/du)^-1 (list of rows), G at t - h, t - 2h
        self._inverse, self._g_past = None, []
        self.theta = THETA   # implicit coupling: the blend of G(t_k+1) and G(t_k), chosen at every interface Jacobian

    def _plan_bonds(self, views):
        """Power bonds: a connection carrying a speed (rad/s) from component A to B paired with one carrying a
        torque (N.m) from B back to A (the k-th speed with the k-th torque when there are several). Their product
        is the power A and B exchange; ``energy_block`` keeps each bond's energy residual."""
        def unit(conn):
            comp, name = conn.source.split(".", 1)
            return _unit(self.instances[comp].variables[name]) or None

        speeds, torques = {}, {}
        for i, transfer in enumerate(self._transfers):
            conn = transfer[-1]
            pair = (conn.source.split(".", 1)[0], conn.target.split(".", 1)[0])
            kind = unit(conn)
            if pair[0] != pair[1] and kind in (SPEED_UNIT, TORQUE_UNIT):
                (speeds if kind == SPEED_UNIT else torques).setdefault(pair, []).append(i)
        self.bond_energies, self._bonds = [], []
        tear_pos = {i: k for k, i in enumerate(self._tears)}
        for (a, b), speed_list in speeds.items():
            for w, tau in zip(speed_list, torques.get((b, a), [])):
                self.bond_energies.append(BondEnergy(self._transfers[w][-1], self._transfers[tau][-1]))
                # [speed's and torque's connections (their transfer index), their tear positions, previous
                # speed, previous torque, last residual, the one before, last E_speed] (``energy_block``)
                self._bonds.append([w, tau, tear_pos.get(w, -1), tear_pos.get(tau, -1),
                                    float(views[w][0]), float(views[tau][0]), 0.0, 0.0, 0.0])
        self._held = None   # implicit coupling: the torn inputs' values held over the last step

    def _log_text(self):
        lines = without_wrapper_noise(self.log)
        return ("\nFMU log:\n" + "\n".join(lines)) if lines else ""

    def _failure(self, message: str) -> Exception:
        """The error of an FMU call that failed: a CosimulationError of message and the FMUs' log, or,
        where a KeyboardInterrupt raised in an FMU's code made the call fail (its log says ``INTERRUPTED_IN_FMU``, or
        a handler raised one at once meanwhile: ``RAISED_IN_RUN``), the Interrupted it is."""
        if self._interrupted_in_fmu():
            RAISED_IN_RUN[0] = False
            return self._interrupted()
        return CosimulationError(message + self._log_text())

    def _interrupted_in_fmu(self) -> bool:
        """A KeyboardInterrupt was raised in an FMU's code (its log says ``INTERRUPTED_IN_FMU``) or a handler raised
        one at once while this co-simulation ran (``RAISED_IN_RUN``)."""
        return RAISED_IN_RUN[0] or any(INTERRUPTED_IN_FMU in line for line in self.log)

    def _communicate(self):
        """Transfer every connection, in feedthrough order, at the current communication point."""
        for op in self._ops:
            if op[0](op[1], op[2], op[3], op[4]) > 1:
                self._op_failed(op)

    def _op_failed(self, op):
        plan = self._ops if op in self._ops else self._lean_ops
        name = self._op_names[plan.index(op)] if op in plan else "reading the recorded signals"
        raise self._failure(f"t = {self.time!r}: {name} failed")

    def read(self, row):
        """Write the recorded signals at the current communication point into row (len(columns) floats)."""
        if not self._fresh:   # the last step read only what the connections need: transfer again, all of it
            self._communicate()
            self._fresh = True
        for op in self._readers:
            if op[0](op[1], op[2], op[3], op[4]) > 1:
                self._op_failed(op)
        row[:] = self._scratch_view[self._record_index]

    @property
    def iterates(self) -> bool:
        """True when the steps iterate the torn inputs (the implicit scheme with a loop to close, not found open)."""
        return self.coupling == "implicit" and bool(self._tears) and not self.open_loop

    def advance(self, n_steps, rows=None, progress=None, output_interval=1):
        """Take n_steps communication steps; when rows is given, record into it after every output_interval-th
        step and after the last (rows: ceil(n_steps / output_interval) x len(columns)). progress: optional
        callable(steps_done, n_steps) called now and then; returning False stops the run there (``RunStopped``).
        ``rows_done``: the rows written so far. A Ctrl-C raises KeyboardInterrupt at the next communication step
        (:func:`_stop_at_next_step`, while Python's own SIGINT handler was the one in place)."""
        previous, RAISED_IN_RUN[0] = None, False
        if (threading.current_thread() is threading.main_thread()
                and signal.getsignal(signal.SIGINT) is signal.default_int_handler):
            previous = signal.signal(signal.SIGINT, _stop_at_next_step)
        try:
            self._advance(n_steps, rows, progress, output_interval)
        finally:
            if previous is not None:
                signal.signal(signal.SIGINT, previous)
            asked, STOP[0] = STOP[0], False   # a Ctrl-C after the last step's check: this run's, not the next's
        if asked:
            raise self._interrupted()

    def _interrupted(self) -> Interrupted:
        """The Interrupted a Ctrl-C or SIGTERM raises at the current communication step."""
        return Interrupted(f"stopped at t = {self.time:.10g} s after {self.steps_done} steps")

    def _advance(self, n_steps, rows, progress, output_interval):
        """:meth:`advance` under whichever SIGINT handler is in place."""
        output_interval = _check_interval(output_interval)
        implicit = self.iterates
        monitor = bool(self._watched or self._bonds)
        every = max(1, n_steps // 200)
        self.rows_done, k = 0, 0
        # the watch: [scratch rows of the steps not yet watched, how many, the log's length before the last of
        # them]; the torn inputs' values held over each of them (implicit steps); rows recorded up to the step it
        # trips at
        self._watch_buffer = ([np.empty((min(n_steps, WATCH_BLOCK), len(self._scratch_view))), 0, len(self.log)]
                              if monitor else None)
        self._held_rows, self._advance_plan = [], (n_steps, output_interval)
        self._advance_start, self._rows_kept = self.steps_done, None
        if monitor:
            watched_at, watched_stride = self._watch_buffer[0].ctypes.data, self._watch_buffer[0].strides[0]
            scratch, scratch_size = addressof(self._scratch), sizeof(self._scratch)
        h, start = self.step_size, self.start_time
        if STOP[0]:   # asked while the FMUs were being set up
            STOP[0] = False
            raise self._interrupted()
        while k < n_steps:
            if not implicit:   # explicit steps up to the next progress report, in one tight loop
                count = min(n_steps - k, every - k % every) if progress is not None else n_steps - k
                self._explicit_steps(k, count, n_steps, output_interval, rows)
                k += count
            else:
                t = start + self.steps_done * h
                try:
                    self._implicit_step(t, h)
                except CosimulationError:   # a divergence the watch has not seen yet is reported first
                    self._settle_pending(failing=True)
                    raise
                self._fresh = True
                implicit = not self.open_loop
                self.steps_done += 1
                self.time = start + self.steps_done * h
                if not implicit:
                    self._communicate()
                k += 1
                if rows is not None and (k % output_interval == 0 or k == n_steps):
                    self.read(rows[self.rows_done])
                    self.rows_done += 1
                if monitor:   # the step's scratch row and held inputs, watched a block at a time
                    buffer = self._watch_buffer
                    memmove(watched_at + buffer[1] * watched_stride, scratch, scratch_size)
                    buffer[1] += 1
                    self._held_rows.append(self._held)
                    self._held = None
                    if (buffer[1] == len(buffer[0]) or len(self.log) != buffer[2] or k == n_steps or not implicit
                            or STOP[0]):
                        self._settle_pending()
                if STOP[0]:
                    STOP[0] = False
                    raise self._interrupted()
            if progress is not None and k % every == 0 and progress(k, n_steps) is False and k < n_steps:
                self._settle_pending()   # the steps taken first, as a failure would
                raise RunStopped(f"t = {self.time!r}: stopped by the progress callback after {k} of {n_steps} steps "
                                 "(it returned False); the results up to here are kept")

    def _explicit_steps(self, k, count, n_steps, interval, rows):
        """Steps k+1 .. k+count of n_steps, explicit: step every FMU from t with its inputs held, transfer the
        connections (``_communicate``), record after every interval-th step and the last. Recorded points are
        copies of the scratch row, gathered into rows' columns in blocks. So are the watched steps' (every step's,
        kept across calls in ``_watch_buffer``), watched a block at a time (``_settle``): when the block is full,
        when an FMU logged in the last step, at the run's last step and before any failure is reported."""
        h, start, steps = self.step_size, self.start_time, self.steps_done
        steppers, ops, lean, readers = self._bare_steppers, self._ops, self._lean_ops, self._readers
        stop = STOP
        step_c, t_c = c_double(h), c_double()
        scratch, size = addressof(self._scratch), sizeof(self._scratch)
        block, filled, first_row = None, 0, self.rows_done
        if rows is not None:
            due = (k + count) // interval - k // interval + (k + count == n_steps and n_steps % interval != 0)
            block = np.empty((min(due, WATCH_BLOCK if interval == 1 else 4096), len(self._scratch_view)))
            base, stride = block.ctypes.data, block.strides[0]
        buffer, watched, pending, logged, shared, log = self._watch_buffer, None, 0, 0, False, self.log
        if buffer is not None:
            # a call that takes the whole run recording every step: the watch reads the record block
            shared = block is not None and interval == 1 and k == 0 and count == n_steps
            watched = block if shared else buffer[0]
            watch_base, watch_stride = watched.ctypes.data, watched.strides[0]
            pending, logged = buffer[1], buffer[2]

        def flush():
            nonlocal filled, first_row
            np.take(block[:filled], self._record_index, axis=1, out=rows[first_row:first_row + filled])
            first_row += filled
            self.rows_done, filled = first_row, 0

        def settle(last, failing=False):
            """Watch the pending steps, the last of them step ``last`` (failing: before a failure in the step after
            them is reported)."""
            nonlocal pending, logged
            buffer[1], buffer[2] = pending, logged
            view = block[filled - pending:filled] if shared else watched[:pending]
            pending = 0
            try:
                self._settle(view, last, n_steps, interval, not failing)
            finally:
                pending, logged = buffer[1], buffer[2]

        record = self._fresh
        try:
            for j in range(k + 1, k + count + 1):
                t_c.value = start + steps * h
                for do_step, comp, name in steppers:
                    if do_step(comp, t_c, step_c, 1) > 1:
                        if pending:
                            settle(steps, failing=True)
                        self._refused(name, t_c.value)
                steps += 1
                self.steps_done, self.time = steps, start + steps * h
                record = block is not None and (j % interval == 0 or j == n_steps)
                for op in ops if record else lean:
                    if op[0](op[1], op[2], op[3], op[4]) > 1:
                        if pending:
                            settle(steps - 1, failing=True)
                        self._op_failed(op)
                if record:
                    for op in readers:
                        if op[0](op[1], op[2], op[3], op[4]) > 1:
                            if pending:
                                settle(steps - 1, failing=True)
                            self._op_failed(op)
                    memmove(base + filled * stride, scratch, size)
                    filled += 1
                if watched is not None:
                    if not shared:
                        memmove(watch_base + pending * watch_stride, scratch, size)
                    pending += 1
                    # a full block, this step logged, or the record block it shares is full
                    if pending == len(watched) or len(log) != logged or (shared and filled == len(block)):
                        settle(steps)
                if record and filled == len(block):
                    flush()
                if stop[0]:
                    if pending:
                        settle(steps)
                    stop[0] = False
                    raise self._interrupted()
            if pending and k + count == n_steps:
                settle(steps)
        finally:
            self._fresh = record   # whether the recorded signals riding on the transfers are those of now
            if buffer is not None:
                buffer[1], buffer[2] = (0, logged) if shared else (pending, logged)
            if filled:
                flush()
            if self._rows_kept is not None:
                self.rows_done = min(self.rows_done, self._rows_kept)

    def _settle(self, rows, last, n_steps, interval, last_logged=True, held=None):
        """``_watch_rows`` over rows, the scratch rows of the steps up to step ``last`` (held: the torn inputs'
        values over each, implicit steps); where the watch trips, ``_rows_kept`` becomes the rows recorded up to
        that step (of the advance over n_steps recording every interval-th)."""
        self._watch_buffer[1] = 0
        try:
            self._watch_rows(rows, last - len(rows), self._watch_buffer[2], last_logged, held)
            self._watch_buffer[2] = len(self.log)
        except CouplingInstabilityError:
            j = self.steps_done - self._advance_start
            self._rows_kept = j // interval + (j == n_steps and n_steps % interval != 0)
            raise

    def _settle_pending(self, failing=False):
        """``_settle`` the steps not yet watched in ``_watch_buffer`` (failing: before a failure in the step after
        them is reported); where the watch trips, the rows recorded after that step are dropped."""
        buffer = self._watch_buffer
        if buffer is None or not buffer[1]:
            return
        held = np.array(self._held_rows, dtype=np.float64) if self._held_rows else None   # implicit steps
        self._held_rows = []
        try:
            self._settle(buffer[0][:buffer[1]], self.steps_done, *self._advance_plan, not failing, held)
        finally:
            if self._rows_kept is not None:
                self.rows_done = min(self.rows_done, self._rows_kept)

    def _step(self, steppers, t, h):
        """fmi2DoStep of each of steppers (bare: t and h as c_double)."""
        for do_step, comp, name in steppers:
            if do_step(comp, t, h, 1) > 1:
                self._refused(name, t.value)

    def _refused(self, name, t):
        if self._interrupted_in_fmu():   # a Ctrl-C, not a divergence
            raise self._failure("")
        if self._held_rows:   # implicit steps not yet watched: the reports below need them
            self._settle_pending(failing=True)
        growing = self._growth_report() or self._jump_report() or self._energy_report()
        if growing:   # a port left its range because the coupling was diverging
            raise CouplingInstabilityError(
                f"component '{name}' refused the step at t = {t!r} after the coupling went unstable: "
                f"{growing}; the component's own message follows" + self._log_text())
        raise self._failure(f"component '{name}' refused the step at t = {t!r}")

    def _remedy(self):
        return ("use the implicit coupling (the default; coupling = \"implicit\" in a scenario's [experiment], "
                "coupling=\"implicit\" from Python), which iterates this connection every step"
                if self.coupling == "explicit" else
                "reduce the step (step_size: try half) and check it with `ujfmu run --check-step` (from Python: "
                "ujfmu.stepsize.estimate)")

    def _where(self, conn):
        return conn.source.split(".", 1)[0], conn.target.split(".", 1)[0]

    def _worst_tear(self, ratio_of):
        """(index, ratio, growth state) of the torn connection with the largest ratio_of(growth state), None
        where ratio_of gives None for every one."""
        worst = None
        for i, state in zip(self._tears, self._growth):
            ratio = ratio_of(state)
            if ratio is not None and (worst is None or ratio > worst[1]):
                worst = (i, ratio, state)
        return worst

    def _jump_report(self):
        """Words on a torn connection whose last change reversed the one before it while growing
        GROWTH_FACTOR-fold, above GROWTH_FLOOR of its largest value ('' if none): a divergence too fast for the
        alternation count of ``_growth_report``."""
        worst = self._worst_tear(lambda state: abs(state[1] / state[5]) if (
            state[1] * state[5] < 0.0 and abs(state[1]) > GROWTH_FACTOR * abs(state[5])
            and abs(state[1]) > max(GROWTH_FLOOR * state[4], NOISE_FLOOR)) else None)
        if worst is None:
            return ""
        i, ratio, state = worst
        conn = self._transfers[i][-1]
        src, dst = self._where(conn)
        return (f"coupling instability between '{src}' and '{dst}': {conn.source} -> {conn.target} reversed its "
                f"change in the last step and grew x{ratio:.3g} in one step (from {abs(state[5]):.4g} to "
                f"{abs(state[1]):.4g}, t = {self.time!r}, {self.coupling} coupling, h = {self.step_size!r}); the "
                f"coupled loop diverges faster than one step can show. Remedy: {self._remedy()}. Results up to "
                "here are kept")

    def _energy_report(self):
        """Words on a power bond whose energy residual in the last step exceeded ENERGY_RATIO times the energy it
        transmitted while growing GROWTH_FACTOR-fold ('' if none)."""
        for bond, energy in zip(self._bonds, self.bond_energies):
            d_e, before, e_speed = bond[6], bond[7], bond[8]
            comp, inp = energy.torque.target.split(".", 1)
            if inp in self.instances[comp].stateless_inputs():   # the torque moves nothing there: no coupling error
                continue
            if abs(d_e) > ENERGY_RATIO * abs(e_speed) and abs(d_e) > GROWTH_FACTOR * abs(before) and d_e != 0.0:
                a, b = energy.components
                return (f"coupling instability between '{a}' and '{b}': the power bond {energy.speed.source} -> "
                        f"{energy.speed.target} / {energy.torque.source} -> {energy.torque.target} had an energy "
                        f"residual of {abs(d_e):.4g} J in the last step, {abs(d_e / e_speed) if e_speed else math.inf:.3g}x "
                        f"the {abs(e_speed):.4g} J it transmitted and {abs(d_e / before) if before else math.inf:.3g}x "
                        f"the step before (t = {self.time!r}, {self.coupling} coupling, h = {self.step_size!r}): "
                        f"the coupling, not the model, is feeding the motion. Remedy: {self._remedy()}. Results up "
                        "to here are kept")
        return ""

    def _noise(self):
        return IMPLICIT_NOISE_TOLERANCES * COUPLING_RTOL if self.coupling == "implicit" else 0.0

    def _watch_tripped(self, k, kind):
        report = (self._growth_report(tripped=k) if kind == "growth" else
                  self._chatter_report(k, self._growth[k]))
        raise CouplingInstabilityError(report + self._log_text())

    def _watch_rows(self, rows, steps_before, log_at, last_logged=True, held=None):
        """The watch over steps steps_before+1, ... whose scratch rows are rows (n x scratch), held the torn inputs'
        values over each (implicit steps; None: explicit): divergence and chatter (``watch_block``) and the power
        bonds' energy (``energy_block``) up to the step the watch trips at, if it does: steps_done and time are
        then set to that step's, the log cut to its length then (log_at: its length before the last row's step,
        which alone may have logged, and only if last_logged), and CouplingInstabilityError is raised."""
        hit = watch_block(self._growth, rows[:, self._watch_columns], len(self._tears),
                          self._noise()) if self._watched else None
        upto = len(rows) if hit is None else hit[0] + 1
        if self._bonds:
            energy_block(self._bonds, self.bond_energies, rows[:upto, self._bond_columns[0]],
                         rows[:upto, self._bond_columns[1]], 0.5 * self.step_size,
                         None if held is None else held[:upto])
        if hit is not None:
            row, k, kind = hit
            if row < len(rows) - 1 or not last_logged:
                del self.log[log_at:]
            self.steps_done = steps_before + row + 1
            self.time = self.start_time + self.steps_done * self.step_size
            self._watch_tripped(k, kind)

    def _chatter_report(self, k, state):
        """Words on the k-th watched connection chattering: reversing at nearly every step without dying out
        (``CHATTER_STEPS``)."""
        conn = self._transfers[self._watched[k]][-1]
        src, dst = self._where(conn)
        return (f"coupling chatter between '{src}' and '{dst}': the change of {conn.source} -> {conn.target} "
                f"reversed its sign at {state[8]} of the last {state[7]} steps without dying out (by "
                f"{abs(state[1]):.4g} in the last step, its largest value {state[4]:.4g}; t = {self.time!r}, "
                f"{self.coupling} coupling, h = {self.step_size!r}): an "
                "oscillation at the step rate, which the models cannot have at this step, so the results are the "
                "coupling's, not the system's. Either the coupled loop is at its stability limit (a stiff shaft, or a "
                "driven side heavier than its driver), or a component switches faster than one step resolves (e.g. "
                "a Load's torque reversing within omega_smooth of zero speed while one step moves the speed "
                "further). Remedy: reduce step_size until it is gone (check with `ujfmu run --check-step`), wire a "
                "stiff or heavy driveline torque-driven (README, \"Choose the wiring for the host\"), or make the "
                "switching smoother (a Load's omega_smooth). Results up to here are kept")

    def _growth_report(self, tripped=None):
        """Words on the growing alternation of the torn connection the watch tripped on (tripped: its index among
        the watched), else of the fastest-growing one whose alternations grew 1.5-fold a step ('' if none). Its
        rate per step: the change now over the one its n alternations began with, to the power 1 / (n - 1)."""
        if tripped is not None:   # GROWTH_FACTOR-fold over its alternations: any rate per step
            state = self._growth[tripped]
            worst = self._tears[tripped], (abs(state[1]) / state[3]) ** (1.0 / (state[2] - 1)), state
        else:
            worst = self._worst_tear(lambda state: (abs(state[1]) / state[3]) ** (1.0 / (state[2] - 1)) if (
                state[2] >= 2 and state[3] > 0.0 and abs(state[1]) > 1.5 ** state[2] * state[3]) else None)
        if worst is None:
            return ""
        i, ratio, state = worst
        conn = self._transfers[i][-1]
        src, dst = self._where(conn)
        remedy = self._remedy()
        return (f"coupling instability between '{src}' and '{dst}': {conn.source} -> {conn.target} changes sign at "
                f"every step for {state[2]} steps, growing x{ratio:.3g} per step (to {abs(state[1]):.4g}, "
                f"t = {self.time!r}, {self.coupling} coupling, h = {self.step_size!r}); the coupled loop feeds "
                f"energy into an oscillation at the step rate. Remedy: {remedy}")

    def _implicit_step(self, t, h):
        """One implicitly coupled step [t, t + h]: the torn inputs u held over the step are iterated until
        u = G(u), G the values their connections carry at t + h after the rolled-back components stepped with u
        and every connection was transferred in feedthrough order.

        Residual r(u) = G(u) - u, solved by a quasi-Newton method on the interface Jacobian dr/du: built by
        finite differences (Kuebler and Schiehlen 2000), then kept up to date across steps by Broyden's rank-one
        update r_{j+1} - r_j = J (u_{j+1} - u_j), which for one torn input is the secant method and the one-column
        case of IQN-ILS (Degroote et al. 2009); its inverse H is what is kept, updated by Sherman-Morrison
        (H += (s - H y) s^T H / (s^T H y), s = du, y = dr), so an iteration costs a matrix-vector product. The
        components owning torn inputs are restored with fmi2SetFMUstate before each re-step; the others step once.
        Ends with the FMUs at t + h and every connection transferred there.
        """
        states = self._states
        for (get_state, _, _, comp, name), ref in zip(self._state_ops, self._state_refs):
            if get_state(comp, ref) > 1:
                raise self._failure(f"component '{name}' could not save its state at t = {t!r}")
        try:
            self._step(self._fixed_steppers, c_double(t), c_double(h))
            g_start = [v[0] for v in self._tear_values]
            self._g_start = g_start
            past, theta = self._g_past, self.theta
            if len(past) == 2:    # G at t + h extrapolated quadratically from t, t - h, t - 2h
                u = [g + theta * (2.0 * g - 3.0 * g1 + g2) for g, g1, g2 in zip(g_start, past[1], past[0])]
            elif past:
                u = [g + theta * (g - g1) for g, g1 in zip(g_start, past[-1])]
            else:
                u = g_start
            self._g_past = (past + [g_start])[-2:]
            end = t + h
            if any(abs(end - jump) <= JUMP_ROUNDING * max(1.0, abs(jump)) for jump in self._jumps):
                # an output jumps at the step's end: its value there is the jump's right side, which the blend
                # would take into this step; held at its start as the explicit scheme does (first order, one step)
                self._evaluate(g_start, t, h, states, restore=False)
                return
            r = self._evaluate(u, t, h, states, restore=False)
            scale = self._tear_scale
            for j, g in enumerate(g_start):   # the running max |G|, NaN kept as np.maximum keeps it
                if abs(g) > scale[j] or g != g:
                    scale[j] = abs(g)
            tol = [COUPLING_RTOL * s + COUPLING_ATOL for s in scale]
            best = (_worst(r, tol), u, r)
            rebuilds = 0
            while best[0] > 1.0:
                if self._inverse is None or rebuilds:
                    jacobian = self._fd_jacobian(u, r, t, h, states, tol)
                    # dG/du from dr/du = theta dG/du - I; the blend re-chosen for it, r and dr/du re-expressed
                    theta, d_g = self.theta, (jacobian + np.eye(len(u))) / self.theta
                    self.theta = blend_weight(d_g)
                    if self.theta != theta:
                        g = (np.add(r, u) - (1.0 - theta) * np.array(g_start)) / theta
                        r = (self.theta * g + (1.0 - self.theta) * np.array(g_start) - u).tolist()
                        jacobian = self.theta * d_g - np.eye(len(u))
                        best = (_worst(r, tol), u, r)
                    self._inverse = np.linalg.inv(jacobian).tolist()
                    # no connection's value moves with u (an ideal speed source ignores its tau_load): no loop to
                    # iterate; explicit from the next step on. Where only G ignores u within a step (a shaft's torque
                    # set by its twist alone, an owner that does move with u), the blend still takes G at t + h
                    self.open_loop = self._inert
                inverse = self._inverse
                for _ in range(MAX_ITERATIONS):
                    du = [-_dot(row, r) for row in inverse]
                    u_new = [a + b for a, b in zip(u, du)]
                    r_new = self._evaluate(u_new, t, h, states)
                    h_dr = [_dot(row, [a - b for a, b in zip(r_new, r)]) for row in inverse]
                    denominator = _dot(du, h_dr)
                    if denominator != 0.0:   # Broyden's update of the inverse (Sherman-Morrison)
                        _broyden(inverse, du, h_dr, denominator)
                    u, r = u_new, r_new
                    error = _worst(r, tol)
                    if error < best[0]:
                        best = (error, u, r)
                    if error <= 1.0:
                        break
                else:
                    rebuilds += 1
                    if rebuilds <= MAX_REBUILDS:
                        continue
                    if len(u) == 1 and best[0] > STALL_FACTOR:   # a steep G (a load's friction at rest)
                        best = min(best, self._bracketed_root(best[1], best[2], t, h, states, tol))
                        if best[0] <= 1.0:
                            if best[1] != self._held:
                                self._evaluate(best[1], t, h, states)
                            break
                    # no fixed point within tol: G jumps inside the step (a torque limit switching on or off)
                    if best[0] > STALL_FACTOR:
                        raise CosimulationError(self._divergence_message(t, best[2], tol))
                    self.stalled_steps += 1
                    self.stalled_worst = max(self.stalled_worst, best[0])
                    self._evaluate(best[1], t, h, states)
                break
        finally:
            for (_, _, free_state, comp, _), state, ref in zip(self._state_ops, states, self._state_refs):
                free_state(comp, ref)
                state.value = None

    def _bracketed_root(self, u, r, t, h, states, tol) -> tuple:
        """(error, u, r) of one torn input's fixed point by the Illinois method, where quasi-Newton steps stall
        on a steep G (a load's smoothed friction through rest: dG/du up to T0 h / (J omega_smooth)). A passive loop
        gives dG/du <= 0, so r = theta G + (1 - theta) G(t_k) - u falls with slope at most -1 and [u, u + r]
        brackets its root; otherwise (no sign change there) the best point found is returned."""
        best = (_worst(r, tol), u, r)
        a, fa = u[0], r[0]
        b = a + fa
        fb = self._evaluate([b], t, h, states)[0]
        best = min(best, (_worst([fb], tol), [b], [fb]))
        if not (fa * fb < 0.0):
            return best
        side = 0
        for _ in range(BRACKET_ITERATIONS):
            if best[0] <= 1.0:
                break
            c = (a * fb - b * fa) / (fb - fa)
            fc = self._evaluate([c], t, h, states)[0]
            best = min(best, (_worst([fc], tol), [c], [fc]))
            if fc * fb < 0.0:
                a, fa, b, fb, side = b, fb, c, fc, 0
            else:   # the end kept twice running is halved (Illinois): linear convergence becomes superlinear
                b, fb = c, fc
                if side == -1:
                    fa *= 0.5
                side = -1
        return best

    def _evaluate(self, u, t, h, states, restore=True):
        """r(u) = G(u) - u: step the rolled-back components with the torn inputs held at u, transfer everything
        at t + h, and read what the torn connections carry."""
        self.iterations += 1
        if restore:
            for (_, set_state, _, comp, name), state in zip(self._state_ops, states):
                if set_state(comp, state) > 1:
                    raise self._failure(f"component '{name}' could not restore its state at t = {t!r}")
        for (set_, dst, dst_vr, one, buffer), i, value in zip(self._tear_sets, self._tears, u):
            buffer[0] = value
            if set_(dst, dst_vr, one, buffer) > 1:
                raise self._failure(f"t = {t!r}: setting {self._transfers[i][-1].target} failed")
        self._held = u
        self._step(self._rolled_steppers, c_double(t), c_double(h))
        self.time = t + h
        self._communicate()
        theta = self.theta
        return [theta * v[0] + (1.0 - theta) * g0 - ui for v, g0, ui in zip(self._tear_values, self._g_start, u)]

    def _fd_jacobian(self, u, r, t, h, states, tol):
        """dr/du by forward differences, one torn input at a time (n re-steps); ``_inert`` set to whether no
        connection's value moved with any probe."""
        self.jacobian_builds += 1
        n = len(u)
        jac = np.empty((n, n))
        values = [t_[4][0] for t_ in self._transfers]   # at u: the last evaluation's
        self._inert = True
        for j in range(n):
            du = max(1e-6 * max(abs(u[j]), self._tear_scale[j]), 1e3 * COUPLING_ATOL)
            probe = list(u)
            probe[j] += du
            jac[:, j] = (np.array(self._evaluate(probe, t, h, states)) - r) / du
            self._inert = self._inert and [t_[4][0] for t_ in self._transfers] == values
        if not np.all(np.isfinite(jac)) or abs(np.linalg.det(jac)) < 1e-12:
            raise CosimulationError(self._divergence_message(t, r, tol, "its interface Jacobian is singular"))
        return jac

    def _divergence_message(self, t, r, tol, why=None):
        names = ", ".join(f"{self._transfers[i][-1].source} -> {self._transfers[i][-1].target} "
                          f"(|residual| {abs(ri):.3g}, tolerance {ti:.3g})" for i, ri, ti in zip(self._tears, r, tol))
        return (f"implicit coupling did not converge in the step at t = {t!r} (h = {self.step_size!r}): {names}"
                + (f": {why}" if why else "") + "; reduce the step size" + self._log_text())

    def run(self, n_steps, progress=None, output_interval=1):
        """Record the current point, take n_steps steps recording after every output_interval-th step and the
        last; a structured array with 'time' and one column per recorded 'comp.var'."""
        output_interval = _check_interval(output_interval)
        steps = np.arange(0, n_steps + 1, output_interval)
        if steps[-1] != n_steps:
            steps = np.append(steps, n_steps)
        values = np.empty((len(steps), len(self.columns)))
        t0 = self.time
        self.read(values[0])
        try:
            self.advance(n_steps, values[1:], progress, output_interval)
        except (CosimulationError, Interrupted) as exc:   # keep what was recorded up to the last completed step
            exc.partial = self._table(t0, values[:self.rows_done + 1], steps)
            raise
        finally:
            self._warn_fmu_warnings()
        return self._table(t0, values, steps)

    def _table(self, t0, values, steps):
        time = t0 + self.step_size * steps[:len(values)]
        dtype = np.dtype([("time", np.float64)] + [(c, np.float64) for c in self.columns])
        return np.rec.fromarrays([time] + list(values.T), dtype=dtype)

    def close(self):
        """Free the FMUs; a Ctrl-C meanwhile waits for the end of it (``deferred_interrupt``) and is kept in
        ``interrupted_while_closing`` (``cosimulate`` then raises Interrupted with the complete results)."""
        asked = STOP[0]
        with deferred_interrupt():
            for inst in self.instances.values():
                inst.free()
            self.instances = {}
            if getattr(self, "_open", False):
                self._open = False
                OPEN[0] -= 1
        if STOP[0] and not asked:   # pressed while the FMUs were freed: the run's, not the next one's
            STOP[0] = False
            self.interrupted_while_closing = True

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def inertia_amplification(d_g: np.ndarray, theta: float) -> float:
    """Largest step-to-step amplification of a perturbation of the torn values in the iterated loop
    u_k = theta G_k+1 + (1 - theta) G_k, G_k+1 = D u_k + (memory), for each eigenvalue D of dG/du.

    Two memories, those of the kinematically driven joints' acceleration estimates: none (backward difference,
    G_k+1 = D u_k: z = (1 - theta) D / (1 - theta D)), and that of the second-order (BDF2) slope, whose torque
    also carries -D/3 of the previous step's input (3 z^2 = D (3 z - 1)(theta z + 1 - theta)); the larger modulus
    of the two. Heavy driven side (D -> -inf): (1 - theta)/theta for both (docs/cosimulation.md, "Implicit").
    """
    worst = 0.0
    for d in np.linalg.eigvals(np.atleast_2d(d_g)):
        memoryless = abs((1.0 - theta) * d / (1.0 - theta * d)) if theta * d != 1.0 else math.inf
        bdf2 = np.roots([3.0 - 3.0 * d * theta, -d * (3.0 - 4.0 * theta), d * (1.0 - theta)])
        worst = max(worst, memoryless, float(np.max(np.abs(bdf2))) if len(bdf2) else 0.0)
    return worst


def blend_weight(d_g: np.ndarray) -> float:
    """The least theta in [1/2, THETA] with ``inertia_amplification``(dG/du, theta) <= AMPLIFICATION_BOUND (THETA
    where none is): theta = 1/2 holds the step mean of a smoothly varying torn value to second order (the
    trapezoidal rule), each increment of theta adds the first-order error (theta - 1/2) h dG/dt, so the blend is
    raised above 1/2 only as far as the loop's inertia feedback needs to keep the bound THETA guarantees for any
    inertia ratio. Bisection; the amplification falls with theta for the inertia feedback (D < 0)."""
    if inertia_amplification(d_g, 0.5) <= AMPLIFICATION_BOUND:
        return 0.5
    if inertia_amplification(d_g, THETA) > AMPLIFICATION_BOUND:
        return THETA
    lo, hi = 0.5, THETA
    while hi - lo > 1e-4:
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if inertia_amplification(d_g, mid) <= AMPLIFICATION_BOUND else (mid, hi)
    return hi


def watch_step(states: list, values: list, torn: int, noise: float):
    """One communication step of the divergence and chatter watch. states: per watched connection (torn first)
    [last value, last change, alternations, |change| when they began, largest |value|, the change before the
    last, chatter score, steps and reversals since the score left 0, the last large change], updated in place;
    values: their values now; torn: how many are torn; noise: the least |change| a growth is measured from, as a
    share of the largest |value|.

    Growth: a torn connection's change d_k = g_k - g_k-1 alternating in sign at GROWTH_STEPS steps in a row
    while |d| grows GROWTH_FACTOR-fold (the explicit inertia coupling's mode d_k = -(J_driven / J_driver) d_k-1,
    docs/cosimulation.md); chatter: the score of ``CHATTER_STEPS``. Returns (k, "growth" or "chatter") of the
    first connection that trips, None when none does (the later connections' states are then not updated)."""
    floor, share = NOISE_FLOOR, CHATTER_SHARE
    for k, (state, g) in enumerate(zip(states, values)):
        d = g - state[0]
        size = d if d >= 0.0 else -d
        top = g if g >= 0.0 else -g
        if top > state[4]:
            state[4] = top
        top = state[4]
        last = state[1]
        state[0], state[1] = g, d
        if k < torn:   # growth: the alternations of a torn connection's change
            state[5] = last
            if d * last < 0.0 and size > floor:
                state[2] += 1
                if state[2] == 1:
                    state[3] = max(size, noise * top)
            else:
                state[2], state[3] = 0, size
            if (state[2] >= GROWTH_STEPS and size > GROWTH_FACTOR * state[3]
                    and size > GROWTH_FLOOR * top):
                return k, "growth"
        if size >= share * top and size > floor:   # chatter: the score of large reversals that do not die out
            if d * state[9] < 0.0 and size >= CHATTER_SUSTAIN * abs(state[9]):
                state[6] += 1
                state[8] += 1
            elif d * state[9] < 0.0:   # a reversal smaller than the last: a decaying alternation, no chatter
                state[6] = max(0, state[6] - CHATTER_FADE)
            else:
                state[6] = max(0, state[6] - CHATTER_BREAK)
            state[9] = d
        elif state[6]:   # a small change (a saturated value held): the score fades
            state[6] = max(0, state[6] - CHATTER_FADE)
        if state[6]:
            state[7] += 1
            if state[6] >= CHATTER_STEPS:
                return k, "chatter"
        elif state[7]:
            state[7] = state[8] = 0
    return None


def watch_block(states: list, values: np.ndarray, torn: int, noise: float):
    """``watch_step`` over the rows of values (n steps x len(states)) in order: (row, k, kind) of the first trip,
    None when none trips; states as after the last step watched.

    Vectorized where it can show that no step trips and no chatter score rises (no growth run reaches
    GROWTH_STEPS growing GROWTH_FACTOR-fold, no large change reverses the last large one, every score 0): the
    states are then set from the block's last steps. Otherwise every row goes through ``watch_step``."""
    n, m = values.shape
    if n == 0 or m == 0:
        return None
    s = np.array(states, dtype=np.float64)
    idx = np.arange(n)[:, None]
    with np.errstate(all="ignore"):
        g = values
        d = g - np.vstack([s[:, 0], g[:-1]])
        size = np.abs(d)
        top = np.fmax.accumulate(np.vstack([s[:, 4], np.abs(g)]), axis=0)[1:]
        last = np.vstack([s[:, 1], d[:-1]])
        # chatter: a large change against the last large one (its sign carried by states[9])
        large = (size >= CHATTER_SHARE * top) & (size > NOISE_FLOOR)
        upto = np.maximum.accumulate(np.where(large, idx, -1), axis=0)   # the last large change's row, or -1
        before = np.vstack([np.full(m, -1), upto[:-1]])
        reference = np.where(before >= 0, np.take_along_axis(d, np.maximum(before, 0), axis=0), s[:, 9])
        quiet = not (s[:, 6].any() or (large & (d * reference < 0.0)).any() or np.isnan(s[:, 4]).any())
        # growth of the torn ones: the run of alternations up to each row and |change| when it began
        alternating = (d * last < 0.0) & (size > NOISE_FLOOR)
        broken = np.maximum.accumulate(np.where(alternating, -1, idx), axis=0)   # last row not alternating
        carried = broken < 0
        run = np.where(carried, s[:, 2] + idx + 1, idx - broken)
        began = np.take_along_axis(np.maximum(size, noise * top), np.clip(broken + 1, 0, n - 1), axis=0)
        began = np.where(carried & (s[:, 2] > 0), s[:, 3], began)
        trips = (run >= GROWTH_STEPS) & (size > GROWTH_FACTOR * began) & (size > GROWTH_FLOOR * top)
    if not quiet or trips[:, :torn].any():
        for row in range(n):
            hit = watch_step(states, values[row].tolist(), torn, noise)
            if hit is not None:
                return (row,) + hit
        return None
    for k, state in enumerate(states):
        state[0], state[1], state[4] = float(g[-1, k]), float(d[-1, k]), float(top[-1, k])
        if k < torn:
            state[5] = float(last[-1, k])
            state[2], state[3] = ((int(run[-1, k]), float(began[-1, k])) if alternating[-1, k]
                                  else (0, float(size[-1, k])))
        if upto[-1, k] >= 0:
            state[9] = float(d[upto[-1, k], k])
    return None


def energy_block(bonds: list, energies: list, w: np.ndarray, tau: np.ndarray, half: float,
                 held: np.ndarray | None = None) -> None:
    """The energy residual of every power bond over n steps (Sadjina et al. 2017), added to energies (``BondEnergy``)
    in step order: each side held its input over [t_k, t_k+1] (u_held) and its own output moved from y_k to
    y_k+1, so

        E_speed  = tau_held h (w_k + w_k+1)/2,     E_torque = w_held h (tau_k + tau_k+1)/2,
        dE_k     = E_torque - E_speed

    w, tau: the bonds' speeds and torques after each step (n x len(bonds)); held: the torn inputs' values held over
    each step (n x torn, implicit coupling), else each side held its input at the step's start (explicit:
    dE_k = h/2 (w_k tau_k+1 - tau_k w_k+1)). A perfect coupling has dE_k = 0; for a speed-driven bond dE_k > 0 is
    energy the coupling created. bonds: per bond [speed's and torque's connections (unused here), their tear
    position or -1, previous speed, previous torque, last residual, the one before, last E_speed], updated."""
    if len(w) == 0:
        return
    start = np.array([[bond[4] for bond in bonds], [bond[5] for bond in bonds]])
    w_before = np.vstack([start[0], w[:-1]])
    tau_before = np.vstack([start[1], tau[:-1]])
    w_held, tau_held = w_before, tau_before
    if held is not None:
        w_held, tau_held = w_before.copy(), tau_before.copy()
        for b, bond in enumerate(bonds):
            if bond[2] >= 0:
                w_held[:, b] = held[:, bond[2]]
            if bond[3] >= 0:
                tau_held[:, b] = held[:, bond[3]]
    e_speed = tau_held * half * (w_before + w)
    d_e = w_held * half * (tau_before + tau) - e_speed
    for b, (bond, energy) in enumerate(zip(bonds, energies)):
        energy.residual = float(np.add.accumulate(np.append(energy.residual, d_e[:, b]))[-1])
        energy.residual_abs = float(np.add.accumulate(np.append(energy.residual_abs, np.abs(d_e[:, b])))[-1])
        energy.transmitted = float(np.add.accumulate(np.append(energy.transmitted, np.abs(e_speed[:, b])))[-1])
        bond[7] = float(d_e[-2, b]) if len(d_e) > 1 else bond[6]
        bond[4], bond[5], bond[6], bond[8] = (float(w[-1, b]), float(tau[-1, b]), float(d_e[-1, b]),
                                              float(e_speed[-1, b]))


def _dot(a: list, b: list) -> float:
    """sum_i a_i b_i, summed in order."""
    total = 0.0
    for x, y in zip(a, b):
        total += x * y
    return total


def _worst(r: list, tol: list) -> float:
    """max_i |r_i| / tol_i, NaN if any is (as numpy's max)."""
    worst = 0.0
    for ri, ti in zip(r, tol):
        ratio = abs(ri) / ti
        if ratio > worst or ratio != ratio:
            worst = ratio
            if ratio != ratio:
                break
    return worst


def _broyden(inverse: list, du: list, h_dr: list, denominator: float) -> None:
    """Broyden's update of the inverse Jacobian H (rows, in place) by Sherman-Morrison:
    H += (du - H dr) (du^T H) / (du^T H dr), h_dr = H dr."""
    du_h = [_dot(du, column) for column in zip(*inverse)]
    for row, a, b in zip(inverse, du, h_dr):
        c = a - b
        for j, w in enumerate(du_h):
            row[j] += c * w / denominator


def _unit(var) -> str:
    """A variable's unit, its own or its declared type's ('' for none)."""
    return var.unit or (var.declaredType.unit if var.declaredType is not None else None) or ""


def check_wiring(connections: list, instances: dict) -> None:
    """CosimulationError naming the connection where one joins an output to an input of another unit or type, feeds
    an input another connection feeds already, or feeds an input the component's parameters also set (the
    connection would override it silently), as a scenario file refuses them; names are 'component.variable'."""
    fed = {}
    for i, conn in enumerate(connections):
        ends = []
        for role, end in (("source", conn.source), ("target", conn.target)):
            comp, dot, name = str(end).partition(".")
            if not dot or comp not in instances:
                raise CosimulationError(f"connections[{i}].{role} = {end!r}: give 'component.variable' with one of "
                                        f"the components {', '.join(map(repr, instances))}")
            inst = instances[comp]
            inst.vr(name)   # names the variables it has where it has no such one
            ends.append((inst, inst.variables[name]))
        (_, out), (target, inp) = ends
        if inp.causality != "input":
            raise CosimulationError(f"connections[{i}]: {conn.target} is an {inp.causality}, not an input")
        if (_VALUE_KINDS.get(out.type, out.type), _unit(out)) != (_VALUE_KINDS.get(inp.type, inp.type), _unit(inp)):
            raise CosimulationError(f"connections[{i}]: {conn.source} [{_unit(out) or out.type}] cannot feed "
                                    f"{conn.target} [{_unit(inp) or inp.type}]: units differ")
        if conn.target in fed:
            raise CosimulationError(f"connections[{i}].target = {conn.target!r} is already fed by connections"
                                    f"[{fed[conn.target]}] ({connections[fed[conn.target]].source}): an input takes "
                                    "one connection")
        if inp.name in target.parameters:
            raise CosimulationError(f"connections[{i}] feeds {conn.target}, which the component's parameters also "
                                    f"set ({target.parameters[inp.name]!r}): the connection would override it; drop "
                                    "one of the two")
        fed[conn.target] = i


#: what pythonfmu's C++ layer logs, as a fatal error, after our Python code refused a call with its own message
_WRAPPER_NOISE = "Fatal py exception encountered"


def without_wrapper_noise(log: list) -> list:
    """The FMU log without pythonfmu's own "Fatal py exception encountered ... unknown error" after an error the
    same instance logged first (which names the cause; the wrapper's line names none)."""
    erred, kept = set(), []
    for line in log:
        status, _, rest = line.partition("] ")
        instance = rest.partition(":")[0]
        if status == "[error":
            erred.add(instance)
        elif status == "[fatal" and _WRAPPER_NOISE in rest and instance in erred:
            continue
        kept.append(line)
    return kept


def held_inputs(instances: dict, connections: list, parameters: dict) -> list:
    """The inputs no connection feeds, as ``HeldInput``: the master holds each at its start value (or the value
    the component's parameters give it) over the whole run; but for an input of a ujfmu FMU that its parameters
    leave unread (its ``used_if`` parameter at 0: a Load's phi without a periodic torque)."""
    fed = {c.target for c in connections}
    held = []
    for comp, inst in instances.items():
        unread = _unread_inputs(inst.md, parameters.get(comp, {}))
        for var in inst.md.modelVariables:
            if var.causality != "input" or f"{comp}.{var.name}" in fed or var.name in unread:
                continue
            value = parameters.get(comp, {}).get(var.name, var.start)
            try:
                value = float(value)
            except (TypeError, ValueError):
                value = math.nan
            held.append(HeldInput(comp, var.name, value, _unit(var)))
    return held


def _ujfmu_class(md):
    """The FMU class of a ujfmu FMU (by its model name and generation tool); None for any other FMU."""
    from .build import FMUS, fmu_class
    if md.modelName not in FMUS or "ujfmu" not in (md.generationTool or ""):
        return None
    return fmu_class(md.modelName)


def _model_and_parameters(md, values: dict, what: str) -> tuple:
    """(model, its Parameters at values over the declared parameters) of a ujfmu FMU whose model has ``what``;
    (None, None) for any other FMU, a model without it, or parameters its model cannot take (the FMU's
    initialization names them)."""
    cls = _ujfmu_class(md)
    model = getattr(cls, "MODEL", None)
    if model is None or not hasattr(model, what):
        return None, None
    values = {**{v.name: v.start for v in cls.VARIABLES if v.causality == "parameter"}, **values}
    try:
        return model, model.Parameters(**{f.name: values[f.name] for f in dataclasses.fields(model.Parameters)
                                          if f.init})
    except (ArithmeticError, ValueError, TypeError, KeyError):
        return None, None


def _output_jumps(md, values: dict) -> tuple:
    """The times [s] where the outputs of a ujfmu FMU jump at values over its declared parameters (its model's
    ``output_jumps``: a speed profile's step, a load step); none for any other FMU."""
    model, p = _model_and_parameters(md, values, "output_jumps")
    return () if model is None else tuple(float(t) for t in model.output_jumps(p))


def changes_by(md, values: dict, t: float) -> bool:
    """True where the outputs of a ujfmu FMU at time t differ from those at 0 at values over its declared
    parameters (its model's ``changes_by``: a speed profile that moved, a load changed); False for any other
    FMU."""
    model, p = _model_and_parameters(md, values, "changes_by")
    return model is not None and bool(model.changes_by(p, t))


def _unread_inputs(md, values: dict) -> set:
    """Names of the inputs of a ujfmu FMU (by its model name and generation tool) whose ``used_if`` parameter is 0
    at values over its declared starts; none for any other FMU."""
    cls = _ujfmu_class(md)
    if cls is None:
        return set()
    declared = cls.VARIABLES
    starts = {v.name: v.start for v in declared if v.causality == "parameter"}
    return {v.name for v in declared if v.causality == "input" and v.used_if is not None
            and not {**starts, **values}.get(v.used_if)}


#: the kind of value each FMI 2.0 and 3.0 variable type takes (``typed_value``)
_VALUE_KINDS = {"Real": "a real number", "Float64": "a real number", "Float32": "a real number",
                "Integer": "a whole number", "Int32": "a whole number", "Int64": "a whole number",
                "Enumeration": "a whole number", "Boolean": "True or False"}


def typed_value(instance, var, value):
    """value as its FMI variable's type takes it: a real number (float) for a Real / Float64, a whole number (int)
    for an Integer or Enumeration, True or False (0 or 1) for a Boolean, a string for a String. Anything else is a
    CosimulationError naming the component and variable: a string "false" or 0.5 is not read as a truthy
    Boolean, nor "10deg" as a Real."""
    kind = _VALUE_KINDS.get(var.type)
    if kind is None:
        return str(value)
    number = isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_))
    if kind == "a real number" and number:
        return float(value)
    if kind == "a whole number" and number and float(value).is_integer():
        return int(value)
    if kind == "True or False" and (isinstance(value, (bool, np.bool_)) or (number and value in (0, 1))):
        return bool(value)
    unit = f" [{var.unit}]" if kind == "a real number" and var.unit else ""
    raise CosimulationError(f"component '{instance.name}' ({instance.md.modelName}): {var.name} = {value!r} must be "
                            f"{kind}{unit} ({var.type} in the modelDescription)"
                            + ("; give SI numbers (10 deg = 0.1745 rad, 1000 rpm = 104.7 rad/s)"
                               if isinstance(value, str) and kind == "a real number" else ""))


def _checked_setup(components, connections, record) -> tuple:
    """(components, connections, record) as the master takes them, or a CosimulationError naming what is wrong:
    components are ``Component`` objects with distinct names, connections ``Connection`` objects (or (source,
    target) pairs of "component.variable" names), record a list of such names (not one string)."""
    components, connections = list(components), list(connections)
    for i, comp in enumerate(components):
        if not isinstance(comp, Component):
            raise CosimulationError(f"components[{i}] = {comp!r} is a {type(comp).__name__}: give "
                                    "Component(name, fmu, parameters): fmu the FMU file's path, parameters a dict")
        if not isinstance(comp.parameters, dict):
            raise CosimulationError(f"components[{i}] ('{comp.name}'): parameters = {comp.parameters!r} must be a "
                                    "dict {name: value} ({} for none)")
    names = [comp.name for comp in components]
    twice = sorted({name for name in names if names.count(name) > 1})
    if twice:
        raise CosimulationError(f"component name{'s' if len(twice) > 1 else ''} {', '.join(map(repr, twice))} "
                                "used more than once: each component needs a name of its own (connections and "
                                "recorded signals name it)")
    checked = []
    for i, conn in enumerate(connections):
        if not isinstance(conn, Connection):
            if isinstance(conn, (tuple, list)) and len(conn) == 2 and all(isinstance(x, str) for x in conn):
                conn = Connection(*conn)
            else:
                raise CosimulationError(f"connections[{i}] = {conn!r}: give Connection('comp.output', 'comp.input') "
                                        "or a (source, target) pair of such names")
        checked.append(conn)
    if isinstance(record, str):
        raise CosimulationError(f"record = {record!r} is one string: give a list of 'component.variable' names, "
                                f"e.g. [{record!r}]")
    record = list(record)
    for name in record:
        if not isinstance(name, str):
            raise CosimulationError(f"record: {name!r} is not a 'component.variable' name")
    twice = sorted({name for name in record if record.count(name) > 1})
    if twice:
        raise CosimulationError(f"record names {', '.join(map(repr, twice))} more than once: each signal is a "
                                "column of the table, once")
    return components, checked, record


def _check_interval(output_interval) -> int:
    """output_interval as an int (a numpy integer too); CosimulationError unless a whole number >= 1."""
    if isinstance(output_interval, bool) or not isinstance(output_interval, numbers.Integral) or output_interval < 1:
        raise CosimulationError(f"output interval {output_interval!r} must be a whole number of steps >= 1")
    return int(output_interval)


def _vrs(*refs):
    return (fmi2ValueReference * len(refs))(*refs)


def cosimulate(components, connections, stop_time, step_size, record, start_time=0.0, progress=None,
               coupling=DEFAULT_COUPLING, output_interval=1, diagnostics=None):
    """Run the co-simulation; returns a structured array with 'time' and one column per recorded 'comp.var', a row
    every output_interval communication steps and at stop_time.

    progress: optional callable(steps_done, steps_total) called now and then. diagnostics: optional dict, filled
    (also when the run fails) with "bonds" (``BondEnergy`` per power bond), "held_inputs" (``HeldInput`` per
    input no connection feeds) and "fmu_warnings" (the FMUs' warnings as logged, each once, as they are also
    warned: ``FmuWarning``), "stalled" (the implicit scheme's steps taken at their best iterate, the largest
    residual among them in tolerances, the steps taken in all; also when the run fails) and after a run
    "iterates" (``Cosimulation.iterates``).
    """
    if not (isinstance(step_size, numbers.Real) and step_size > 0.0 and math.isfinite(step_size)):
        raise CosimulationError(f"communication step size {step_size!r} must be finite and > 0")
    for name, value in (("start_time", start_time), ("stop_time", stop_time)):
        if not (isinstance(value, numbers.Real) and math.isfinite(value)):
            raise CosimulationError(f"{name} = {value!r} s must be a finite number")
    if not stop_time > start_time:
        raise CosimulationError(f"stop_time = {stop_time!r} s must be after start_time = {start_time!r} s")
    if not (stop_time - start_time) / step_size <= MAX_STEPS:
        raise CosimulationError(f"{stop_time - start_time!r} s at a step of {step_size!r} s is "
                                f"{(stop_time - start_time) / step_size:.3g} steps, more than the {MAX_STEPS:.0e} a "
                                "run may take (its record alone would not fit in memory)")
    n_steps = int(round((stop_time - start_time) / step_size))
    if n_steps < 1 or not math.isclose(start_time + n_steps * step_size, stop_time, rel_tol=1e-9, abs_tol=1e-12):
        raise CosimulationError(f"stop_time - start_time = {stop_time - start_time} is not a whole number of "
                                f"communication steps of {step_size}")
    with Cosimulation(components, connections, step_size, record, start_time, coupling) as cosim:
        if diagnostics is not None:
            diagnostics.update(bonds=cosim.bond_energies, held_inputs=cosim.held_inputs, fmu_warnings=cosim.warned)
        try:
            table = cosim.run(n_steps, progress, output_interval)
        finally:   # a failed run's stalled steps too: they may be why it failed
            if diagnostics is not None:
                diagnostics["stalled"] = (cosim.stalled_steps, cosim.stalled_worst, cosim.steps_done)
        if diagnostics is not None:
            diagnostics["iterates"] = cosim.iterates
    if cosim.interrupted_while_closing:   # the run is complete: stopped with it
        stopped = Interrupted(f"stopped at t = {stop_time:.10g} s, the run's end, while its FMUs were freed")
        stopped.partial = table
        raise stopped
    return table
