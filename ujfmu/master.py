"""Fixed-step co-simulation master on fmpy's FMU2Slave.

Coupling scheme (Jacobi with ordered output propagation):

1. Instantiate every component, set its parameters in initialization mode, exit initialization mode.
2. At every communication point t_k, transfer the connections in a topological order of the direct-feedthrough
   graph read from each modelDescription (ModelStructure/Outputs dependencies): a connection leaving output
   ``A.y`` is transferred only after every input of A that y depends on has been set. Outputs with direct
   feedthrough (the joint's omega_out and tau_in, the load's tau) are therefore consistent with their inputs at
   t_k, with no one-step lag, and no FMU is stepped twice. A cycle in that graph (an algebraic loop) is an error.
3. Record, then step every FMU from t_k to t_k + h with its inputs held (each FMU sees values at t_k), and repeat.

The only coupling delay left is the held input over one step (first order in h), e.g. the motor sees the joint's
tau_in(t_k) during [t_k, t_k+1]. Stable for explicit inertia coupling while the driven inertia reflected to the
motor stays below the motor's own (see docs/cosimulation.md).
"""

import atexit
import math
import shutil
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi1 import calloc, free
from fmpy.fmi2 import (FMU2Slave, fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE,
                       fmi2CallbackFunctions, fmi2CallbackLoggerTYPE, fmi2Real, fmi2ValueReference)


class CosimulationError(RuntimeError):
    """A co-simulation could not be set up or an FMU refused a call; carries the FMUs' log messages."""


@dataclass
class Component:
    name: str
    fmu: Path
    parameters: dict = field(default_factory=dict)


@dataclass
class Connection:
    source: str   # "component.output"
    target: str   # "component.input"


_STATUS = ["ok", "warning", "discard", "error", "fatal", "pending"]


class FmuInstance:
    """One FMU instance over fmpy's FMU2Slave: variables by name, FMU log messages collected in ``log``."""

    def __init__(self, component, unzip_dir, model_description, log):
        self.name = component.name
        self.md = model_description
        self.variables = {v.name: v for v in model_description.modelVariables}
        self._log = log

        def logger(env, instance, status, category, message):
            log.append(f"[{_STATUS[status] if 0 <= status < 6 else status}] {instance.decode()}: "
                       f"{message.decode(errors='replace')}")

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

    def vr(self, name):
        try:
            return self.variables[name].valueReference
        except KeyError:
            raise CosimulationError(f"component '{self.name}' ({self.md.modelName}) has no variable '{name}'; "
                                    f"it has: {', '.join(self.variables)}") from None

    def set_value(self, name, value):
        var = self.variables.get(name)
        if var is None:
            self.vr(name)
        if var.type == "Real":
            self.slave.setReal([var.valueReference], [float(value)])
        elif var.type in ("Integer", "Enumeration"):
            self.slave.setInteger([var.valueReference], [int(value)])
        elif var.type == "Boolean":
            self.slave.setBoolean([var.valueReference], [bool(value)])
        else:
            self.slave.setString([var.valueReference], [str(value)])

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


def extracted(fmu):
    """(unzip folder, model description) of an FMU file, extracted once per process and file version.

    Every instance of an FMU then loads the same binary (the loader counts references) instead of a fresh copy
    from a fresh folder, which a sweep of thousands of co-simulations in one worker process would pile up. The
    folders are removed when the process exits."""
    path = Path(fmu).resolve()
    stat = path.stat()
    key = (str(path), stat.st_size, stat.st_mtime_ns)
    if key not in _EXTRACTED:
        if not _EXTRACTED:
            atexit.register(lambda: [shutil.rmtree(d, ignore_errors=True) for d, _ in _EXTRACTED.values()])
        _EXTRACTED[key] = (extract(str(path), unzipdir=tempfile.mkdtemp(prefix="ujfmu_fmu_")),
                           read_model_description(str(path)))
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

    def __init__(self, components, connections, step_size, record, start_time=0.0):
        if not (step_size > 0.0 and math.isfinite(step_size)):
            raise CosimulationError(f"communication step size {step_size!r} must be finite and > 0")
        self.step_size, self.time, self.steps_done = step_size, start_time, 0
        self.start_time = start_time
        self.log = []
        self.instances = {}
        try:
            self._setup(components, connections, record)
        except CosimulationError:
            self.close()
            raise
        except Exception as exc:
            self.close()
            raise CosimulationError(f"{exc}" + self._log_text()) from exc

    def _setup(self, components, connections, record):
        for comp in components:
            if not Path(comp.fmu).is_file():
                raise CosimulationError(f"component '{comp.name}': FMU file {comp.fmu} not found "
                                        "(run `ujfmu build` first)")
            unzip_dir, md = extracted(comp.fmu)
            self.instances[comp.name] = FmuInstance(comp, unzip_dir, md, self.log)
        for comp in components:
            self.instances[comp.name].initialize(comp.parameters, self.start_time)

        # Each connection: one fmi2GetReal into a buffer, one fmi2SetReal from it. A component's recorded
        # signals ride along on the last get from that component made after every input they depend on is set
        # (one call fewer per component and step); otherwise they get a fmi2GetReal of their own in read().
        ordered = _feedthrough_order(connections, self.instances)
        set_at = {tuple(c.target.split(".", 1)): i for i, c in enumerate(ordered)}
        get_vrs = [[self.instances[c.source.split(".", 1)[0]].vr(c.source.split(".", 1)[1])] for c in ordered]
        self.columns, riders, readers = [], [], []
        for comp_name in dict.fromkeys(name.split(".", 1)[0] for name in record):
            names = [name for name in record if name.split(".", 1)[0] == comp_name]
            if comp_name not in self.instances:
                raise CosimulationError(f"recorded signal '{names[0]}': no component '{comp_name}'")
            inst = self.instances[comp_name]
            vrs = [inst.vr(n.split(".", 1)[1]) for n in names]
            ready = max((set_at.get((comp_name, d), -1) for n in names
                         for d in inst.input_dependencies(n.split(".", 1)[1])), default=-1)
            host = next((i for i in range(len(ordered) - 1, ready, -1)
                         if ordered[i].source.split(".", 1)[0] == comp_name), None)
            if host is None:
                readers.append((inst, vrs, len(self.columns)))
            else:
                riders.append((host, len(get_vrs[host]), len(names), len(self.columns)))
                get_vrs[host] += vrs
            self.columns += names
        self._transfers, views = [], []
        for conn, vrs in zip(ordered, get_vrs):
            src, dst = (self.instances[x.split(".", 1)[0]] for x in (conn.source, conn.target))
            buffer = (fmi2Real * len(vrs))()
            views.append(np.frombuffer(buffer, dtype=np.float64))
            dst_vr = _vrs(dst.vr(conn.target.split(".", 1)[1]))
            self._transfers.append((src.raw("fmi2GetReal"), src.slave.component, _vrs(*vrs), len(vrs), buffer,
                                    dst.raw("fmi2SetReal"), dst.slave.component, dst_vr, conn))
        self._riders = [(views[host][offset:offset + n], column, n) for host, offset, n, column in riders]
        self._readers = []
        for inst, vrs, column in readers:
            buffer = (fmi2Real * len(vrs))()
            self._readers.append((inst.raw("fmi2GetReal"), inst.slave.component, _vrs(*vrs), len(vrs), buffer,
                                  np.frombuffer(buffer, dtype=np.float64), column))
        self._steppers = [(inst.raw("fmi2DoStep"), inst.slave.component, name)
                          for name, inst in self.instances.items()]
        self._communicate()

    def _log_text(self):
        return ("\nFMU log:\n" + "\n".join(self.log)) if self.log else ""

    def _communicate(self):
        """Transfer every connection, in feedthrough order, at the current communication point."""
        for get, src, src_vrs, n, buffer, set_, dst, dst_vr, conn in self._transfers:
            if get(src, src_vrs, n, buffer) > 1 or set_(dst, dst_vr, 1, buffer) > 1:
                raise CosimulationError(f"t = {self.time!r}: transfer {conn.source} -> {conn.target} failed"
                                        + self._log_text())

    def read(self, row):
        """Write the recorded signals at the current communication point into row (len(columns) floats)."""
        for view, offset, n in self._riders:
            row[offset:offset + n] = view
        for get, comp, vrs, n, buffer, view, offset in self._readers:
            if get(comp, vrs, n, buffer) > 1:
                raise CosimulationError(f"t = {self.time!r}: reading the recorded signals failed" + self._log_text())
            row[offset:offset + n] = view

    def advance(self, n_steps, rows=None, progress=None):
        """Take n_steps communication steps; when rows (n_steps x len(columns)) is given, record into it after
        every step. progress: optional callable(steps_done, n_steps) called now and then."""
        h, steppers, start = self.step_size, self._steppers, self.start_time
        every = max(1, n_steps // 200)
        for k in range(n_steps):
            t = start + self.steps_done * h
            for do_step, comp, name in steppers:
                if do_step(comp, t, h, 1) > 1:
                    raise CosimulationError(f"component '{name}' refused the step at t = {t!r}" + self._log_text())
            self.steps_done += 1
            self.time = start + self.steps_done * h
            self._communicate()
            if rows is not None:
                self.read(rows[k])
            if progress is not None and (k + 1) % every == 0:
                progress(k + 1, n_steps)

    def run(self, n_steps, progress=None):
        """Record the current point, take n_steps steps recording after each; a structured array with 'time'
        and one column per recorded 'comp.var'."""
        values = np.empty((n_steps + 1, len(self.columns)))
        t0 = self.time
        self.read(values[0])
        self.advance(n_steps, values[1:], progress)
        time = t0 + self.step_size * np.arange(n_steps + 1)
        dtype = np.dtype([("time", np.float64)] + [(c, np.float64) for c in self.columns])
        return np.rec.fromarrays([time] + list(values.T), dtype=dtype)

    def close(self):
        for inst in self.instances.values():
            inst.free()
        self.instances = {}

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def _vrs(*refs):
    return (fmi2ValueReference * len(refs))(*refs)


def cosimulate(components, connections, stop_time, step_size, record, start_time=0.0, progress=None):
    """Run the co-simulation; returns a structured array with 'time' and one column per recorded 'comp.var'.

    progress: optional callable(steps_done, steps_total) called now and then.
    """
    n_steps = int(round((stop_time - start_time) / step_size))
    if n_steps < 1 or not math.isclose(start_time + n_steps * step_size, stop_time, rel_tol=1e-9, abs_tol=1e-12):
        raise CosimulationError(f"stop_time - start_time = {stop_time - start_time} is not a whole number of "
                                f"communication steps of {step_size}")
    with Cosimulation(components, connections, step_size, record, start_time) as cosim:
        return cosim.run(n_steps, progress)
