"""Shared fixtures: FMUs built once per test session from the working tree, into a temporary folder."""

import os
import sys

import pytest

from ujfmu.build import build_all
from ujfmu.build3 import build_all3
from ujfmu.extras import preload

preload()   # the extras' compiled modules before any FMU is loaded (see ujfmu.extras.preload)


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


_EXIT = []


def pytest_sessionfinish(session, exitstatus):
    _EXIT.append(int(exitstatus))


@pytest.hookimpl(trylast=True)
def pytest_unconfigure(config):
    """End the process with pytest's exit status once everything is reported, skipping interpreter finalization.

    pythonfmu 0.7.0 binaries stay loaded (they cannot be unloaded safely, docs/cosimulation.md), and tearing the
    interpreter down under them has now and then aborted the process after the last test ("corrupted
    double-linked list", SIGSEGV): a result already reported must not turn into a failing exit status."""
    if _EXIT and not hasattr(config, "workerinput"):   # the main pytest process, not a pytest-xdist worker
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(_EXIT[-1])
