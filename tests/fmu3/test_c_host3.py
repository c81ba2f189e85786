"""Non-Python host, FMI 3.0: a small C host (tests/c_host/fmi3_host.c, fmi3 headers from fmpy) compiled with gcc
at test time runs every FMI 3.0 Co-Simulation FMU with libpython preloaded; its outputs equal the fmpy run's."""

import os
import shutil
import subprocess
import sysconfig
from pathlib import Path

import fmpy
import pytest

from ujfmu.build import FMUS
from ujfmu.fmi3_host import FmuInstance3
from ujfmu.master import Component, extracted

HOST_SOURCE = Path(__file__).parents[1] / "c_host" / "fmi3_host.c"
H, STEPS = 1e-3, 200
INPUTS = {
    "omega_in": lambda t: 40.0 + 30.0 * t,
    "tau_load": lambda t: 0.2 + 0.1 * t,
    "omega": lambda t: 40.0 + 30.0 * t,
    "tau_in": lambda t: 0.5 + 0.2 * t,
}


def libpython():
    name = sysconfig.get_config_var("INSTSONAME") or sysconfig.get_config_var("LDLIBRARY")
    for folder in (sysconfig.get_config_var("LIBDIR"), sysconfig.get_config_var("LIBPL")):
        if folder and name and (Path(folder) / name).is_file():
            return Path(folder) / name
    return None


@pytest.fixture(scope="module")
def host3(tmp_path_factory):
    if shutil.which("gcc") is None:
        pytest.skip("gcc not available")
    exe = tmp_path_factory.mktemp("c_host3") / "fmi3_host"
    headers = Path(fmpy.__file__).parent / "c-code"
    subprocess.run(["gcc", "-O1", "-Wall", "-Wextra", "-Werror", "-o", str(exe), str(HOST_SOURCE),
                    f"-I{headers}", "-ldl"], check=True, capture_output=True, text=True)
    return exe


@pytest.mark.parametrize("name", list(FMUS))
def test_c_host_runs_the_fmi3_fmu_like_fmpy(host3, fmu3_dir, name):
    lib = libpython()
    assert lib is not None, "this Python has no shared libpython to preload"
    path = fmu3_dir / f"{name}.fmu"
    unzip, md = extracted(path)
    unzip = Path(unzip)
    inputs = [v for v in md.modelVariables if v.causality == "input"]
    outputs = [v for v in md.modelVariables if v.causality == "output"]
    plan = [f"{len(inputs)} " + " ".join(str(v.valueReference) for v in inputs),
            f"{len(outputs)} " + " ".join(str(v.valueReference) for v in outputs)]
    plan += [" ".join(repr(INPUTS[v.name](k * H)) for v in inputs) for k in range(STEPS)]
    binary = unzip / "binaries" / "x86_64-linux" / f"{md.coSimulation.modelIdentifier}.so"
    env = {**os.environ, "LD_PRELOAD": str(lib)}
    run = subprocess.run([str(host3), str(binary), md.guid, str(unzip / "resources") + os.sep, repr(H), str(STEPS)],
                         input="\n".join(plan) + "\n", capture_output=True, text=True, env=env, timeout=120)
    assert run.returncode == 0, run.stderr[-2000:]
    theirs = [[float(x) for x in line.split()] for line in run.stdout.splitlines()]

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
