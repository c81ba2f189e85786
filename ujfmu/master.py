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

import math
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi1 import calloc, free
from fmpy.fmi2 import (FMU2Slave, fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE,
                       fmi2CallbackFunctions, fmi2CallbackLoggerTYPE)


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


def _feedthrough_order(connections, instances):
    """Connections sorted so that each is transferred after the inputs its source output depends on."""
    def deps_of(comp, output):
        inst = instances[comp]
        for unknown in inst.md.outputs:
            if unknown.variable.name == output:
                if unknown.dependencies is None:  # no information: depends on every input
                    return [v.name for v in inst.md.modelVariables if v.causality == "input"]
                return [v.name for v in unknown.dependencies if v.causality == "input"]
        raise CosimulationError(f"'{comp}.{output}' is not an output of {inst.md.modelName}")

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


def cosimulate(components, connections, stop_time, step_size, record, start_time=0.0, progress=None):
    """Run the co-simulation; returns a structured array with 'time' and one column per recorded 'comp.var'.

    progress: optional callable(steps_done, steps_total) called now and then.
    """
    log = []
    instances = {}
    n_steps = int(round((stop_time - start_time) / step_size))
    if n_steps < 1 or not math.isclose(start_time + n_steps * step_size, stop_time, rel_tol=1e-9, abs_tol=1e-12):
        raise CosimulationError(f"stop_time - start_time = {stop_time - start_time} is not a whole number of "
                                f"communication steps of {step_size}")
    with tempfile.TemporaryDirectory(prefix="ujfmu_cosim_") as tmp:
        unzipped = {}
        try:
            for comp in components:
                fmu = str(comp.fmu)
                if fmu not in unzipped:
                    if not Path(fmu).is_file():
                        raise CosimulationError(f"component '{comp.name}': FMU file {fmu} not found "
                                                "(run `ujfmu build` first)")
                    unzipped[fmu] = (extract(fmu, unzipdir=str(Path(tmp) / str(len(unzipped)))),
                                     read_model_description(fmu))
                unzip_dir, md = unzipped[fmu]
                instances[comp.name] = FmuInstance(comp, unzip_dir, md, log)

            for comp in components:
                instances[comp.name].initialize(comp.parameters, start_time)

            ordered = _feedthrough_order(connections, instances)
            transfers = []
            for conn in ordered:
                src_comp, src_var = conn.source.split(".", 1)
                dst_comp, dst_var = conn.target.split(".", 1)
                src, dst = instances[src_comp], instances[dst_comp]
                transfers.append((src.slave, [src.vr(src_var)], dst.slave, [dst.vr(dst_var)]))
            readers = []
            columns = []
            for comp_name in dict.fromkeys(name.split(".", 1)[0] for name in record):
                names = [name for name in record if name.split(".", 1)[0] == comp_name]
                if comp_name not in instances:
                    raise CosimulationError(f"recorded signal '{names[0]}': no component '{comp_name}'")
                inst = instances[comp_name]
                readers.append((inst.slave, [inst.vr(n.split(".", 1)[1]) for n in names]))
                columns += names

            slaves = [instances[c.name].slave for c in components]
            rows = np.empty((n_steps + 1, len(columns) + 1))

            def communicate(k, t):
                for src, src_vr, dst, dst_vr in transfers:
                    dst.setReal(dst_vr, src.getReal(src_vr))
                row = rows[k]
                row[0] = t
                j = 1
                for slave, vrs in readers:
                    values = slave.getReal(vrs)
                    row[j:j + len(values)] = values
                    j += len(values)

            communicate(0, start_time)
            every = max(1, n_steps // 200)
            for k in range(n_steps):
                t = start_time + k * step_size
                for slave in slaves:
                    slave.doStep(currentCommunicationPoint=t, communicationStepSize=step_size)
                communicate(k + 1, start_time + (k + 1) * step_size)
                if progress is not None and (k + 1) % every == 0:
                    progress(k + 1, n_steps)
        except CosimulationError:
            raise
        except Exception as exc:
            raise CosimulationError(f"{exc}" + ("\nFMU log:\n" + "\n".join(log) if log else "")) from exc
        finally:
            for inst in instances.values():
                inst.free()
    dtype = np.dtype([("time", np.float64)] + [(c, np.float64) for c in columns])
    return np.rec.fromarrays(rows.T, dtype=dtype)
