"""Non-Python host: a small FMI 2.0 host in C (tests/c_host/fmi2_host.c, fmi2 headers from fmpy) compiled with gcc
at test time runs every FMU with libpython preloaded; its outputs equal the fmpy run's."""

from pathlib import Path

import pytest
from fmu_helpers import INPUTS, open_instance

from ujfmu.build import FMUS
from ujfmu.master import extracted

H, STEPS = 1e-3, 200


@pytest.mark.parametrize("name", list(FMUS))
def test_c_host_runs_the_fmu_like_fmpy(c_host, fmu_dir, name):
    unzip, md = extracted(fmu_dir / f"{name}.fmu")
    unzip = Path(unzip)
    inputs = [v for v in md.modelVariables if v.causality == "input"]
    outputs = [v for v in md.modelVariables if v.causality == "output"]
    binary = unzip / "binaries" / "linux64" / f"{md.coSimulation.modelIdentifier}.so"
    theirs = c_host("fmi2_host", binary, md.guid, (unzip / "resources").as_uri(), md, INPUTS, H, STEPS)

    inst = open_instance(fmu_dir, name, [], "fmpy")
    try:
        inst.initialize()
        ours = []
        for k in range(STEPS):
            inst.set(**{v.name: INPUTS[v.name](k * H) for v in inputs})
            inst.slave.doStep(k * H, H)
            ours.append(inst.get(*[v.name for v in outputs]))
    finally:
        inst.free()
    assert len(theirs) == STEPS and theirs == ours
