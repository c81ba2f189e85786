"""Helpers shared by the FMU-level tests (imported by name: pytest puts tests/fmu on sys.path)."""

import math

from ujfmu.master import Component, FmuInstance, extracted

#: inputs as functions of time: a ramping, wavering speed and a varying load exercise the input history
#: (backward-difference acceleration) that the FMUs' state must carry
INPUTS = {
    "omega_in": lambda t: 40.0 + 30.0 * t + 3.0 * math.sin(17.0 * t),
    "tau_load": lambda t: 0.2 + 0.1 * math.cos(11.0 * t),
    "omega": lambda t: 40.0 + 30.0 * t,
    "tau_in": lambda t: 0.5 + 0.2 * math.sin(13.0 * t),   # driving torque of the torque-driven variants
    "phi": lambda t: 40.0 * t + 15.0 * t * t,   # the Load's shaft angle (its periodic torque's)
}


def open_instance(fmu_dir, name, log, instance_name="probe"):
    """An FmuInstance of fmus/<name>.fmu (extracted once per process); the caller frees it."""
    path = fmu_dir / f"{name}.fmu"
    unzip_dir, md = extracted(path)
    return FmuInstance(Component(instance_name, path), unzip_dir, md, log)


def inputs_of(inst):
    return [v.name for v in inst.md.modelVariables if v.causality == "input"]


def outputs_of(inst):
    return [v.name for v in inst.md.modelVariables if v.causality == "output"]
