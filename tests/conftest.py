"""Shared fixtures: FMUs built once per test session from the working tree, into a temporary folder; an opened FMU
instance and a driver for the FMU-level tests (tests/fmu, tests/models)."""

import atexit
import os
import shutil
import subprocess
import sys
import sysconfig
import tempfile
from pathlib import Path

import numpy as np
import pytest

from ujfmu.build import build_all
from ujfmu.build3 import build_all3
from ujfmu.extras import preload

preload()   # the extras' compiled modules before any FMU is loaded (see ujfmu.extras.preload)


#: the test files that take minutes (255, 248, 211 and 130 s of a 1146 s suite on 2 cores; the other 130 files
#: 300 s in all), started first: a two-process run whose longest files come last ends with one process idle
SLOWEST_FILES = ("test_scenarios.py", "test_report.py", "fmu/test_long_run.py", "test_ssp.py")


def pytest_collection_modifyitems(config, items):
    """Files in ``SLOWEST_FILES`` first, in that order, then the others as collected (the order within a file
    kept); ``--dist loadfile --no-loadscope-reorder`` hands files to the worker processes in this order."""
    here = Path(__file__).parent
    rank = {name: i for i, name in enumerate(SLOWEST_FILES)}

    def position(item):
        inside = item.path.is_relative_to(here)
        return rank.get(item.path.relative_to(here).as_posix(), len(rank)) if inside else len(rank)
    items.sort(key=position)


@pytest.fixture(scope="session")
def fmu_dir(tmp_path_factory):
    dest = tmp_path_factory.mktemp("fmus")
    build_all(dest)
    return dest


@pytest.fixture(scope="session")
def fmu3_dir(tmp_path_factory):
    """Every FMI 3.0 FMU (ujfmu build --fmi 3), built once per session."""
    dest = tmp_path_factory.mktemp("fmus3")
    build_all3(dest)
    return dest


@pytest.fixture
def open_fmu(fmu_dir):
    """open_fmu(name, instance_name) -> FmuInstance (freed at the end of the test)."""
    from fmpy import extract, read_model_description

    from ujfmu.master import Component, FmuInstance

    opened = []

    def _open(name, instance_name="x"):
        path = fmu_dir / f"{name}.fmu"
        tmp = tempfile.TemporaryDirectory(prefix="ujfmu_test_")
        inst = FmuInstance(Component(instance_name, path), extract(str(path), unzipdir=tmp.name),
                           read_model_description(str(path)), [])
        opened.append((inst, tmp))
        return inst

    yield _open
    for inst, tmp in opened:
        inst.free()
        tmp.cleanup()


@pytest.fixture
def python_sigint():
    """Python's own SIGINT handler for the test, as a script has it (a process started in the background or
    under nohup ignores SIGINT, and a Ctrl-C test would see nothing), the one in place restored after."""
    import signal
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, previous)


@pytest.fixture
def drive():
    """drive(inst, omega, tau_load, h, n, outputs, params) -> record array, see _drive."""
    return _drive


def _drive(inst, omega, tau_load, h, n, outputs, params=None):
    """Initialise inst with params, then n steps of h with omega_in = omega(t) and a constant tau_load; returns a
    record array of time, omega_in and the outputs read at each communication point before stepping."""
    inst.initialize(params)
    rows = []
    for k in range(n):
        t = k * h
        inst.set(omega_in=omega(t), tau_load=tau_load)
        rows.append([t, omega(t)] + inst.get(*outputs))
        inst.slave.doStep(t, h)
    return np.rec.fromarrays(np.array(rows).T, names=("time", "omega_in") + tuple(outputs))


@pytest.fixture
def against_fine():
    """against_fine(stepper, fine, p, y0, phi, w, h, duration, inputs, scale) -> largest scaled error, see
    _against_fine."""
    return _against_fine


def _against_fine(stepper, fine, p, y0, phi, w, h, duration, inputs, scale):
    """A prescribed-input stepper against an oracle: the largest error, each state's over its scale, after duration
    of steps of h by stepper(p, h, phi, w, alpha, y, tau) and by fine (the same signature), both from y0 with the
    input shaft at angle phi and speed w, under inputs(t) = (alpha, tau) held over the step from t (the input's angle
    and speed follow alpha exactly)."""
    y = ref = y0
    for k in range(int(round(duration / h))):
        alpha, tau = inputs(k * h)
        y = stepper(p, h, phi, w, alpha, y, tau)
        ref = fine(p, h, phi, w, alpha, ref, tau)
        phi, w = phi + h * (w + 0.5 * alpha * h), w + alpha * h
    return np.max(np.abs(np.array(y) - np.array(ref)) / np.asarray(scale))


@pytest.fixture(scope="session")
def libpython():
    """The shared libpython a C host preloads to run the FMUs (Linux)."""
    name = sysconfig.get_config_var("INSTSONAME") or sysconfig.get_config_var("LDLIBRARY")
    for folder in (sysconfig.get_config_var("LIBDIR"), sysconfig.get_config_var("LIBPL")):
        if folder and name and (Path(folder) / name).is_file():
            return Path(folder) / name
    pytest.fail("this Python has no shared libpython to preload")


@pytest.fixture(scope="session")
def c_host(tmp_path_factory, libpython):
    """c_host(source, binary, token, resources, md, inputs, h, steps) -> the output rows the C host
    tests/c_host/<source>.c (compiled once with gcc and fmpy's FMI headers) prints for an FMU's shared library
    run with libpython preloaded: the modelDescription md's inputs set from inputs[name](t) before each step, all
    its outputs read after it. Skips without gcc."""
    if shutil.which("gcc") is None:
        pytest.skip("gcc not available")
    import fmpy
    built = {}

    def run(source, binary, token, resources, md, inputs, h, steps):
        if source not in built:
            exe = tmp_path_factory.mktemp("c_host") / source
            subprocess.run(["gcc", "-O1", "-Wall", "-Wextra", "-Werror", "-o", str(exe),
                            str(Path(__file__).parent / "c_host" / f"{source}.c"),
                            f"-I{Path(fmpy.__file__).parent / 'c-code'}", "-ldl"], check=True, capture_output=True)
            built[source] = exe
        ins = [v for v in md.modelVariables if v.causality == "input"]
        outs = [v for v in md.modelVariables if v.causality == "output"]
        plan = [f"{len(ins)} " + " ".join(str(v.valueReference) for v in ins),
                f"{len(outs)} " + " ".join(str(v.valueReference) for v in outs)]
        plan += [" ".join(repr(inputs[v.name](k * h)) for v in ins) for k in range(steps)]
        done = subprocess.run([str(built[source]), str(binary), token, resources, repr(h), str(steps)],
                              input="\n".join(plan) + "\n", capture_output=True, text=True, timeout=120,
                              env={**os.environ, "LD_PRELOAD": str(libpython)})
        assert done.returncode == 0, done.stderr[-2000:]
        return [[float(x) for x in line.split()] for line in done.stdout.splitlines()]

    return run


_EXIT = []


def pytest_sessionfinish(session, exitstatus):
    _EXIT.append(int(exitstatus))


@pytest.hookimpl(trylast=True)
def pytest_unconfigure(config):
    """End the process with pytest's exit status once everything is reported, skipping interpreter finalization.

    pythonfmu 0.7.0 binaries stay loaded (they cannot be unloaded safely, docs/cosimulation.md), and tearing the
    interpreter down under them has now and then aborted the process after the last test ("corrupted
    double-linked list", SIGSEGV): a result already reported must not turn into a failing exit status. Python's
    exit handlers still run (they remove the extracted FMUs' folders), as in ``ujfmu.cli.run_and_exit``."""
    if _EXIT and not hasattr(config, "workerinput"):   # the main pytest process, not a pytest-xdist worker
        atexit._run_exitfuncs()
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(_EXIT[-1])


#: a host's wrong calls on one initialized Motor, then steps and a free, in a process of its own (a crash must not
#: take the tests with it); prints what the FMU logged. ujfmu's instance classes keep the log; {kind} is one of them
WRONG_CALLS = """
import sys
from pathlib import Path
from ujfmu.master import Component, FmuInstance, extracted
from ujfmu.fmi3_host import FmuInstance3
path = Path(sys.argv[1])
log = []
inst = {kind}(Component("m", path), *extracted(path), log)
inst.initialize()
slave, vr = inst.slave, {{v.name: v.valueReference for v in inst.md.modelVariables}}
for call in ({calls}):
    try:
        call()
        print("ACCEPTED")
    except Exception:
        pass
for k in range(3):
    slave.doStep(k * 1e-3, 1e-3)
inst.free()
print("\\n".join(log))
"""


@pytest.fixture
def run_wrong_calls():
    """run(kind, path, calls, said): WRONG_CALLS on the FMU at path, opened as ``kind`` (FmuInstance,
    FmuInstance3), checked: the process ends cleanly (no crash), no call was accepted, and the FMU logged each
    text of ``said``."""
    def run(kind: str, path, calls: str, said: tuple):
        out = subprocess.run([sys.executable, "-c", WRONG_CALLS.format(kind=kind, calls=calls), str(path)],
                             capture_output=True, text=True, timeout=120)
        assert out.returncode == 0, out.stderr[-2000:]
        assert "ACCEPTED" not in out.stdout
        for text in said:
            assert text in out.stdout, out.stdout
    return run
