"""Model Exchange run of a scenario: the FMI 3.0 Model Exchange FMUs of its components integrated together by
one solver, fmpy's CVode (BDF, SUNDIALS), as a system simulator that imports them would.

There is no communication step: at every right-hand-side evaluation the solver sets the time and every FMU's
continuous states, the connections are transferred in the order of the direct-feedthrough graph (as in
``ujfmu.master``), and the state derivatives are read. So there is no coupling delay and no explicit-coupling
instability; the accuracy is the solver's. Components must offer Model Exchange: the torque-driven variants
(CardanJoint, DoubleCardanDriveline, TwinJeffcottRotor, RingCoupling), MotorController and Load (``ujfmu build
--fmi 3``; the speed-driven models would need the driver's acceleration, an input derivative Model Exchange does
not provide). The FMUs' event indicators are the solver's root functions (``simulate_me``).
"""

import contextlib
import math
import re
import warnings
from ctypes import c_double

import numpy as np
from fmpy.fmi3 import FMU3Model

from .build3 import ME_TOLERANCE
from .fmi3_host import FmuInstance3
from .master import (OPEN, STOP, CosimulationError, FmuWarning, Interrupted, _feedthrough_order,
                     deferred_interrupt, extracted)


#: the spacing of floats at 1
EPS = np.finfo(float).eps


class ModelExchangeError(CosimulationError):
    """A Model Exchange run could not be set up, an FMU refused a call, or the solver failed."""


class MeInstance(FmuInstance3):
    """One FMI 3.0 Model Exchange FMU instance (fmpy's FMU3Model) with FmuInstance3's access by name."""

    INTERFACE = "modelExchange"
    FMU_CLASS = FMU3Model

    def __init__(self, component, unzip_dir, model_description, log):
        if not model_description.fmiVersion.startswith("3"):
            raise ModelExchangeError(f"component '{component.name}': {model_description.modelName} is an FMI "
                                     f"{model_description.fmiVersion} FMU; Model Exchange runs take the FMI 3.0 "
                                     "FMUs (ujfmu build --fmi 3, into fmus/fmi3/; from Python fmu_dir=\"fmus/fmi3\")")
        if model_description.modelExchange is None:
            raise ModelExchangeError(f"component '{component.name}': {model_description.modelName} has no Model "
                                     "Exchange interface (speed-driven joints need the driver's acceleration; use "
                                     "the torque-driven variant with a MotorController)")
        super().__init__(component, unzip_dir, model_description, log)
        self.nx = self.slave.getNumberOfContinuousStates()
        self.nz = self.slave.getNumberOfEventIndicators()
        self.time = 0.0
        self.buffer = (c_double * max(self.nx, 1))()
        self.z_buffer = (c_double * max(self.nz, 1))()


class _NoInput:
    @staticmethod
    def apply(time):
        pass


def simulate_me(components, connections, stop_time: float, output_interval: float, record, start_time=0.0,
                relative_tolerance: float = ME_TOLERANCE, events: list | None = None,
                event_indicators: bool = True, warned: list | None = None) -> np.ndarray:
    """Integrate the components' Model Exchange FMUs together with CVode; a structured array with 'time' and one
    column per recorded 'comp.var' at start_time + k * output_interval (as ``master.cosimulate`` returns).

    The FMUs' event indicators (the MotorController's torque limit and anti-windup switches) are CVode's root
    functions: the solver stops where one changes sign (located to its tolerance), every FMU goes through event
    mode and the solver restarts there, so no step straddles a switch of the right-hand side. So does every time
    event an FMU announces (fmi3UpdateDiscreteStates' nextEventTime: the MotorController's profile corner). Each
    event is appended to ``events`` (if given) as (time, 'comp.indicator') or (time, 'comp.time event');
    ``event_indicators=False`` leaves the switches to the solver's error control. What the FMUs warned of comes as
    one ``FmuWarning`` per distinct text, as from ``master.cosimulate``, and is appended to ``warned`` (if given),
    also when the run fails."""
    from fmpy.sundials import CVodeSolver

    n_out = int(round((stop_time - start_time) / output_interval))
    if n_out < 1 or not math.isclose(start_time + n_out * output_interval, stop_time, rel_tol=1e-9, abs_tol=1e-12):
        raise ModelExchangeError(f"stop_time - start_time = {stop_time - start_time} is not a whole number of "
                                 f"output intervals of {output_interval}")
    log, instances = [], {}
    failure = []

    def failed(what, exc):
        failure.append(f"{what}: {exc}")

    def table(rows):
        """The first rows of the output as a structured array."""
        time = start_time + output_interval * np.arange(rows)
        dtype = np.dtype([("time", np.float64)] + [(c, np.float64) for c in record])
        return np.rec.fromarrays([time] + list(values[:rows].T), dtype=dtype)

    values = np.empty((n_out + 1, len(record)))
    interrupts = contextlib.ExitStack()   # a Ctrl-C waits for the next output point (not inside CVode's callbacks)
    interrupts.enter_context(deferred_interrupt())
    OPEN[0] += 1   # open, as a co-simulation: the ``ujfmu`` command's handler then defers a Ctrl-C too
    try:
        for comp in components:
            unzip_dir, md = extracted(comp.fmu)
            instances[comp.name] = MeInstance(comp, unzip_dir, md, log)
        for comp in components:
            instances[comp.name].initialize(comp.parameters, start_time)
        for inst in instances.values():   # the FMUs cannot see fmi3EnterInitializationMode's startTime (pythonfmu3)
            inst.slave.setTime(start_time)
            inst.time = start_time
        ordered = _feedthrough_order(connections, instances)
        transfers = []
        for conn in ordered:
            (src, out), (dst, inp) = (x.split(".", 1) for x in (conn.source, conn.target))
            transfers.append((instances[src].slave, [instances[src].vr(out)], instances[dst].slave,
                              [instances[dst].vr(inp)]))
        readers = []
        for name in record:
            comp, var = name.split(".", 1)
            if comp not in instances:
                raise ModelExchangeError(f"recorded signal '{name}': no component '{comp}'")
            readers.append((instances[comp].slave, [instances[comp].vr(var)]))

        def transfer():
            for src, out, dst, inp in transfers:
                dst.setFloat64(inp, src.getFloat64(out))

        time_events = {}   # component name -> its next time event (fmi3UpdateDiscreteStates' nextEventTime)

        def update(name, inst):
            """Event iteration of one FMU (fmi3UpdateDiscreteStates until it needs no more), keeping the next
            time event it announces."""
            while True:
                result = inst.slave.updateDiscreteStates()
                if result[1]:
                    raise ModelExchangeError(f"{name} ended the simulation (fmi3UpdateDiscreteStates: "
                                             f"terminateSimulation) at t = {getattr(inst, 'time', start_time)!r}")
                if not result[0]:
                    break
            time_events.pop(name, None)
            if result[4]:
                time_events[name] = result[5]

        transfer()
        for name, inst in instances.items():
            update(name, inst)
            inst.slave.enterContinuousTimeMode()
        parts, offset = [], 0
        for inst in instances.values():
            if inst.nx:
                parts.append((inst, slice(offset, offset + inst.nx)))
                offset += inst.nx
        nx = offset
        z_parts, offset, z_names = [], 0, []
        for name, inst in instances.items():
            if inst.nz and event_indicators:
                z_parts.append((inst, slice(offset, offset + inst.nz)))
                offset += inst.nz
                z_names += [f"{name}.{u.variable.name}" for u in inst.md.eventIndicators]
        nz = offset

        def get_z(ptr, n):
            z = np.ctypeslib.as_array(ptr, (n,))
            try:
                transfer()
                for inst, part in z_parts:
                    inst.slave.getEventIndicators(inst.z_buffer, inst.nz)
                    z[part] = inst.z_buffer[:inst.nz]
            except Exception as exc:    # from a C callback: make the solver fail, report the cause after it
                failed("event indicators", exc)
                z[:] = np.nan

        def event(t, roots, timed=()):
            """Event mode for every FMU at a located switch or a time event, then continuous-time mode and a solver
            restart."""
            set_time(t)
            transfer()
            for name, inst in instances.items():
                inst.slave.enterEventMode()
                update(name, inst)
                inst.slave.enterContinuousTimeMode()
            solver.reset(t)
            if events is not None:
                events.extend((t, z_names[i]) for i in np.flatnonzero(roots))
                events.extend((t, f"{name}.time event") for name in timed)

        def get_x(ptr, n):
            x = np.ctypeslib.as_array(ptr, (n,))
            for inst, part in parts:
                inst.slave.getContinuousStates(inst.buffer, inst.nx)
                x[part] = inst.buffer[:inst.nx]

        def set_x(ptr, n):
            x = np.ctypeslib.as_array(ptr, (n,))
            for inst, part in parts:
                inst.buffer[:inst.nx] = x[part].tolist()
                inst.slave.setContinuousStates(inst.buffer, inst.nx)

        def get_dx(ptr, n):
            dx = np.ctypeslib.as_array(ptr, (n,))
            try:
                transfer()
                for inst, part in parts:
                    inst.slave.getContinuousStateDerivatives(inst.buffer, inst.nx)
                    dx[part] = inst.buffer[:inst.nx]
                    if not np.all(np.isfinite(dx[part])):   # the FMU logged why
                        raise ModelExchangeError(f"component '{inst.name}' gave non-finite derivatives at t = "
                                                 f"{inst.time!r}")
            except Exception as exc:    # from a C callback: make the solver fail, report the cause after it
                failed("derivatives", exc)
                dx[:] = np.nan

        def set_time(t):
            for inst in instances.values():
                inst.slave.setTime(t)
                inst.time = t

        def get_nominals(ptr, n):
            nominals = np.ctypeslib.as_array(ptr, (n,))
            for inst, part in parts:
                inst.slave.getNominalsOfContinuousStates(inst.buffer, inst.nx)
                nominals[part] = inst.buffer[:inst.nx]

        solver = CVodeSolver(nx=nx, nz=nz, get_x=get_x, set_x=set_x, get_dx=get_dx, get_z=get_z,
                             get_nominals=get_nominals, set_time=set_time, input=_NoInput(), startTime=start_time,
                             relativeTolerance=relative_tolerance, maxNumSteps=100_000)

        def read(row):
            transfer()
            row[:] = [slave.getFloat64(vr)[0] for slave, vr in readers]

        read(values[0])
        t = start_time
        for k in range(1, n_out + 1):
            t_next = start_time + k * output_interval
            # an event a few ulps from the output time (0.35 against 35 * 0.01 = 0.35000000000000003) is taken at
            # it: CVode refuses an interval that short ("tout too close to t0")
            rounding = 8.0 * EPS * max(1.0, abs(t_next))
            while True:
                t_stop = min([t_next, *(at for at in time_events.values() if at > t + rounding)])
                if t_next - t_stop <= rounding:
                    t_stop = t_next
                try:
                    state_event, roots, t_reached = solver.step(t, t_stop)
                except RuntimeError as exc:
                    raise ModelExchangeError(f"CVode failed between t = {t!r} and {t_stop!r}: "
                                             + _failures(failure or [str(exc)]) + _switch_hint(instances)) from None
                if failure:
                    raise ModelExchangeError(f"between t = {t!r} and {t_stop!r}: " + _failures(failure))
                timed = [] if state_event else [name for name, at in time_events.items()
                                                if abs(at - t_stop) <= rounding]
                if state_event and t_reached < t_next or timed:
                    event(t_reached, roots if state_event else np.zeros(nz, bool), timed)
                    t = t_reached
                    if t < t_next:
                        continue
                break
            t = t_next
            set_time(t)
            read(values[k])
            for inst in instances.values():
                inst.slave.completedIntegratorStep()
            if STOP[0]:   # a Ctrl-C: stopped here, the rows so far kept
                STOP[0] = False
                stopped = Interrupted(f"stopped at t = {t:.10g} s ({k} of {n_out} output points)")
                stopped.partial = table(k + 1)
                raise stopped
        del solver
    except ModelExchangeError as exc:
        exc.args = (exc.args[0] + _log_text(log),)
        raise
    except Exception as exc:
        raise ModelExchangeError(f"{exc}" + _log_text(log)) from exc
    finally:
        for inst in instances.values():
            inst.free()
        OPEN[0] -= 1
        interrupts.close()
        asked, STOP[0] = STOP[0], False   # this run's, not the next's
        for entry in dict.fromkeys(line for line in log if line.startswith("[warning]")):   # as cosimulate does
            if warned is not None:
                warned.append(entry)
            warnings.warn(entry, FmuWarning, stacklevel=2)
    if asked:   # pressed during the last interval or while freeing
        stopped = Interrupted(f"stopped at t = {stop_time:.10g} s, the run's end")
        stopped.partial = table(n_out + 1)
        raise stopped
    return table(n_out + 1)


#: an event indicator this close to zero where the solver failed is at its switch (:func:`_switch_hint`)
AT_SWITCH = 1e-6


def _switch_hint(instances: dict) -> str:
    """Where the solver failed with an FMU's event indicator at its switch (within ``AT_SWITCH``): the sentence
    that the equations may switch back and forth there, with the model's ``CHATTER_ADVICE`` (the MotorController's
    PI law sliding along its torque limit); '' otherwise."""
    from .master import _ujfmu_class
    nearest = None
    for name, inst in instances.items():
        if not inst.nz:
            continue
        with contextlib.suppress(Exception):
            inst.slave.getEventIndicators(inst.z_buffer, inst.nz)
            for u, z in zip(inst.md.eventIndicators, inst.z_buffer[:inst.nz]):
                if math.isfinite(z) and (nearest is None or abs(z) < abs(nearest[2])):
                    nearest = (name, inst, z, u.variable.name)
    if nearest is None or abs(nearest[2]) > AT_SWITCH:
        return ""
    name, inst, z, indicator = nearest
    advice = getattr(getattr(_ujfmu_class(inst.md), "MODEL", None), "CHATTER_ADVICE", "")
    return (f"\n{name}.{indicator} = {z:.3g} there, at its switch: the equations may switch back and forth at it "
            "faster than the solver can step, a motion along the switch that Model Exchange cannot follow (it needs "
            "the inputs' derivatives, which it does not pass). " + advice)


def _log_text(log):
    """The FMU log's distinct messages (the same words with other numbers once), the last 20 of them."""
    from .master import without_wrapper_noise
    seen, kept = set(), []
    for line in without_wrapper_noise(log):
        key = re.sub(r"\d[\d.e+-]*", "#", line)
        if key not in seen:
            seen.add(key)
            kept.append(line)
    left_out = len(log) - len(kept[-20:])
    return ("\nFMU log:\n  " + "\n  ".join(kept[-20:])
            + (f"\n  ({left_out} more lines: the same with other numbers, or earlier)" if left_out else "")) if log else ""


def _failures(failure):
    """The first failed call and how many followed (a solver retries a failing evaluation many times)."""
    return failure[0] + (f" (then {len(failure) - 1} more failed calls)" if len(failure) > 1 else "")


def simulate_scenario_me(scenario, fmu_dir, relative_tolerance: float = ME_TOLERANCE, extra: list = (),
                         warned: list | None = None) -> np.ndarray:
    """The scenario (a ``ujfmu.scenario.Scenario``) run with the Model Exchange FMUs of fmu_dir, output at its
    communication step; extra: signals recorded besides the scenario's; warned: as ``simulate_me``'s."""
    scenario.check_fmus(fmu_dir)
    return simulate_me(scenario.master_components(fmu_dir), scenario.connections, scenario.stop_time,
                       scenario.step_size, list(scenario.record) + list(extra), scenario.start_time,
                       relative_tolerance, warned=warned)
