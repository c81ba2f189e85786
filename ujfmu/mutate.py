"""Mutation run (`ujfmu mutate`): how many plausible bugs does the test suite catch?

The mutants are a curated list, ``mutants.toml`` at the top of the repository: each replaces one exact piece of
code (``find``, which must occur exactly once in ``file``) by a plausible bug (``replace``): a flipped sign, swapped
arguments, an off-by-one, a changed comparison, a dropped term. Each names the tests that cover the mutated line
(``tests``, pytest files or node ids), cheapest first. A mutant of a
reference generator may name scenarios whose reference CSVs it regenerates first (``regenerate``), since a
changed generator is committed together with its regenerated CSV; the generator's self-checks may then refuse.
A mutant that cannot change any result is listed with ``equivalent = "why"`` and not run.

Each mutant runs in a scratch copy of the repository's tracked files (the working tree is never touched): the
file is mutated, the FMUs are built from the copy by the tests' own fixture, and pytest runs the named tests with
``-x`` (fail fast) at low CPU priority. A mutant is killed when a test fails (or the regeneration is refused), it
survives when they all pass. Score = killed / (killed + survived). Not part of CI: about 10-60 s per mutant.
"""

from __future__ import annotations

import fnmatch
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

REPOSITORY = Path(__file__).resolve().parents[1]
DEFAULT_LIST = REPOSITORY / "mutants.toml"
#: the areas the list must cover (a path prefix each)
AREAS = {"physics": ("ujfmu/models/*/model.py", "ujfmu/models/protocol.py", "ujfmu/fmu/rk4.py"),
         "FMU layer": ("ujfmu/models/*/fmu.py", "ujfmu/fmu/", "ujfmu/build.py"), "master": "ujfmu/master.py",
         "scenario comparison": ("ujfmu/scenario.py", "ujfmu/scenario_run.py", "ujfmu/stepsize.py", "ujfmu/ssp.py",
                                 "ujfmu/report.py"),
         "references": ("ujfmu/models/*/reference.py", "ujfmu/references/"),
         "FMI 3.0 layer": ("ujfmu/fmu3/", "ujfmu/build3.py", "ujfmu/model_exchange.py", "ujfmu/fmi3_host.py"),
         "sweeps and command line": ("ujfmu/sweep.py", "ujfmu/steady.py", "ujfmu/analysis.py", "ujfmu/cli.py",
                                     "ujfmu/plotting.py")}


@dataclass
class Mutant:
    id: str
    file: str
    find: str
    replace: str
    tests: list = field(default_factory=list)
    regenerate: list = field(default_factory=list)
    equivalent: str = ""
    why: str = ""


@dataclass
class Outcome:
    mutant: Mutant
    status: str            # killed, survived, equivalent, error, timeout
    seconds: float = 0.0
    detail: str = ""


def load_mutants(path: Path = DEFAULT_LIST) -> list[Mutant]:
    """The mutants of a list file; ValueError naming the entry for a missing or unknown field."""
    data = tomllib.loads(Path(path).read_text())
    mutants, seen = [], set()
    for i, entry in enumerate(data.get("mutant", [])):
        unknown = set(entry) - set(Mutant.__dataclass_fields__)
        missing = {"id", "file", "find", "replace"} - set(entry)
        if unknown or missing or entry.get("id") in seen:
            raise ValueError(f"{path}: mutant[{i}] ({entry.get('id')}): unknown {sorted(unknown)}, missing "
                             f"{sorted(missing)}, or a duplicate id")
        if not entry.get("equivalent") and not entry.get("tests"):
            raise ValueError(f"{path}: mutant {entry['id']}: needs the tests that cover it, or equivalent = why")
        seen.add(entry["id"])
        mutants.append(Mutant(**entry))
    return mutants


def area(mutant: Mutant) -> str:
    """Which of AREAS the mutated file belongs to ('' if none)."""
    for name, patterns in AREAS.items():
        if any(fnmatch.fnmatch(mutant.file, p if p.endswith(".py") else p + "*")
               for p in ((patterns,) if isinstance(patterns, str) else patterns)):
            return name
    return ""


def scratch_copy(dest: Path, repository: Path = REPOSITORY) -> Path:
    """Copy the repository's tracked files (as in the working tree) into dest/src; returns that folder."""
    files = subprocess.run(["git", "ls-files", "-z"], cwd=repository, check=True, capture_output=True,
                           text=True).stdout.split("\0")
    src = Path(dest) / "src"
    for name in filter(None, files):
        target = src / name
        target.parent.mkdir(parents=True, exist_ok=True)
        if (repository / name).is_file():
            shutil.copy2(repository / name, target)
    return src


def _run(args, src, timeout, niceness):
    """args run in src with its own temporary directory, removed afterwards even if a timeout killed the run."""
    with tempfile.TemporaryDirectory(prefix="ujfmu_mutant_", ignore_cleanup_errors=True) as tmp:
        env = dict(os.environ, PYTHONPATH=str(src), PYTHONDONTWRITEBYTECODE="1", TMPDIR=tmp)
        return subprocess.run(args, cwd=src, env=env, capture_output=True, text=True, timeout=timeout,
                              preexec_fn=(lambda: os.nice(niceness)) if niceness else None)


def run_mutant(mutant: Mutant, src: Path, timeout: float = 900.0, niceness: int = 19) -> Outcome:
    """Apply the mutant in the scratch copy src, regenerate what it names, run its tests; always restore."""
    if mutant.equivalent:
        return Outcome(mutant, "equivalent", detail=mutant.equivalent)
    path = src / mutant.file
    original = path.read_text()
    if original.count(mutant.find) != 1:
        return Outcome(mutant, "error", detail=f"'find' occurs {original.count(mutant.find)} times in {mutant.file}")
    saved = {p: p.read_bytes() for p in (src / "scenarios" / "references").glob("*.csv")} if mutant.regenerate else {}
    started = time.perf_counter()
    try:
        path.write_text(original.replace(mutant.find, mutant.replace))
        if mutant.regenerate:
            done = _run([sys.executable, "-m", "ujfmu", "references"]
                        + [f"scenarios/{name}.toml" for name in mutant.regenerate], src, timeout, niceness)
            if done.returncode != 0:
                killed = "self-check failed" in done.stderr + done.stdout
                return Outcome(mutant, "killed" if killed else "error", time.perf_counter() - started,
                               _tail(done.stderr + done.stdout))
        args = [sys.executable, "-m", "pytest", "-x", "-q", "-p", "no:cacheprovider", "-n", "0", *mutant.tests]
        done = _run(args, src, timeout, niceness)
        status = {0: "survived", 1: "killed"}.get(done.returncode, "error")
        return Outcome(mutant, status, time.perf_counter() - started, _tail(done.stdout + done.stderr))
    except subprocess.TimeoutExpired:
        return Outcome(mutant, "timeout", time.perf_counter() - started, f"no verdict within {timeout:g} s")
    finally:
        path.write_text(original)
        for p, content in saved.items():
            p.write_bytes(content)


def _tail(text, lines=6):
    kept = [line for line in text.strip().splitlines() if line.strip()]
    for line in kept:
        if line.startswith(("FAILED", "ERROR")):
            return line[:300]
    for line in reversed(kept):
        if "Error: " in line:
            return line.strip()[:300]
    return "\n".join(kept[-lines:])[-600:]


def score(statuses: list[str]) -> tuple[int, int, float]:
    """(killed, killed + survived, fraction) of outcome statuses; a timeout counts as killed (the tests did not
    pass), equivalent mutants and errors are not judged."""
    killed = sum(s in ("killed", "timeout") for s in statuses)
    judged = killed + statuses.count("survived")
    return killed, judged, killed / judged if judged else float("nan")


def mutate(mutants: list[Mutant], workdir: Path | None = None, timeout: float = 900.0, niceness: int = 19,
           progress=None, journal: Path | None = None) -> list[Outcome]:
    """Run each mutant in one scratch copy; progress(outcome) after each; each outcome appended to journal."""
    outcomes = []
    with tempfile.TemporaryDirectory(prefix="ujfmu_mutate_", dir=workdir) as tmp:
        src = scratch_copy(Path(tmp))
        for mutant in mutants:
            outcome = run_mutant(mutant, src, timeout, niceness)
            outcomes.append(outcome)
            if journal is not None:
                journal.parent.mkdir(parents=True, exist_ok=True)
                with open(journal, "a") as f:
                    f.write(json.dumps({"id": mutant.id, "area": area(mutant), "status": outcome.status,
                                        "seconds": round(outcome.seconds, 1), "detail": outcome.detail}) + "\n")
            if progress is not None:
                progress(outcome)
    return outcomes
