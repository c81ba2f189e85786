"""Shared fixtures: FMUs built once per test session from the working tree, into a temporary folder."""

import pytest

from ujfmu.build import build_all


@pytest.fixture(scope="session")
def fmu_dir(tmp_path_factory):
    dest = tmp_path_factory.mktemp("fmus")
    build_all(dest)
    return dest
