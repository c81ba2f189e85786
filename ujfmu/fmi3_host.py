"""FMI 3.0 Co-Simulation FMUs in the master (``ujfmu.master``): one instance over fmpy's FMU3Slave with the
interface of ``master.FmuInstance``, so a scenario runs the FMI 3.0 FMUs (``ujfmu build --fmi 3``, then
``--fmu-dir fmus/fmi3``) through the same stepping loop, explicit or implicit coupling, as the FMI 2.0 ones.

The stepping loop calls the FMUs' C functions by their FMI 2.0 names (fmi2DoStep, fmi2GetReal, ...);
``FmuInstance3.raw`` returns the FMI 3.0 function behind each, adapted to the FMI 2.0 argument list. Each such
call goes through one Python wrapper more than an FMI 2.0 call (``ujfmu bench`` measures the cost per step).
"""

from ctypes import byref

from fmpy.fmi3 import FMU3Slave, fmi3Boolean, fmi3Float64

from .master import _STATUS, CosimulationError, FmuInstance, changes_by, typed_value


class FmuInstance3(FmuInstance):
    """One FMI 3.0 Co-Simulation FMU instance: variables by name, FMU log messages collected in ``log``."""

    INTERFACE = "coSimulation"   # the modelDescription element of the interface, and fmpy's class for it
    FMU_CLASS = FMU3Slave

    def __init__(self, component, unzip_dir, model_description, log):
        self.name = component.name
        self.parameters = component.parameters
        self.md = model_description
        self.variables = {v.name: v for v in model_description.modelVariables}
        self._log = log
        name = component.name

        def logger(env, status, category, message):
            log.append(f"[{_STATUS[status] if 0 <= status < 6 else status}] {name}: "
                       f"{message.decode(errors='replace')}")

        self.slave = self.FMU_CLASS(guid=model_description.guid, unzipDirectory=unzip_dir,
                                    modelIdentifier=getattr(model_description, self.INTERFACE).modelIdentifier,
                                    instanceName=component.name)
        self.slave.instantiate(loggingOn=True, logMessage=logger)
        self.instantiated = True

    def _adapters(self):
        f = self.slave._functions
        get, set_, step = f["fmi3GetFloat64"], f["fmi3SetFloat64"], f["fmi3DoStep"]
        flags = [fmi3Boolean() for _ in range(3)]
        last = fmi3Float64()
        refs = tuple(byref(x) for x in flags) + (byref(last),)

        def do_step(component, t, h, no_set_prior):
            return step(component, t, h, no_set_prior, *refs)

        return {
            "fmi2GetReal": lambda component, vrs, n, values: get(component, vrs, n, values, n),
            "fmi2SetReal": lambda component, vrs, n, values: set_(component, vrs, n, values, n),
            "fmi2DoStep": do_step,
            "fmi2GetFMUstate": f["fmi3GetFMUState"],
            "fmi2SetFMUstate": f["fmi3SetFMUState"],
            "fmi2FreeFMUstate": f["fmi3FreeFMUState"],
        }

    def raw(self, function):
        """The FMU's FMI 3.0 C function behind the FMI 2.0 name, with the FMI 2.0 argument list."""
        if "_raw" not in self.__dict__:
            self._raw = self._adapters()
        return self._raw[function]

    def bare(self, function):
        """The stepping loop's fast path (``FmuInstance.bare``) has no FMI 3.0 counterpart: the adapted function of
        ``raw``, which accepts the same ctypes arguments."""
        return self.raw(function)

    def set_value(self, name, value):
        var = self.variables.get(name)
        if var is None:
            self.vr(name)
        value = typed_value(self, var, value)
        if var.type == "Float64":
            self.slave.setFloat64([var.valueReference], [value])
        elif var.type in ("Int32", "Int64", "Enumeration"):
            setter = f"set{'Int64' if var.type == 'Enumeration' else var.type}"
            getattr(self.slave, setter)([var.valueReference], [value])
        elif var.type == "Boolean":
            self.slave.setBoolean([var.valueReference], [value])
        else:
            self.slave.setString([var.valueReference], [value])

    def get(self, *names):
        """Float64 values by name."""
        return self.slave.getFloat64([self.vr(n) for n in names])

    def initialize(self, parameters=None, start_time=0.0):
        if start_time != 0.0 and self.INTERFACE == "coSimulation" and changes_by(self.md, parameters or {},
                                                                                  start_time):
            raise CosimulationError(
                f"component '{self.name}' ({self.md.modelName}, FMI 3.0 Co-Simulation) cannot start at t = "
                f"{start_time:g} s: its outputs there differ from those at t = 0 (its profile or load moved), and "
                "pythonfmu3 does not pass the start time to the FMU before its first step, so the values a host "
                "reads at the start would be those of t = 0 (a "
                "joint fed from them starts out of phase for good); run it with the FMI 2.0 FMUs (without --fmi 3), "
                "from start_time = 0, or, in a torque-driven wiring, as Model Exchange (--model-exchange)")
        self.slave.enterInitializationMode(startTime=start_time)
        for name, value in (parameters or {}).items():
            self.vr(name)
            self.set_value(name, value)
        self.slave.exitInitializationMode()
