import tempfile

import numpy as np
import pytest
from fmpy import extract, read_model_description

from ujfmu.master import Component, FmuInstance


@pytest.fixture
def open_fmu(fmu_dir):
    """open_fmu(name, instance_name) -> FmuInstance (freed at the end of the test)."""
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
