"""The same SSP package (``ujfmu export-ssp``) stepped by three engines, for ``ujfmu bench``: our master, Ecos
(``ecospy``, C++) and libcosim (``libcosimpy``, C++).

Each run is a child process (``python -m ujfmu.engines ENGINE SSP SCENARIO``) whose CPU affinity is set before it
starts, as ``taskset -c 0`` does: a multithreaded engine's worker threads all take the GIL to call a pythonfmu
FMU, and on several cores they spend more time handing it over than stepping (README, "Using the FMUs in another
simulator"). Only the stepping loop is timed, with every recorded signal of the scenario recorded at every step
by the engine's own recorder: our master's result table, Ecos's CSV writer, libcosim's time-series observer.
Ecos and libcosim are the ``bench`` extra; ``missing`` names what is not installed. ``cosimulate_ecos`` runs an
SSP package in Ecos in this process and returns its results (the tests run the FMI 3.0 packages with it: libcosim
loads FMI 2.0 only).
"""

import argparse
import contextlib
import ctypes
import importlib.metadata
import importlib.util
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import zipfile
from pathlib import Path
from unittest import mock

import numpy as np

#: engine -> (importable modules it needs, pip distributions that bring them)
ENGINES = {"ujfmu": ((), ()), "ecos": (("ecospy",), ("ecospy", "tbb==2022.*")),
           "libcosim": (("libcosimpy",), ("libcosimpy",))}


def missing(engine: str) -> str | None:
    """Why engine cannot run here (a sentence naming what to install), or None when it can."""
    modules, dists = ENGINES[engine]
    absent = [m for m in modules if importlib.util.find_spec(m) is None]
    if engine == "ecos" and not absent and _tbb_library() is None:
        absent = ["tbb (libtbb.so.12)"]
    if absent:
        return (f"{engine} is not installed ({', '.join(absent)} missing): pip install 'ujfmu[bench]' "
                f"(or pip install {' '.join(repr(d) if '=' in d else d for d in dists)})")
    return None


def _tbb_library() -> str | None:
    """Path of the libtbb.so.12 that the tbb wheel installs (Ecos's shared library needs it loaded first)."""
    try:
        files = importlib.metadata.files("tbb") or []
    except importlib.metadata.PackageNotFoundError:
        return None
    found = [f.locate() for f in files if f.name == "libtbb.so.12"]
    return str(Path(found[0]).resolve()) if found else None


#: runs of an engine on a package before a crash (a process killed by a signal) counts as its result: Ecos 0.7.2
#: crashed (SIGSEGV in pythonfmu's fmi2SetupExperiment, called by its initialization) on the three RingCoupling
#: instances of ring_coupling_speed_study in some runs and not in others of the same package (not under its debug
#: logging, nor under valgrind); a crash of the engine is not a figure of ours
CRASH_ATTEMPTS = 3


def run(engine: str, ssp: Path, scenario_path: Path, cpus: set[int] | None = None, timeout: float = 1800.0) -> dict:
    """One run of engine on an SSP package in a child process with CPU affinity cpus (None: every core).

    Returns {'engine', 'steps', 'rows', 'setup_s', 'step_s', 'us_per_step', 'cpu_us_per_step'}: the stepping loop's
    wall seconds and microseconds per communication step, and the CPU time per step of the process (all its threads:
    on a busy machine, the process's own work without the waits for a core), rows the recorded rows (steps + 1 when
    every step was recorded)."""
    reason = missing(engine)
    if reason:
        raise RuntimeError(reason)
    command = [sys.executable, "-m", "ujfmu.engines", engine, str(ssp), str(scenario_path)]
    for _ in range(CRASH_ATTEMPTS):
        done = subprocess.run(command, capture_output=True, text=True, timeout=timeout,
                              preexec_fn=(lambda: os.sched_setaffinity(0, cpus)) if cpus else None)
        if done.returncode >= 0:   # not killed by a signal: a result, or an error it says
            break
    if done.returncode < 0:
        raise RuntimeError(f"{engine} on {Path(ssp).name} crashed ({signal.Signals(-done.returncode).name}) in each of "
                           f"{CRASH_ATTEMPTS} runs" + "".join(f": {line}" for line in done.stderr.strip().splitlines()[-1:]))
    if done.returncode != 0:
        raise RuntimeError(f"{engine} on {Path(ssp).name} failed: " + (done.stderr.strip().splitlines() or ["?"])[-1])
    return json.loads(done.stdout.strip().splitlines()[-1])


def _step_ujfmu(ssp, scenario, n_steps, work):
    from .master import Cosimulation
    with zipfile.ZipFile(ssp) as zf:
        zf.extractall(work)
    components = scenario.master_components(Path(work) / "resources")
    with Cosimulation(components, scenario.connections, scenario.step_size, scenario.record, scenario.start_time,
                      coupling="explicit") as cosim:
        ready = _clocks()
        table = cosim.run(n_steps)
        return ready, _clocks(), len(table)


@contextlib.contextmanager
def _ecos_session(ssp, scenario, csv, work, log_level="warn"):
    """An initialized Ecos simulation of the SSP package (its 'scenario' parameter set) writing every recorded
    signal to csv at every step; freed on leaving.

    Ecos unpacks the package and its FMUs into folders under TMPDIR and leaves the package's folder behind even
    after ``free`` and a normal exit (ecospy 0.7.2): here TMPDIR points into work while Ecos loads, and that folder
    is removed once the simulation is freed."""
    ctypes.CDLL(_tbb_library(), mode=ctypes.RTLD_GLOBAL)   # before ecospy loads libecosc
    from ecospy import EcosLib, EcosSimulation
    EcosLib.set_log_level(log_level)
    unpacked = Path(tempfile.mkdtemp(prefix="ecos_", dir=work))
    try:
        with mock.patch.dict(os.environ, TMPDIR=str(unpacked)):   # Ecos unpacks while it loads and initializes
            sim = EcosSimulation(ssp_path=str(Path(ssp).resolve()), step_size=scenario.step_size)
            sim.add_csv_writer(str(csv), identifiers=[name.replace(".", "::", 1) for name in scenario.record])
            initialized = sim.init(start_time=scenario.start_time, parameter_set="scenario")
        if not initialized:
            raise RuntimeError("Ecos could not initialize the system: " + EcosLib.get_last_error())
        try:
            yield sim
        finally:
            sim.terminate()
            sim.free()
    finally:
        shutil.rmtree(unpacked, ignore_errors=True)


def cosimulate_ecos(ssp: Path, scenario, work: Path) -> np.ndarray:
    """The scenario's SSP package (FMI 2.0 or 3.0 FMUs) run by Ecos in this process up to the scenario's stop
    time; a structured array with 'time' and one column per recorded signal, as ``master.cosimulate`` returns.
    Needs the ``bench`` extra (ecospy, tbb): MissingExtraError naming it otherwise."""
    reason = missing("ecos")
    if reason:
        from .extras import MissingExtraError
        raise MissingExtraError(f"ujfmu.engines.cosimulate_ecos: {reason}")
    csv = Path(work) / "ecos.csv"
    with _ecos_session(ssp, scenario, csv, work, "err") as sim:
        sim.step(int(round((scenario.stop_time - scenario.start_time) / scenario.step_size)))
    with open(csv) as f:
        header = [h.strip().split("[")[0].replace("::", ".", 1) for h in f.readline().split(",")]
        data = np.loadtxt(f, delimiter=",", ndmin=2)
    columns = {name: data[:, i] for i, name in enumerate(header)}
    return np.rec.fromarrays([columns["time"]] + [columns[n] for n in scenario.record],
                             names=["time"] + list(scenario.record))


def _step_ecos(ssp, scenario, n_steps, work):
    csv = Path(work) / "ecos.csv"
    with _ecos_session(ssp, scenario, csv, work) as sim:
        ready = _clocks()
        sim.step(n_steps)
        stopped = _clocks()
    with open(csv) as f:
        rows = sum(1 for _ in f) - 1
    return ready, stopped, rows


def _step_libcosim(ssp, scenario, n_steps, work):
    from libcosimpy.CosimEnums import CosimVariableType
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimObserver import CosimObserver
    log_output_level(CosimLogLevel.WARNING)
    execution = CosimExecution.from_ssp_file(str(Path(ssp).resolve()), int(round(scenario.step_size * 1e9)))
    observer = CosimObserver.create_time_series(buffer_size=n_steps + 1)
    execution.add_observer(observer)
    index = {name: execution.slave_index_from_instance_name(name) for name in scenario.components}
    refs = {name: {v.name.decode(): v.reference for v in execution.slave_variables(i)} for name, i in index.items()}
    series = [(index[c], refs[c][v]) for c, v in (name.split(".", 1) for name in scenario.record)]
    for slave, ref in series:
        observer.start_time_series(slave, ref, CosimVariableType.REAL)
    ready = _clocks()
    if not execution.step(n_steps):
        raise RuntimeError("libcosim refused a step")
    stopped = _clocks()
    samples = observer.time_series_real_samples(*series[0], from_step=0, sample_count=n_steps + 1) if series else None
    return ready, stopped, len(samples[0]) if samples else 0


def _clocks():
    return time.perf_counter(), time.process_time()


_STEPPERS = {"ujfmu": _step_ujfmu, "ecos": _step_ecos, "libcosim": _step_libcosim}


def main(argv=None) -> int:
    from .scenario import Scenario
    parser = argparse.ArgumentParser(description="time one engine's stepping loop on an SSP package (JSON out)")
    parser.add_argument("engine", choices=list(ENGINES))
    parser.add_argument("ssp", type=Path)
    parser.add_argument("scenario", type=Path)
    args = parser.parse_args(argv)
    scenario = Scenario(args.scenario)
    n_steps = int(round((scenario.stop_time - scenario.start_time) / scenario.step_size))
    started = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix=f"ujfmu_{args.engine}_") as work:
        ready, stopped, rows = _STEPPERS[args.engine](args.ssp, scenario, n_steps, work)
    print(json.dumps(dict(engine=args.engine, steps=n_steps, rows=rows, setup_s=ready[0] - started,
                          step_s=stopped[0] - ready[0], us_per_step=1e6 * (stopped[0] - ready[0]) / n_steps,
                          cpu_us_per_step=1e6 * (stopped[1] - ready[1]) / n_steps)))
    return 0


if __name__ == "__main__":
    from .cli import run_and_exit
    run_and_exit(main)
