"""A regular (non-editable) install used from a project folder of its own, as a user or a cluster worker has it:
fmus/, scenarios/ and results/ are that folder's; a plain install (no extras) builds, runs and checks; a missing
extra is named.

The venv sees this environment's packages through a path file (no downloads), but an import blocker hides the
extras' packages from it (scipy, sympy, dask, matplotlib): what runs is what a plain ``pip install ujfmu`` gets.
"""

import os
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest

REPO = Path(__file__).parents[1]
EXTRAS = ("scipy", "sympy", "dask", "distributed", "matplotlib")
BLOCKER = f'''
import sys

class _Extras:
    """Hides the packages of ujfmu's extras, as on a plain install."""
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in {EXTRAS!r}:
            raise ModuleNotFoundError(f"No module named {{name!r}}", name=name)
        return None

sys.meta_path.insert(0, _Extras())
'''


@pytest.fixture(scope="module")
def plain_install(tmp_path_factory):
    """(venv, project folder): ujfmu installed non-editable into a fresh venv in a temporary folder."""
    root = tmp_path_factory.mktemp("plain_install")
    source = root / "source"   # a copy, so that building the wheel leaves nothing in the clone
    shutil.copytree(REPO, source, ignore=shutil.ignore_patterns(".venv", ".git", "fmus", "results", "build",
                                                                 "*.egg-info", "__pycache__", "tests", "docs"))
    venv = root / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True)
    python = venv / "bin" / "python"
    site = Path(subprocess.run([str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                               check=True, capture_output=True, text=True).stdout.strip())
    # this environment's packages (fmpy, numpy, ...) after the venv's own; extras hidden
    (site / "zz_host_packages.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    (site / "ujfmu_test_block_extras.py").write_text(BLOCKER)
    (site / "aa_block_extras.pth").write_text("import ujfmu_test_block_extras\n")
    subprocess.run([sys.executable, "-m", "pip", "--python", str(python), "install", "-q", "--no-deps",
                    "--no-build-isolation", "--no-index", str(source)], check=True, capture_output=True)
    project = root / "project"
    (project / "scenarios" / "references").mkdir(parents=True)
    for name in ("cardan_constant_speed.toml", "references/cardan_constant_speed.csv"):
        shutil.copy(REPO / "scenarios" / name, project / "scenarios" / name)
    return venv, project


def ujfmu(venv, project, *args):
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    return subprocess.run([str(venv / "bin" / "ujfmu"), *args], cwd=project, capture_output=True, text=True,
                          env=env)


def test_installed_copy_builds_and_checks_the_project_folder(plain_install):
    venv, project = plain_install
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    where = subprocess.run([str(venv / "bin" / "python"), "-c", "import ujfmu, scipy"], cwd=project,
                           capture_output=True, text=True, env=env)
    assert "No module named 'scipy'" in where.stderr   # the extras are hidden
    where = subprocess.run([str(venv / "bin" / "python"), "-c", "import ujfmu; print(ujfmu.__file__)"],
                           cwd=project, capture_output=True, text=True, env=env)
    assert Path(where.stdout.strip()).is_relative_to(venv), where   # the installed copy, not the clone
    built = ujfmu(venv, project, "build", "Motor", "CardanJoint", "Load")
    assert built.returncode == 0, built.stderr
    assert sorted(p.name for p in (project / "fmus").iterdir()) == ["CardanJoint.fmu", "Load.fmu", "Motor.fmu"]
    checked = ujfmu(venv, project, "check")
    assert checked.returncode == 0, checked.stdout + checked.stderr
    assert "PASS cardan_constant_speed" in checked.stdout and "1 passed, 0 failed, 0 not checked" in checked.stdout
    assert (project / "results" / "cardan_constant_speed.csv").is_file()
    assert "pip install 'ujfmu[plot]'" in checked.stderr   # no matplotlib: said once, the check still passes
    # a missing extra is named, with the command that installs it; a sweep without dask runs in this process
    swept = ujfmu(venv, project, "sweep", "scenarios/cardan_constant_speed.toml", "--param",
                  "load.T0=0.1,0.2", "--settle", "0.1", "--running-speed", "motor.omega", "--workers", "2")
    assert swept.returncode == 2 and "pip install 'ujfmu[sweep]'" in swept.stderr
    assert "ujfmu sweep (--workers 0 runs in this process without it) needs distributed" in swept.stderr
    in_process = ujfmu(venv, project, "sweep", "scenarios/cardan_constant_speed.toml", "--param", "load.T0=0.1,0.2",
                       "--settle", "0.1", "--running-speed", "motor.omega")
    assert in_process.returncode == 0 and "pip install 'ujfmu[plot]'" in in_process.stderr, in_process.stderr
    assert "the points run one after another in this process (for worker processes" in in_process.stderr
    assert (project / "results" / "cardan_constant_speed_sweep.csv").is_file()
    regenerated = ujfmu(venv, project, "references")
    assert regenerated.returncode == 2 and "pip install 'ujfmu[references]'" in regenerated.stderr


def test_an_empty_project_folder_is_an_error_naming_it(plain_install, tmp_path):
    venv, _ = plain_install
    checked = ujfmu(venv, tmp_path, "check")
    assert checked.returncode == 2 and f"no scenario files (*.toml) in {tmp_path / 'scenarios'}" in checked.stderr
