import tempfile
from contextlib import contextmanager

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
