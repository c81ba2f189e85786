import pytest

from ujfmu.build3 import build_all3


@pytest.fixture(scope="session")
def fmu3_dir(tmp_path_factory):
    """Every FMI 3.0 FMU, built once per test session from the working tree."""
    dest = tmp_path_factory.mktemp("fmus3")
    build_all3(dest)
    return dest
