"""Non-Python host, FMI 3.0: a small C host (tests/c_host/fmi3_host.c, fmi3 headers from fmpy) compiled with gcc
at test time runs every FMI 3.0 Co-Simulation FMU with libpython preloaded; its outputs equal the fmpy run's."""

import os
from pathlib import Path

import pytest

from ujfmu.build import FMUS
from ujfmu.fmi3_host import FmuInstance3
from ujfmu.master import Component, extracted

H, STEPS = 1e-3, 200
INPUTS = {
    "omega_in": lambda t: 40.0 + 30.0 * t,
    "tau_load": lambda t: 0.2 + 0.1 * t,
    "omega": lambda t: 40.0 + 30.0 * t,
    "tau_in": lambda t: 0.5 + 0.2 * t,
    "phi": lambda t: 40.0 * t + 15.0 * t * t,   # the Load's shaft angle (its periodic torque's)
}


@pytest.mark.parametrize("name", list(FMUS))
def test_c_host_runs_the_fmi3_fmu_like_fmpy(c_host, fmu3_dir, name):
    path = fmu3_dir / f"{name}.fmu"
    unzip, md = extracted(path)
    unzip = Path(unzip)
    inputs = [v for v in md.modelVariables if v.causality == "input"]
    outputs = [v for v in md.modelVariables if v.causality == "output"]
    binary = unzip / "binaries" / "x86_64-linux" / f"{md.coSimulation.modelIdentifier}.so"
    theirs = c_host("fmi3_host", binary, md.guid, str(unzip / "resources") + os.sep, md, INPUTS, H, STEPS)

    inst = FmuInstance3(Component("fmpy", path), str(unzip), md, [])
    try:
        inst.initialize()
        ours = []
        for k in range(STEPS):
            inst.set(**{v.name: INPUTS[v.name](k * H) for v in inputs})
            assert inst.raw("fmi2DoStep")(inst.slave.component, k * H, H, 1) == 0
            ours.append(inst.get(*[v.name for v in outputs]))
    finally:
        inst.free()
    assert len(theirs) == STEPS and theirs == ours
