"""The README's Python recipes run as written: the sweep as a plain script without a __main__ guard (its dask
workers must not re-run the script), in a project folder of its own; the plain fmpy script against Hooke's joint."""

import math
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).parents[1]


def readme_python_blocks():
    return re.findall(r"```python\n(.*?)```", (REPO / "README.md").read_text(), re.S)


#: dask's log of a connection closed while the cluster shuts down on a loaded machine: noise, not a failure
CLOSED_CONNECTION = ("CommClosedError", "StreamClosedError")


#: how Python joins the tracebacks of one chain of exceptions
CHAINED = ("During handling of the above exception, another exception occurred:",
           "The above exception was the direct cause of the following exception:")


def unexpected_tracebacks(stderr: str) -> list:
    """The tracebacks in stderr but those of a closed dask connection (a chain of exceptions is one traceback: a
    timeout while connecting that ends in a closed connection is that)."""
    chains, chain = [], ""
    for block in stderr.split("Traceback (most recent call last):")[1:]:
        chain += block
        if not any(marker in block for marker in CHAINED):
            chains.append(chain)
            chain = ""
    if chain:
        chains.append(chain)
    return [c for c in chains if not any(name in c for name in CLOSED_CONNECTION)]


def test_unexpected_tracebacks_keep_all_but_closed_connections():
    closed = "Traceback (most recent call last):\n  File x\ndistributed.comm.core.CommClosedError: in <TCP>\n"
    spawn = "Traceback (most recent call last):\n  File y\nRuntimeError: An attempt has been made to start\n"
    assert unexpected_tracebacks(closed + closed) == [] and len(unexpected_tracebacks(closed + spawn)) == 1
    timeout = ("Traceback (most recent call last):\n  File z\nTimeoutError\n\n"
               "During handling of the above exception, another exception occurred:\n\n")
    assert unexpected_tracebacks(timeout + closed) == [] and len(unexpected_tracebacks(timeout + spawn)) == 1


def test_the_sweep_recipe_runs_as_written_in_an_unguarded_script(fmu_dir, tmp_path):
    recipe = next(block for block in readme_python_blocks() if "Sweep(" in block)
    assert "__main__" not in recipe
    (tmp_path / "scenarios").symlink_to(REPO / "scenarios")
    (tmp_path / "fmus").symlink_to(fmu_dir)
    script = tmp_path / "recipe.py"
    # as written, but for two local workers at most (the machine is shared) and a closing line to check it ran
    script.write_text(recipe.replace("sweep.run()", "sweep.run(workers=2)") + "\nprint('RECIPE DONE')\n")
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    done = subprocess.run([sys.executable, str(script)], cwd=tmp_path, capture_output=True, text=True, env=env,
                          timeout=300)
    assert done.returncode == 0, done.stderr[-3000:]
    lines = done.stdout.splitlines()
    assert lines[-1] == "RECIPE DONE" and not unexpected_tracebacks(done.stderr) and "Nanny" not in done.stderr
    rows = [line.split() for line in lines[:-1]]
    # 600, 650, 700 rpm in SI, each point ok with a positive twist
    assert [round(float(r[0]) * 30 / 3.141592653589793) for r in rows] == [600, 650, 700]
    assert all(r[1] == "ok" and float(r[2]) > 0 for r in rows)
    results = tmp_path / "results"
    # its own name: the command-line recipe's default grid keeps double_cardan_omar_torsional_sweep.*
    for name in (".csv", ".png", "_orders.png", ".jsonl"):
        assert (results / f"omar_600_700rpm{name}").is_file()
    assert not list(results.glob("double_cardan_omar_torsional_sweep*"))


def run_fmpy_recipe(tmp_path, fmu_dir, recipe):
    (tmp_path / "fmus").symlink_to(fmu_dir)
    script = tmp_path / "plain_fmpy.py"
    script.write_text(recipe)
    return subprocess.run([sys.executable, str(script)], cwd=tmp_path, capture_output=True, text=True, timeout=120)


def test_the_plain_fmpy_recipe_gives_the_joints_velocity_ratio_bounds(fmu_dir, tmp_path):
    """An ideal 30 deg joint at constant input speed: omega_out swings between omega cos(30 deg) and
    omega / cos(30 deg) (Hooke's joint), which the recipe prints."""
    recipe = next(block for block in readme_python_blocks() if "simulate_fmu" in block)
    done = run_fmpy_recipe(tmp_path, fmu_dir, recipe)
    assert done.returncode == 0, done.stderr[-3000:]
    low, high = map(float, done.stdout.split()[-2:])
    c = math.cos(0.5236)
    assert low == pytest.approx(62.83 * c, rel=1e-4) and high == pytest.approx(62.83 / c, rel=1e-4)


def test_the_plain_fmpy_recipe_shows_the_cause_of_a_degree_slip(fmu_dir, tmp_path):
    recipe = next(block for block in readme_python_blocks() if "simulate_fmu" in block)
    done = run_fmpy_recipe(tmp_path, fmu_dir, recipe.replace('"bend_angle": 0.5236', '"bend_angle": 30.0'))
    assert done.returncode != 0 and "status 4" in done.stderr
    assert "bend_angle = 30.0 is outside its allowed range" in done.stdout + done.stderr
    assert "(30 deg = 0.5236 rad?)" in done.stdout + done.stderr
