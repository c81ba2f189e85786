"""Scenario files (TOML): components and their parameters, connections, experiment, records, reference.

    title = "..."           optional (default: the file name); description = "..." optional free text
    [experiment]            stop_time, step_size [s]; start_time optional (0); stop_time - start_time a whole
                            number (>= 1) of steps; coupling = "implicit" (default, iterated to convergence
                            every step) or "explicit" (docs/cosimulation.md); output_interval = n records
                            every n-th communication step and the last (default 1: every step)
    [components.NAME]       fmu = "CardanJoint" (fmus/CardanJoint.fmu), parameters = { name = value, ... } (SI
                            units: rad, rad/s, ...), inputs = { name = value } (inputs no connection feeds, held
                            constant: every input must be connected or set here)
    [[connections]]         from = "comp.output", to = "comp.input"
    [output]                record = ["comp.var", ...]; plot = [...] (default: the compared signals);
                            orbits = [["comp.X", "comp.Y"], ...], spectra = ["comp.var", ...] (recorded signals),
                            running_speed = "comp.omega" (spectra in running-speed orders), steady_from [s]
                            (orbits and spectra from that time on)
    [sweep]                 optional defaults of `ujfmu sweep`: params = ["comp.par=START:STOP:STEP[rpm|deg]", ...],
                            outputs = [...], running_speed, settle_time [s], revolutions, orders = [1, 2, 4],
                            steady_tol = 1e-3 (0: no check), max_settle_time [s] (see ujfmu.steady)
    [reference]             optional: file = "references/x.csv" (relative to the scenario; `ujfmu references`
                            writes it only inside the scenario's folder), generator = "cardan_joint",
                            not_compared = { "comp.var" = "why this recorded signal is not compared", ... };
                            without it (or without tolerances) the scenario is run, NOT CHECKED
    [reference.tolerance]   "comp.var" = { rel_range = 0.01, abs = 0.0 }
      pass when max |result - reference| <= rel_range * (max - min of the reference) + abs
    [reference.extrapolated] "comp.var" = { rel_range = 0.001 }: the same test on the step-halving (Richardson)
                            extrapolation 2 y(h/2) - y(h) of runs at step_size and step_size/2, which removes the
                            first-order coupling error; for scenarios whose [reference.tolerance] must allow for it
    [reference.orders]      "comp.var" = { rel = 0.05 }: its running-speed orders over the steady window within
                            rel of the reference's (needs output.running_speed and steady_from)
    With a reference file, every recorded signal is compared or listed in not_compared with its reason; a reference
    whose provenance names another setup (``Scenario.setup_digest``) than the scenario's is refused.
"""

import contextlib
import copy
import dataclasses
import difflib
import hashlib
import json
import math
import numbers
import os
import re
import tomllib
import types
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import IO

import numpy as np

from .build import DEFAULT_FMU_DIR, FMUS, PACKAGE_DIR, REPO_DIR, build_hint, fmu_class, source_hash
from .fmu.base import HUMAN_UNITS, model_stem
from .master import COUPLINGS, DEFAULT_COUPLING, MAX_STEPS, Component, Connection


TOP_LEVEL_KEYS = {"title", "description", "experiment", "components", "connections", "output", "reference",
                  "sweep"}
EXPERIMENT_KEYS = {"start_time", "stop_time", "step_size", "coupling", "output_interval"}
#: fields of the optional [sweep] table (defaults of `ujfmu sweep`, see ujfmu.sweep)
SWEEP_KEYS = {"params", "outputs", "running_speed", "settle_time", "revolutions", "orders", "steady_tol",
              "max_settle_time"}
OUTPUT_KEYS = {"record", "plot", "orbits", "spectra", "running_speed", "steady_from"}
REFERENCE_KEYS = {"file", "generator", "tolerance", "extrapolated", "not_compared", "orders"}
TOLERANCE_KEYS = {"rel_range", "abs"}
#: a rel_range from this on is refused: a flat line through the middle of the reference's range is within half of
#: it everywhere
MAX_REL_RANGE = 0.5


#: what a name set under the wrong table is, and where it goes
_OTHER_CAUSALITY = {"input": "an input: connect it, or set it under inputs",
                    "parameter": "a parameter: set it under parameters",
                    "output": "an output, which the FMU computes"}
#: where a parameter a user looks for on one FMU lives in this wiring: (FMU, name) -> where
_MISPLACED = {("MotorController", "J_rotor"): "the motor's rotor inertia is the driven machine's: set J_drive of the "
              "torque-driven FMU it drives; the MotorController is the speed loop alone"}


#: a name that names the files a run or sweep writes: a plain file name any system stores
_FILE_NAME = re.compile(r"[\w+=,@-][\w.+=,@-]*")


def file_name_problem(name) -> str:
    """Why name cannot name the files a run or sweep writes ('' where it can): a plain file name of letters,
    digits and _ . + = , @ -, not starting or ending with '.' (no path, nothing a system refuses in a name)."""
    if isinstance(name, str) and _FILE_NAME.fullmatch(name) and not name.endswith("."):
        return ""
    return (f"{name!r} must be a plain file name of letters, digits and _ . + = , @ - (not starting or ending with "
            "'.'): it names the files written")


def plain_number(value):
    """A numpy scalar or 0-d array as the Python number it holds (np.int64 an int, np.float32 a float, np.bool_ a
    bool: what a numpy or scipy loop hands over); anything else as it is."""
    item = getattr(value, "item", None)
    if callable(item) and getattr(value, "shape", None) == ():
        return item()
    return value


def _converted(var, value) -> str:
    """': "8deg" is 0.139626' for a string of a number and the human unit of var's SI unit (deg for rad, rpm for
    rad/s), the number to give; else ''."""
    human = HUMAN_UNITS.get(var.unit)
    match = re.fullmatch(r"\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*(\w+)\s*", value) \
        if isinstance(value, str) else None
    if human is None or match is None or match[2] != human[0]:
        return ""
    return f": {value!r} is {float(match[1]) * human[1]:.6g} {var.unit}"


def _expected(var):
    """What a TOML value of var must be, in words (scenario values are SI: no unit strings)."""
    if var.type is bool:
        return "true or false"
    if var.type is int:
        return f"an integer in {var.range_text()} ({var.description})"
    unit = f" in {var.unit}" if var.unit not in (None, "1") else ""
    hint = ""
    if var.unit in ("rad", "rad/s"):
        hint = (" (scenario values, in a file or from Python, are SI numbers: angles in rad, speeds in rad/s; "
                "`ujfmu run --set` and `ujfmu sweep --param` take deg and rpm suffixes, and Python converts with "
                "math.radians or a factor pi/30)")
    return f"a number{unit}{hint}"


#: the scenarios that come with ujfmu (a clone's scenarios/ folder), offered for a mistyped name
BUNDLED_SCENARIOS = REPO_DIR / "scenarios"


def not_found_hint(path: Path) -> str:
    """'; did you mean ...?' for a scenario path that does not exist: the same path with .toml when that file
    exists, else the closest names (difflib) among the .toml files of its folder, of the current directory's
    scenarios/ (a project's own) and of the bundled scenarios, else (a name without a suffix) among the folders
    beside it that hold scenarios."""
    path = Path(path)
    if path.suffix != ".toml" and path.with_name(path.name + ".toml").is_file():
        return f"; did you mean {path.with_name(path.name + '.toml')}? (scenario files end in .toml)"
    candidates = {}
    for folder, shown in ((path.parent, path.parent), (Path("scenarios"), Path("scenarios")),
                          (BUNDLED_SCENARIOS, BUNDLED_SCENARIOS)):
        if folder.is_dir():
            for file in sorted(folder.glob("*.toml")):
                candidates.setdefault(file.stem, shown / file.name)
    stem = path.name[:-len(".toml")] if path.name.endswith(".toml") else path.name
    close = [stem] if stem in candidates else difflib.get_close_matches(stem, list(candidates), n=3, cutoff=0.6)
    if not close and not path.suffix and path.parent.is_dir():   # a folder of scenarios, misspelt
        folders = {f.name: f for f in sorted(path.parent.iterdir()) if f.is_dir() and any(f.glob("*.toml"))}
        near = difflib.get_close_matches(path.name, list(folders), n=3, cutoff=0.6)
        return f"; did you mean the folder {' or '.join(str(folders[name]) for name in near)}?" if near else ""
    if not close:
        return ""
    return f"; did you mean {' or '.join(str(candidates[name]) for name in close)}?"



#: a Load whose constant torque, in one step, moves the inertia it acts on by more than this many omega_smooth is
#: named before a run whose drive reaches rest (``Scenario.model_advice``): a start from rest lingers near it; from 1
#: on it chatters where the shaft stays near rest (a stall), which a failure's hint names (Omar's driveline at a
#: constant speed runs at 1111 with his 1e-3 rad/s; his start-up runs at 1.1 and 1.8, 5 and 8 N.m, and stops as a
#: coupling instability or chatter from 2.2 on, 10 N.m)
LOAD_CHATTER_ADVICE = 2.0
#: the implicit scheme iterates a load's chatter on a PI Motor's rotor away, where the load's constant torque is
#: at most this share of the Motor's tau_max: above, a joint's swing of the torque it passes (up to 1 / cos of its
#: angle) may keep the shaft stalled at rest, where the iterated steps still ring at the step rate (T0 = 4.9 N.m
#: against cardan_startup's 5 N.m through its 30 deg joint)
BREAKAWAY_SHARE = 0.8
#: Kp h / J at or above which a MotorController's PI, sampled at the step, is unstable (its pole 1 - Kp h / J at -1)
SAMPLED_LOOP_LIMIT = 2.0
#: input angles over a turn at which ``Scenario._sampled_loops`` takes the inertia, the smallest
SAMPLED_LOOP_ANGLES = 16
#: a Load's smooth sign below this at a drive's settled speed is named before the run
#: (``Scenario.smoothed_friction``): 10 omega_smooth gives 0.995
SMOOTH_SIGN = 0.99


@dataclass
class LoadChatter:
    """A Load's constant torque against the output inertia it acts on (``Scenario.load_chatter``)."""
    load: str
    driven: str
    inertia: float
    torque: float
    smooth: float
    step: float
    ratio: float   # the speed one step of the torque moves the inertia by (:meth:`reach`), over omega_smooth
    name: str = "T0"   # what torque is meant: T0, or T0 + T_change where the change makes it larger
    #: where the driven model's output follows its input (a CardanJoint, a rigid double Cardan): the inertia the
    #: load acts on instead, named ("motor's rotor inertia J_rotor", "its driven input shaft's J_drive")
    holder: str = ""
    #: the proportional gain Kp [N.m.s/rad] of a PI Motor's speed loop on that inertia (0: none), which holds the
    #: speed back within the step
    gain: float = 0.0
    #: the load's torque reaches that inertia through the Motor's tau_load, an input the implicit scheme iterates
    #: (``ujfmu.master``: one torn input's root bracketed), and the Motor can break it away
    #: (``BREAKAWAY_SHARE``), so only explicit coupling chatters there
    iterated: bool = False

    @staticmethod
    def reach_of(torque: float, step: float, inertia: float, gain: float = 0.0) -> float:
        """The speed [rad/s] a torque held over a step moves the inertia by: T h / J, or against a speed loop of
        gain Kp, T (1 - exp(-Kp h / J)) / Kp (the loop's proportional part resisting the change)."""
        if gain > 0.0:
            return torque * -math.expm1(-gain * step / inertia) / gain
        return torque * step / inertia

    def text(self) -> str:
        reach = self.reach_of(self.torque, self.step, self.inertia, self.gain)
        moves = (f"{self.driven}'s output, which follows its input, and with it {self.holder}, J = "
                 f"{self.inertia:g} kg.m2," if self.holder else
                 f"{self.driven}'s output inertia J = {self.inertia:g} kg.m2")
        law = (f"{self.name} (1 - exp(-Kp h / J)) / Kp (its speed loop's Kp = {self.gain:g} N.m.s/rad holding it "
               "back)" if self.gain > 0.0 else f"{self.name} h / J")
        if self.gain > 0.0:   # the step at which the loop's hold meets omega_smooth
            share = self.gain * self.smooth / self.torque
            step = -self.inertia / self.gain * math.log1p(-share) if share < 1.0 else math.inf
        else:
            step = self.inertia * self.smooth / self.torque
        return (f"{self.load}: its constant torque {self.name} = {self.torque:g} N.m reverses within omega_smooth = "
                f"{self.smooth:g} rad/s of rest, and one step of it ({self.step:g} s) moves {moves} by "
                f"{law} = {reach:.3g} rad/s, "
                f"{self.ratio:.3g}x omega_smooth: near rest (a start, a stall) the load's torque reverses at every "
                f"step, and the run stops as a coupling instability or chatter. Widen omega_smooth to at least "
                f"{reach:.3g} rad/s, or take a step of at most {step:.3g} s (one step then moves it by at most "
                f"omega_smooth: no chatter even where the shaft stays at rest; a start that only passes rest runs "
                f"at up to about {LOAD_CHATTER_ADVICE:g}x, above which a run is warned before it starts)")


class ScenarioError(ValueError):
    """A scenario file is invalid; the message names the file and the field."""


def _round_step(span: float, step: float) -> float:
    """The largest of 1, 2, 2.5 and 5 times a power of 10 that is at most step and divides span into whole steps
    (step itself if none of the 20 below it does)."""
    for exponent in range(math.floor(math.log10(step)), math.floor(math.log10(step)) - 20, -1):
        for mantissa in (5.0, 2.5, 2.0, 1.0):
            h = mantissa * 10.0 ** exponent
            if h <= step * (1 + 1e-12) and math.isclose(span / h, round(span / h), rel_tol=1e-9, abs_tol=1e-9):
                return h
    return step


class _Problems:
    """The problems of one scenario file, gathered part by part so that one reading names them all."""

    def __init__(self, path: Path):
        self.path, self.messages = path, []

    def add(self, message: str) -> None:
        self.messages.append(message)

    @contextlib.contextmanager
    def kept(self):
        """A part of the file read: a ScenarioError inside is kept and ends the part; yields an object whose ``ok``
        says afterwards whether the part was read without one."""
        part = types.SimpleNamespace(ok=True)
        try:
            yield part
        except ScenarioError as exc:
            self.messages.append(str(exc))
            part.ok = False

    def raise_any(self) -> None:
        """ScenarioError with the one problem, or with all of them, one a line."""
        if len(self.messages) == 1:
            raise ScenarioError(self.messages[0])
        if self.messages:
            prefix = f"{self.path}: "
            raise ScenarioError(f"{self.path}: {len(self.messages)} problems:\n"
                                + "\n".join("  - " + m.removeprefix(prefix) for m in self.messages))


@dataclass
class Tolerance:
    rel_range: float = 0.0
    abs: float = 0.0


def description_attribute(path: Path | IO[bytes], attribute: str) -> str | None:
    """An attribute of an FMU file's fmiModelDescription element, e.g. modelName or fmiVersion (None where it cannot
    be read: the run reports that); path may be a file object (an FMU inside an SSP package)."""
    try:
        with zipfile.ZipFile(path) as fmu:
            head = fmu.read("modelDescription.xml")[:4096].decode("utf-8", "replace")
    except (OSError, KeyError, zipfile.BadZipFile):
        return None
    found = re.search(rf'<fmiModelDescription\b[^>]*\s{attribute}="([^"]*)"', head)
    return found.group(1) if found else None


#: an FMU's runtime package entry, named after the FMU and the hash of the sources it was built from
_BUILD_ENTRY = re.compile(r"resources/ujfmu(3?)_\w+_([0-9a-f]{10})_entry\.py")


def reference_problem(table: np.ndarray, columns: list) -> tuple:
    """('', '') if the reference has two rows or more, its columns are finite and its times increase, else (what is
    wrong, at the first such row; how to mend a file made by hand): a NaN or infinite value compares as nothing (an
    infinite band passes any error), and times out of order make the comparison's interpolation meaningless
    (fmpy's validate_result does not return)."""
    if len(table) < 2:
        return (f"has {len(table)} row{'s' * (len(table) != 1)} of data",
                "give it a row at least at the run's start and stop times")
    for name in dict.fromkeys(columns):
        bad = np.flatnonzero(~np.isfinite(table[name]))
        if len(bad):
            return (f"has {table[name][bad[0]]} in column {name} (data row {bad[0] + 1})",
                    "remove that row, or fill it, e.g. by interpolating its neighbours")
    steps = np.diff(table["time"])
    if not np.all(steps > 0.0):
        row = int(np.flatnonzero(~(steps > 0.0))[0]) + 2
        return (f"has times that do not increase (data row {row}: {float(table['time'][row - 1]):g} after "
                f"{float(table['time'][row - 2]):g})", "sort its rows by time and keep one row per time")
    return "", ""


def stale_build(path: Path, fmu: str) -> tuple:
    """(the build hash an FMU file of ujfmu's model fmu carries, the hash a build from this ujfmu's sources gives):
    different when the file was built from other sources (stale, or another checkout's). Equal (nothing to say)
    for a file without a ujfmu runtime package or one that cannot be read."""
    try:
        with zipfile.ZipFile(path) as archive:
            found = [m for m in map(_BUILD_ENTRY.fullmatch, archive.namelist()) if m]
    except (OSError, zipfile.BadZipFile):
        return None, None
    if len(found) != 1 or fmu not in FMUS:
        return None, None
    stem = model_stem(fmu_class(fmu).__module__)
    if found[0].group(1):
        from .build3 import fmi3_hash
        return found[0].group(2), fmi3_hash(stem)
    return found[0].group(2), source_hash(stem)


def edited_members(path: Path, fmu: str) -> list:
    """The members of an FMU file of ujfmu's model fmu whose bytes differ from what its build ships: its runtime
    package (this ujfmu's sources, the build hash in the package's name being theirs: :func:`stale_build`, and its
    docstring), its entry point and the module pythonfmu loads (``slavemodule.txt``), the pythonfmu packages
    copied from the installed ones, and any other Python file under resources/; [] for a file without a ujfmu
    runtime package or one that cannot be read. An FMU edited by hand, or with another build's files copied in,
    keeps the name whose hash :func:`stale_build` compares."""
    import importlib.util
    try:
        with zipfile.ZipFile(path) as archive:
            entries = [m for m in map(_BUILD_ENTRY.fullmatch, archive.namelist()) if m]
            if len(entries) != 1 or fmu not in FMUS:
                return []
            entry = entries[0].group(0)
            unique = entry[len("resources/"):-len("_entry.py")]
            from .build import runtime_title
            fmi3 = bool(entries[0].group(1))
            if fmi3:
                from .build3 import shipped_entry3
                expected = {entry: shipped_entry3(fmu, unique).encode()}
            else:
                from .build import shipped_entry
                expected = {entry: shipped_entry(fmu, unique).encode()}
            expected[f"resources/{unique}/__init__.py"] = f'"""{runtime_title(fmu, fmi3)}"""\n'.encode()
            expected["resources/slavemodule.txt"] = f"{unique}_entry".encode()
            roots = {f"resources/{unique}/": PACKAGE_DIR}
            for package in ("pythonfmu", "pythonfmu3"):
                spec = importlib.util.find_spec(package)
                if spec is not None and spec.origin:
                    roots[f"resources/{package}/"] = Path(spec.origin).parent
            edited = []
            for name in archive.namelist():
                if name in expected:
                    shipped = expected[name]
                else:
                    root = next((r for r in roots if name.startswith(r)), None)
                    rel = name[len(root):] if root else ""
                    if not rel or rel.endswith("/"):   # no copied source: a folder, or none of the build's code
                        if name.startswith("resources/") and name.endswith(".py"):
                            edited.append(name)   # Python that no build ships
                        continue
                    source = roots[root] / rel
                    shipped = source.read_bytes() if source.is_file() else None
                if shipped is None or archive.read(name).replace(b"\r\n", b"\n") != shipped.replace(b"\r\n", b"\n"):
                    edited.append(name)
            return edited
    except (OSError, zipfile.BadZipFile, KeyError):
        return []


class Scenario:
    """A scenario file read and checked (README, "Scenario format"): what ``run_scenario`` and the master run.

    Attributes a caller may read, and set on a copy (``with_parameters``) before running it: ``name``, ``title``,
    ``start_time``, ``stop_time``, ``step_size``, ``output_interval``, ``coupling`` ("implicit" or "explicit"),
    ``components`` ({name: (FMU name, {parameter: value})}), ``inputs``, ``connections`` (``master.Connection``),
    ``record`` ("component.variable" names), ``tolerances`` ({signal: Tolerance}), ``running_speed``,
    ``steady_from``, ``sweep`` (its [sweep] table); ``reference_file`` is None on a changed copy, whose ``changes``
    ({"component.parameter": value}, {} as read) say what ``with_parameters`` changed from the file."""

    def __init__(self, path: str | os.PathLike):
        """Read the scenario file at path (a ScenarioError names every problem in it); the paths it names are
        resolved against its folder now, so a later change of the working directory leaves them valid."""
        self.path = Path(path)
        #: the file, absolute: where the object looks for it, and for the files it names, after it is read
        self.file_path = self.path.absolute()
        try:
            data = tomllib.loads(self.path.read_text())
        except FileNotFoundError:
            raise ScenarioError(f"{self.path}: scenario file not found{not_found_hint(self.path)}") from None
        except IsADirectoryError:
            raise ScenarioError(f"{self.path} is a folder: name one scenario file in it (`ujfmu check {self.path}` "
                                "checks every *.toml there)") from None
        except tomllib.TOMLDecodeError as exc:
            raise ScenarioError(f"{self.path}: {exc}") from None
        self.name = self.path.stem
        self.changes = {}
        problems = _Problems(self.path)
        with problems.kept():
            self._read_header(data)
        with problems.kept() as experiment:
            self._read_experiment(self._table(data, "experiment"))
        broken = self._read_components(data, problems)
        self._read_connections(data, problems, broken)
        with problems.kept():
            self._read_output(data.get("output", {}), problems, broken, experiment.ok)
        with problems.kept():
            output = data.get("output", {})
            self._read_reference(data.get("reference", {}), output if isinstance(output, dict) else {})
        with problems.kept():
            self._read_sweep(data.get("sweep", {}))
        problems.raise_any()
        #: the file's reference, kept on a changed copy that runs without it (``with_parameters``), and the step and
        #: coupling its bands were chosen for
        self.file_reference = self.reference_file
        self.file_step_size, self.file_coupling = self.step_size, self.coupling

    def __repr__(self) -> str:
        parts = ", ".join(f"{c} ({fmu})" for c, (fmu, _) in self.components.items())
        return f"<Scenario {self.name} from {self.path}: {parts}>"

    def _read_header(self, data):
        """The top-level fields: only known ones; title and description strings."""
        unknown = set(data) - TOP_LEVEL_KEYS
        if unknown:
            raise ScenarioError(f"{self.path}: unknown top-level field(s) {', '.join(sorted(unknown))}; "
                                f"known: {', '.join(sorted(TOP_LEVEL_KEYS))}")
        self.title = data.get("title", self.name)
        self.file_title = self.title   # the file's, which a changed copy's title cites after its changes
        self.description = data.get("description", "")
        for field, value in (("title", self.title), ("description", self.description)):
            if not isinstance(value, str):
                raise ScenarioError(f"{self.path}: {field} = {value!r} must be a string")

    def _unknown_fields(self, section: str, unknown: set, known) -> str:
        """The error for unknown fields of a section: each with the known one it likely misspells, and the known."""
        close = {name: difflib.get_close_matches(str(name), sorted(known), n=1, cutoff=0.6) for name in unknown}
        named = ", ".join(f"{name} (did you mean {close[name][0]}?)" if close[name] else str(name)
                          for name in sorted(unknown, key=str))
        return f"{self.path}: [{section}]: unknown field(s) {named}; known: {', '.join(sorted(known))}"

    def _recorded_hint(self, name) -> str:
        """' (did you mean ...?)' for a name close to a recorded signal, else how to record it."""
        close = difflib.get_close_matches(str(name), [str(n) for n in self.record], n=1, cutoff=0.6)
        if close:
            return f" (did you mean {close[0]!r}?)"
        return ": add it to output.record (what the figures and checks read is recorded)"

    def _read_experiment(self, exp):
        """[experiment]: times, step, coupling scheme and output interval."""
        unknown = set(exp) - EXPERIMENT_KEYS
        if unknown:   # before the required ones: a misspelt stop_time is named as such, not as a missing value
            raise ScenarioError(self._unknown_fields("experiment", unknown, EXPERIMENT_KEYS))
        self.start_time = self._number(exp, "experiment.start_time", 0.0)
        self.stop_time = self._number(exp, "experiment.stop_time")
        self.step_size = self._number(exp, "experiment.step_size")
        self.declared_step = self.step_size   # the file's step, which [reference.extrapolated] bands are made for
        if not self.step_size > 0 or not self.stop_time > self.start_time:
            raise ScenarioError(f"{self.path}: [experiment] needs step_size > 0 and stop_time > start_time")
        self.coupling = exp.get("coupling", DEFAULT_COUPLING)
        if self.coupling not in COUPLINGS:
            raise ScenarioError(f"{self.path}: experiment.coupling = {self.coupling!r} must be one of "
                                f"{', '.join(repr(c) for c in COUPLINGS)} (docs/cosimulation.md)")
        self.output_interval = exp.get("output_interval", 1)
        self._check_output_interval()
        self._check_steps()

    def _read_components(self, data, problems) -> set:
        """[components.*], each checked on its own: the names of those whose FMU is not known (their variables
        cannot be checked where they are named); the problems kept in problems."""
        self.components = {}
        self.inputs = {}
        broken = set()
        with problems.kept():
            self._table(data, "components")
        for cname, comp in data["components"].items() if isinstance(data.get("components"), dict) else ():
            with problems.kept() as component:
                if not isinstance(comp, dict) or set(comp) - {"fmu", "parameters", "inputs"}:
                    raise ScenarioError(f"{self.path}: components.{cname}: fields are fmu, parameters and inputs, "
                                        f"got {sorted(comp) if isinstance(comp, dict) else comp!r}")
                fmu = comp.get("fmu")
                if fmu not in FMUS:
                    close = difflib.get_close_matches(str(fmu), FMUS, n=1)
                    raise ScenarioError(f"{self.path}: components.{cname}.fmu = {fmu!r} is not one of {list(FMUS)}"
                                        + (f" (did you mean {close[0]!r}?)" if close else ""))
            if not component.ok:
                broken.add(cname)
                continue
            # the FMU is known: its variables are checked where connections and outputs name them
            self.components[cname], self.inputs[cname] = (fmu, {}), {}
            with problems.kept():
                params = self._values(cname, fmu, comp, "parameters", problems)
                inputs = self._values(cname, fmu, comp, "inputs", problems)
                self.components[cname] = (fmu, params or {})
                self.inputs[cname] = inputs if inputs is not None else dict(comp.get("inputs", {}))
                model = self.model_problems(cname) if params is not None else []
                if model:
                    raise ScenarioError(f"{self.path}: components.{cname}.parameters: {'; '.join(model)}")
        return broken

    def _read_connections(self, data, problems, broken):
        """[[connections]], each checked on its own (one to or from a component with a problem is not: its
        problem is named already), then every input of the components fed or set."""
        self.connections = []
        fed = {}
        complete = True
        for i, conn in enumerate(data.get("connections", [])):
            src, dst = conn.get("from"), conn.get("to")
            if {str(src).partition(".")[0], str(dst).partition(".")[0]} & broken:
                complete = False
                continue
            with problems.kept() as connection:
                out = self._check_signal(src, f"connections[{i}].from", "output")
                inp = self._check_signal(dst, f"connections[{i}].to", "input")
                if (out.type, out.unit) != (inp.type, inp.unit):
                    raise ScenarioError(f"{self.path}: connections[{i}]: {src} [{out.unit or out.type.__name__}] "
                                        f"cannot feed {dst} [{inp.unit or inp.type.__name__}]: units differ")
                if dst in fed:
                    raise ScenarioError(f"{self.path}: connections[{i}].to = {dst!r} is already fed by "
                                        f"connections[{fed[dst]}]")
                comp, _, name = dst.partition(".")
                if name in self.inputs[comp]:
                    raise ScenarioError(f"{self.path}: connections[{i}].to = {dst!r} is also set under "
                                        f"components.{comp}.inputs: the connection would override it; drop one")
                fed[dst] = i
                self.connections.append(Connection(src, dst))
            complete = complete and connection.ok
        unfed = self.unfed_inputs()
        if unfed and complete:   # an input a connection with a problem was meant to feed is not named again
            problems.add(f"{self.path}: {self._unfed_text(unfed)}")

    def unfed_inputs(self) -> list:
        """The inputs ("component.input") no connection feeds and the scenario does not set, but for those the
        component's parameters leave unread (``used_if`` at 0); one its parameters read (a Load's phi for its T_h)
        must be connected, not set."""
        fed = {c.target for c in self.connections}
        return [f"{cname}.{v.name}" for cname, (fmu, _) in self.components.items()
                for v in fmu_class(fmu).VARIABLES
                if v.causality == "input" and f"{cname}.{v.name}" not in fed
                and (v.name not in self.inputs[cname] if v.used_if is None
                     else self.parameters_with_defaults(cname).get(v.used_if))]

    def _unfed_text(self, unfed: list) -> str:
        """Why the inputs unfed (:meth:`unfed_inputs`) must be connected, and how."""
        read = [name for name in unfed if self._used_if(name)]
        if read:
            name = read[0]
            return (f"input(s) {', '.join(read)} not connected: {name.partition('.')[0]}'s "
                    f"{self._used_if(name)} != 0 reads it over the run (a Load's periodic torque reads its shaft's "
                    f"angle): connect it, e.g. from = \"<machine>.phi_out\", to = \"{name}\" (a value held there "
                    "would make the torque a constant)")
        first = unfed[0].split(".", 1)
        return (f"input(s) {', '.join(unfed)} not connected: connect each ([[connections]] to = ...) "
                f"or set it explicitly, held constant, e.g. [components.{first[0]}] inputs = {{ {first[1]} = 0.0 }}")

    def _used_if(self, name: str) -> str | None:
        """The parameter that makes the model read the input "component.input" (``used_if``), None for another."""
        comp, _, port = name.partition(".")
        return next((v.used_if for v in fmu_class(self.components[comp][0]).VARIABLES if v.name == port), None)

    def _read_output(self, out, problems, broken, timed):
        """[output]: recorded signals (each checked on its own, those of a component with a problem not), the ones
        plotted, drawn as orbits or spectra, the running speed, and steady_from within the experiment's times
        (where those are valid: ``timed``)."""
        if not isinstance(out, dict):
            self.record = []
            raise ScenarioError(f"{self.path}: [output] must be a table; known fields: "
                                f"{', '.join(sorted(OUTPUT_KEYS))}")
        unknown = set(out) - OUTPUT_KEYS
        if unknown:   # the others still read: what they name is checked, and nothing is blamed on the misspelling
            problems.add(self._unknown_fields("output", unknown, OUTPUT_KEYS))
        self.record = list(out.get("record", []))
        if not self.record:
            offered = [f"{c}.{v.name}" for c, (fmu, _) in self.components.items() if fmu in FMUS
                       for v in fmu_class(fmu).VARIABLES if v.causality == "output"]
            problems.add(f"{self.path}: output.record: no signal is recorded, so a run would write a table of times "
                         f"alone and check nothing; name what to record under [output], e.g. record = "
                         f"{offered[:3]!r}" + (f" (the components' outputs: {', '.join(offered)})" if offered else ""))
        for i, name in enumerate(self.record):
            if str(name).partition(".")[0] not in broken:
                with problems.kept():
                    self._check_signal(name, f"output.record[{i}]")
        self.orbits = [tuple(pair) for pair in out.get("orbits", [])]
        for i, pair in enumerate(self.orbits):
            if len(pair) != 2:
                raise ScenarioError(f"{self.path}: output.orbits[{i}] = {list(pair)!r} must be [x, y] signals")
        self.spectra = list(out.get("spectra", []))
        self.running_speed = out.get("running_speed")
        for field, names in (("orbits", [n for pair in self.orbits for n in pair]), ("spectra", self.spectra),
                             ("running_speed", [self.running_speed] if self.running_speed else [])):
            for name in names:
                if name not in self.record:
                    raise ScenarioError(f"{self.path}: output.{field}: {name!r} is not a recorded signal"
                                        f"{self._recorded_hint(name)}")
        if self.running_speed:
            self._check_running_speed(self.running_speed, "output.running_speed")
        if timed:
            self.steady_from = self._number(out, "output.steady_from", self.start_time)
            if not self.start_time <= self.steady_from < self.stop_time:
                raise ScenarioError(f"{self.path}: output.steady_from = {self.steady_from!r} s must lie in "
                                    f"[start_time, stop_time) = [{self.start_time!r}, {self.stop_time!r}) s")

    def _read_reference(self, ref, out):
        """[reference]: the file, its generator, the bands and the signals not compared (every recorded signal is
        one or the other); then [output] out's plot (default: the compared signals)."""
        self.reference_file_text = ref.get("file") if isinstance(ref, dict) else None
        unknown = set(ref) - REFERENCE_KEYS if isinstance(ref, dict) else {"(not a table)"}
        if unknown:
            raise ScenarioError(self._unknown_fields("reference", unknown, REFERENCE_KEYS))
        self.reference_file = None
        if "file" in ref:
            if not isinstance(ref["file"], str) or not ref["file"].endswith((".csv", ".csv.gz")):
                raise ScenarioError(f"{self.path}: reference.file = {ref['file']!r} must be the path of a .csv file "
                                    "(or a gzipped .csv.gz)")
            self.reference_file = self.file_path.parent / ref["file"]
        self.reference_generator = ref.get("generator")
        self._check_generator()
        self.tolerances = self._tolerances(ref, "tolerance")
        self.extrapolated_tolerances = self._tolerances(ref, "extrapolated")
        self.not_compared = {}
        for name, reason in ref.get("not_compared", {}).items():
            field = f"reference.not_compared.{name}"
            if name not in self.record:
                raise ScenarioError(f"{self.path}: {field}: not a recorded signal{self._recorded_hint(name)}")
            if name in self.tolerances:
                raise ScenarioError(f"{self.path}: {field}: the signal also has a [reference.tolerance]")
            if not isinstance(reason, str) or not reason.strip():
                raise ScenarioError(f"{self.path}: {field} = {reason!r} must be the reason, a non-empty string")
            self.not_compared[name] = reason.strip()
        if self.reference_file is not None:
            missing = [n for n in self.record if n not in self.tolerances and n not in self.not_compared]
            if missing:
                from .steady import grows
                bands = [f"\"{n}\" = {{ abs = 0.05 }} (it grows along the run: an absolute band, in its unit)"
                         if grows(n)
                         else f"\"{n}\" = {{ rel_range = 0.05 }}" for n in missing[:2]]
                raise ScenarioError(f"{self.path}: output.record: {', '.join(missing)} neither compared "
                                    "([reference.tolerance]) nor listed in reference.not_compared with the reason; "
                                    "while you make a new reference (`ujfmu references`) and choose the bands "
                                    "(`ujfmu run --check-step`), give each a provisional band, e.g. "
                                    + "; ".join(bands))
        self.order_tolerances = self._order_tolerances(ref)
        self.plot = list(out.get("plot", self.tolerances or self.record))
        for name in self.plot:
            if name not in self.record:
                raise ScenarioError(f"{self.path}: output.plot: {name!r} is not a recorded signal"
                                    f"{self._recorded_hint(name)}")

    def _read_sweep(self, sweep):
        """[sweep]: known fields, numbers where numbers go, recorded signals."""
        self.sweep = sweep
        unknown = set(self.sweep) - SWEEP_KEYS if isinstance(self.sweep, dict) else {"(not a table)"}
        if unknown:
            raise ScenarioError(self._unknown_fields("sweep", unknown, SWEEP_KEYS))
        for key in ("settle_time", "revolutions", "steady_tol", "max_settle_time"):
            if key in self.sweep:
                self._number(self.sweep, f"sweep.{key}")
        speed = [self.sweep["running_speed"]] if "running_speed" in self.sweep else []
        for name in list(self.sweep.get("outputs", [])) + speed:
            if name not in self.record:
                raise ScenarioError(f"{self.path}: sweep: {name!r} is not a recorded signal"
                                    f"{self._recorded_hint(name)}")

    def _values(self, cname, fmu, comp, key, problems):
        """components.NAME.parameters or .inputs: declared names of that causality, values of the declared type
        within range; None where any is not (each named in problems)."""
        causality = key[:-1]
        values = comp.get(key, {})
        if not isinstance(values, dict):
            raise ScenarioError(f"{self.path}: components.{cname}.{key} must be a table {{ name = value, ... }}")
        declared = {v.name: v for v in fmu_class(fmu).VARIABLES if v.causality == causality}
        valid = True
        for pname, value in values.items():
            with problems.kept() as item:
                self._check_value(fmu, declared, causality, f"components.{cname}.{key}.{pname}", pname, value)
            valid = valid and item.ok
        return dict(values) if valid else None

    def _check_value(self, fmu, declared, causality, field, pname, value):
        """ScenarioError unless pname is one of the declared variables and value of its type and within range."""
        if pname not in declared:
            other = next((v.causality for v in fmu_class(fmu).VARIABLES if v.name == pname), None)
            close = [] if other else difflib.get_close_matches(pname, declared, n=2, cutoff=0.6)
            raise ScenarioError(f"{self.path}: {field}: {fmu} has no {causality} '{pname}'"
                                + (f" (it is {_OTHER_CAUSALITY.get(other, 'an ' + str(other))})" if other else "")
                                + (f" (did you mean {' or '.join(close)}?)" if close else "")
                                + (f" ({_MISPLACED[fmu, pname]})" if (fmu, pname) in _MISPLACED else "")
                                + f" (it has {', '.join(declared) or 'none'})")
        var = declared[pname]
        kinds = (bool,) if var.type is bool else (int,) if var.type is int else (int, float)
        if not isinstance(value, kinds) or (var.type is not bool and isinstance(value, bool)):
            raise ScenarioError(f"{self.path}: {field} = {value!r} must be {_expected(var)}{_converted(var, value)}")
        problem = var.check(var.type(value))
        if problem:
            raise ScenarioError(f"{self.path}: {field}: {problem}")

    def with_values(self, changes: dict) -> "Scenario":
        """A copy with parameters {"component.parameter": value} set as given, unchecked; its lists and tables
        (record, plot, connections, tolerances, ...) are its own, so a change to the copy leaves this one as it is."""
        out = copy.deepcopy(self)
        for key, value in changes.items():
            comp, _, par = key.partition(".")
            out.components[comp][1][par] = value
        return out

    def check_setup(self) -> None:
        """ScenarioError unless what a caller may change on a read Scenario still holds as a file's must: its name a
        plain file name (it names the files a run writes), every parameter of its type and range, every recorded
        signal a variable of a component, named once. ``run_scenario`` calls it before anything runs."""
        problems = _Problems(self.path)
        if file_name_problem(self.name):
            problems.add(f"{self.path}: name = {file_name_problem(self.name)}")
        for comp, (fmu, params) in self.components.items():
            declared = {v.name: v for v in fmu_class(fmu).VARIABLES if v.causality == "parameter"}
            for par, value in params.items():
                with problems.kept():
                    self._check_value(fmu, declared, "parameter", f"components.{comp}.parameters.{par}", par,
                                      plain_number(value))
        if isinstance(self.record, str) or not isinstance(self.record, (list, tuple)):
            problems.add(f"{self.path}: record = {self.record!r} must be a list of signals, e.g. "
                         f"[{self.record!r}]" if isinstance(self.record, str) else
                         f"{self.path}: record = {self.record!r} must be a list of signals")
            problems.raise_any()
        for i, name in enumerate(self.record):
            with problems.kept():
                self._check_signal(name, f"record[{i}]")
        twice = sorted({name for name in self.record if self.record.count(name) > 1})
        if twice:
            problems.add(f"{self.path}: record names {', '.join(twice)} more than once: record each signal once")
        compared = dict.fromkeys([*self.tolerances, *self.extrapolated_tolerances, *self.order_tolerances])
        unrecorded = [n for n in compared if n not in self.record] if self.reference_file is not None else []
        if unrecorded:   # the run would end in a comparison of columns it does not have
            one = len(unrecorded) == 1
            problems.add(f"{self.path}: {', '.join(unrecorded)} {'is' if one else 'are'} compared with the reference "
                         f"but not recorded: record {'it' if one else 'them'} (scenario.record), or compare "
                         f"{'it' if one else 'them'} no more (del scenario.tolerances[name], and from "
                         "extrapolated_tolerances and order_tolerances where named), or set reference_file = None "
                         "to run unchecked")
        if self.coupling not in COUPLINGS:
            problems.add(f"{self.path}: coupling = {self.coupling!r} must be one of {', '.join(COUPLINGS)}")
        if isinstance(self.record, tuple):
            self.record = list(self.record)
        asked = {"running_speed": [self.running_speed] if self.running_speed else [],
                 "orbits": [n for pair in self.orbits for n in pair], "spectra": self.spectra}
        for what, names in asked.items():
            unrecorded = list(dict.fromkeys(n for n in names if n not in self.record))
            if unrecorded:
                problems.add(f"{self.path}: {what} names {', '.join(unrecorded)}, not recorded: record "
                             f"{'it' if len(unrecorded) == 1 else 'them'} (scenario.record), or leave "
                             f"{'it' if len(unrecorded) == 1 else 'them'} out of scenario.{what}")
        if self.running_speed and self.running_speed in self.record:
            with problems.kept():
                self._check_running_speed(self.running_speed, "running_speed")
        problems.raise_any()

    def with_parameters(self, changes: dict, name: str | None = None) -> "Scenario":
        """A copy with parameters changed, {"component.parameter": value} (SI units), each checked as the file's
        are; named ``name`` (default ``<name>_changed``: its CSV and figures do not overwrite this scenario's), its
        title saying what changed, and without the reference: a reference is made for the file's setup, so the copy
        runs unchecked (give it a scenario file and `ujfmu references` to check it)."""
        if not isinstance(changes, dict):
            raise ScenarioError(f"{self.path}: with_parameters takes a dict {{\"component.parameter\": value}}, not "
                                f"{type(changes).__name__} {changes!r}")
        changes = {key: plain_number(value) for key, value in changes.items()}
        problems = _Problems(self.path)
        if name is not None and file_name_problem(name):
            problems.add(f"{self.path}: with_parameters: name = {file_name_problem(name)}")
        for key, value in changes.items():
            with problems.kept():
                comp, _, par = key.partition(".")
                if comp not in self.components:
                    close = difflib.get_close_matches(comp, self.components, n=1)
                    raise ScenarioError(f"{self.path}: with_parameters: no component '{comp}' in {key!r}"
                                        + (f" (did you mean {close[0]!r}?)" if close else "")
                                        + f" (it has {', '.join(self.components)})")
                fmu = self.components[comp][0]
                declared = {v.name: v for v in fmu_class(fmu).VARIABLES if v.causality == "parameter"}
                if (par in declared and declared[par].type is int and isinstance(value, float)
                        and value.is_integer()):   # a whole number written 1.0 (an optimizer's), as --set takes it
                    value = changes[key] = int(value)
                self._check_value(fmu, declared, "parameter", f"components.{comp}.parameters.{par}", par, value)
        problems.raise_any()
        out = self.with_values(changes)
        for comp in {key.partition(".")[0] for key in changes}:
            problems = out.model_problems(comp)
            if problems:
                raise ScenarioError(f"{self.path}: with_parameters: components.{comp}.parameters: "
                                    f"{'; '.join(problems)}")
        unfed = [name for name in out.unfed_inputs() if name not in self.unfed_inputs()]
        if unfed:   # an input the changed parameters make the model read (a Load's phi for its T_h)
            raise ScenarioError(f"{self.path}: with_parameters: {', '.join(changes)}: {self._unfed_text(unfed)}")
        out.name = name or f"{self.name}_changed"
        out.changes = {**self.changes, **changes}
        if changes:   # what the copy runs first: the file's title describes another setup
            out.title = (", ".join(self.change_text(k, v) for k, v in out.changes.items())
                         + f" (a changed copy of: {self.file_title})")
        out.reference_file, out.tolerances, out.extrapolated_tolerances = None, {}, {}
        out.order_tolerances = {}
        return out

    def with_stop_time(self, stop_time: float) -> "Scenario":
        """This scenario run until stop_time [s] (``--stop-time``): a copy as :meth:`with_parameters` makes
        (``<name>_changed``, without the file's reference, even where the run ends within it: the bands are shares of
        the range the file's whole run reaches, which a shorter one need not), its title saying so, and without the
        file's steady window where that starts at or after stop_time (a window past the run's end is empty); itself
        where stop_time is the file's; ScenarioError unless stop_time is a whole number of steps after the start.
        A copy of a copy keeps its name (this scenario is left as it was)."""
        if isinstance(stop_time, bool) or not isinstance(stop_time, numbers.Real) or not math.isfinite(stop_time):
            raise ScenarioError(f"{self.path}: with_stop_time({stop_time!r}): the stop time must be a finite number "
                                "[s]")
        stop_time = float(stop_time)
        if stop_time == self.stop_time:
            return self
        out = self.with_parameters({}, name=None if self.name == self.path.stem else self.name)
        out.stop_time = stop_time
        out.title = f"{out.title} (stop_time = {stop_time:g} s)"
        if out.steady_from is not None and out.steady_from >= stop_time:
            out.title += f" (no steady window: the file's steady_from = {out.steady_from:g} s is after it)"
            out.steady_from = 0.0
        try:
            out.check_experiment()
        except ScenarioError as exc:   # the stop time given, not the file's experiment
            text = str(exc).removeprefix(f"{self.path}: ")
            raise ScenarioError(f"{self.path}: with_stop_time({stop_time!r}) (ujfmu run --stop-time): {text}") from None
        return out

    def change_text(self, key: str, value) -> str:
        """'component.parameter = value unit' for a title, with deg or rpm beside rad and rad/s."""
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            return f"{key} = {value}"
        unit = self.unit(key)
        text = f"{key} = {value:g}" + (f" {unit}" if unit and unit != "1" else "")
        if unit == "rad":
            text += f" ({math.degrees(value):.6g} deg)"
        elif unit == "rad/s":
            text += f" ({value * 30.0 / math.pi:.6g} rpm)"
        return text

    def _check_running_speed(self, name, field: str) -> None:
        """ScenarioError unless the signal name (recorded: checked before) is a speed, in rad/s: orders and
        revolutions count its angle."""
        unit = self.unit(name)
        if unit != "rad/s":
            raise ScenarioError(f"{self.path}: {field} = {name!r} is in {unit or 'no unit'}, not rad/s: whole "
                                "revolutions and orders are counted from a shaft's speed; this scenario's speeds: "
                                f"{', '.join(self.speed_signals())}")

    def speed_signals(self) -> list:
        """The components' outputs in rad/s, "component.variable"."""
        return [f"{c}.{v.name}" for c, (fmu, _) in self.components.items()
                for v in fmu_class(fmu).VARIABLES if v.unit == "rad/s" and v.causality == "output"]

    def unit(self, name: str) -> str:
        """The declared unit of a "component.variable" ("" when it has none), "s" for "time" (a table's first
        column); ScenarioError for a name the scenario does not have."""
        if name == "time":
            return "s"
        comp, _, var = name.partition(".")
        declared = {v.name: v for v in fmu_class(self.components[comp][0]).VARIABLES} if comp in self.components \
            else {}
        if var not in declared:
            raise ScenarioError(f"{self.path}: {name!r} is not a variable of this scenario's components "
                                f"({', '.join(self.components)}): give 'component.variable'")
        return declared[var].unit or ""

    def start_values(self, component):
        """What the scenario sets in a component before it runs: its parameters, its explicitly set inputs, and
        the inputs its parameters leave unread (``used_if``), unconnected, at their start values (held
        deliberately, not by omission)."""
        fmu, params = self.components[component]
        fed = {c.target for c in getattr(self, "connections", ())}
        unread = {v.name: v.start for v in fmu_class(fmu).VARIABLES
                  if v.causality == "input" and v.used_if and f"{component}.{v.name}" not in fed
                  and not self.parameters_with_defaults(component).get(v.used_if)}
        return {**unread, **params, **self.inputs.get(component, {})}

    def _check_generator(self):
        """A named reference generator must be one of ujfmu.references.GENERATORS; a former name is refused with
        today's."""
        from .references import GENERATORS, RENAMED
        name = self.reference_generator
        if name is None or name in GENERATORS:
            return
        field = f"{self.path}: reference.generator = {name!r}"
        if name in RENAMED:
            raise ScenarioError(f'{field} is now called {RENAMED[name]!r}: write generator = "{RENAMED[name]}"')
        raise ScenarioError(f"{field} is not a reference generator (known: {', '.join(GENERATORS)}; "
                            "leave it out for a reference made otherwise)")

    def setup_digest(self) -> str:
        """Digest of what a reference solution of this scenario depends on: each component's FMU, parameters and
        set inputs, the connections and the start time (numbers as floats, so 1 and 1.0 agree). Left out: the
        step, the stop time, the records and the tolerances (the comparison interpolates the reference and checks
        that it spans the run and has the compared columns)."""
        def values(table):
            return {k: v if isinstance(v, bool) else float(v) for k, v in sorted(table.items())}
        setup = {"components": {name: [fmu, values(params), values(self.inputs.get(name, {}))]
                                for name, (fmu, params) in sorted(self.components.items())},
                 "connections": sorted([c.source, c.target] for c in self.connections),
                 "start_time": float(self.start_time)}
        return hashlib.sha256(json.dumps(setup, sort_keys=True).encode()).hexdigest()[:12]

    def defaults_digest(self) -> str:
        """Digest of the FMU defaults a reference of this scenario relies on: the declared start value of every
        parameter and unconnected input of its components that the scenario leaves unset (a default changed in an
        update of an FMU changes the system the reference solved, which :meth:`setup_digest` cannot see), but for a
        parameter at its neutral value (``Var.neutral``: a feature an update added, off by default, leaves the
        system as it was)."""
        setup, connected = {}, {c.target for c in self.connections}
        for name, (fmu, params) in sorted(self.components.items()):
            given = {**params, **self.inputs.get(name, {}), **{t.split(".", 1)[1]: None for t in connected
                                                                if t.split(".", 1)[0] == name}}
            setup[name] = [fmu, {v.name: v.start for v in fmu_class(fmu).VARIABLES
                                 if v.causality in ("parameter", "input") and v.name not in given
                                 and not (v.neutral is not None and v.start == v.neutral)}]
        return hashlib.sha256(json.dumps(setup, sort_keys=True, default=float).encode()).hexdigest()[:12]

    def read_reference(self):
        """The [reference] file as a structured array (:meth:`reference`)."""
        return self.reference()[0]

    def bands_hold_at(self, step: float) -> bool:
        """The [reference.extrapolated] bands apply to a run at step: they hold the O(h^2) remainder of the step-halving
        extrapolation at the scenario's declared step, so at that step or a finer one."""
        return step <= self.declared_step * (1 + 1e-9)

    def reference(self) -> tuple:
        """(table, provenance) of the [reference] file; ScenarioError naming the scenario and the field when it
        cannot be read, or when its provenance line names another setup (setup_digest) than the scenario's: a
        reference left over from other parameters or wiring would compare against another system."""
        from .references import defaults_of, read_reference, scenario_of, setup_of
        field = f"{self.path}: [reference] file = {self.reference_file_text!r}"
        if not self.reference_file.is_file():
            raise ScenarioError(f"{field}: {self.reference_file} not found (the path is relative to the scenario "
                                f"file; `ujfmu references {self.path}` regenerates it when the scenario names a "
                                "generator, with the references extra: pip install 'ujfmu[references]'; or remove "
                                "the [reference] tables to run it unchecked)")
        try:
            table, provenance = read_reference(self.reference_file)
        except (ValueError, IndexError, OSError) as exc:
            head = self.reference_file.read_bytes()[:200] if self.reference_file.is_file() else b""
            remake = (f"`ujfmu references {self.path}` regenerates it" if self.reference_generator else
                      "the scenario names no generator (a measured or hand-made reference): fix the file, a header "
                      "line of the column names then one line of numbers a time, in SI units, comma-separated")
            why = (" (it is a Git LFS pointer, not the data: fetch the file, e.g. `git lfs pull`"
                   + (", or regenerate it)" if self.reference_generator else ")")
                   if head.startswith(b"version https://git-lfs") else f" (a truncated or hand-edited file? {remake})")
            raise ScenarioError(f"{field}: cannot read {self.reference_file}: {exc}{why}") from None
        made_for = setup_of(provenance)
        if made_for is not None and made_for != self.setup_digest():
            owner = scenario_of(provenance)
            foreign = self.foreign_reference(owner)
            if foreign:
                raise ScenarioError(foreign)
            if owner is not None and Path(owner).stem != self.path.stem:
                raise ScenarioError(f"{field}: {self.reference_file} holds the reference of {owner} (its provenance "
                                    "line says so), copied here; make this scenario's own: "
                                    f"`ujfmu references {self.path}`")
            if self.file_path.is_file() and Scenario(self.file_path).setup_digest() == made_for:
                raise ScenarioError(f"{field}: this Scenario object was changed after it was read from {self.path}, "
                                    f"whose setup its reference {self.reference_file} was made for, so the reference "
                                    "cannot check it: make the copy with scenario.with_parameters({...}), which runs "
                                    "it unchecked under its own name, or set reference_file = None")
            raise ScenarioError(f"{field}: {self.reference_file} was made for another setup of this scenario "
                                f"(setup {made_for}, the scenario's is now {self.setup_digest()}: a component, "
                                "parameter, set input, connection or the start time changed since); regenerate it: "
                                f"`ujfmu references {self.path}`")
        made_with = defaults_of(provenance)
        if made_with is not None and made_with != self.defaults_digest():
            raise ScenarioError(f"{field}: {self.reference_file} was made with other FMU defaults (defaults "
                                f"{made_with}, now {self.defaults_digest()}): the declared default of a parameter or "
                                "input this scenario leaves unset changed since (an update of an FMU), so the "
                                f"reference solved another system; regenerate it: `ujfmu references {self.path}`, or "
                                "set the parameter in the scenario to the value the reference was made with")
        missing = list(dict.fromkeys(n for n in ["time", *self.tolerances, *self.extrapolated_tolerances]
                                     if n not in table.dtype.names))
        if missing:
            raise ScenarioError(f"{field}: no column {', '.join(missing)} in {self.reference_file}")
        problem, mend = reference_problem(table, ["time", *self.tolerances, *self.extrapolated_tolerances])
        if problem:
            raise ScenarioError(f"{field}: {self.reference_file} {problem}: a reference must be a finite solution on "
                                "increasing times; "
                                + (f"regenerate it (`ujfmu references {self.path}`)" if self.reference_generator else
                                   f"the scenario names no generator (a measured or hand-made reference): {mend}"))
        if made_for is None and self.reference_generator:
            raise ScenarioError(f"{field}: {self.reference_file} has no provenance line (the '#' line `ujfmu "
                                f"references` writes: how it was made, for which setup), though the scenario names "
                                f"its generator {self.reference_generator!r}: a file made otherwise, or edited, would "
                                f"be compared unchecked; regenerate it: `ujfmu references {self.path}`")
        return table, provenance

    def foreign_reference(self, owner: str | None) -> str:
        """'' unless owner (the scenario a reference file's provenance line names) is another scenario than this
        one and the file is not named after this one: then what to do, since the file is that one's (a copied
        scenario still naming its original's). A file named after this scenario is its own, whatever it holds
        (a copy of another's reference), and ``ujfmu references`` may replace it."""
        if owner is None or Path(owner).stem == self.path.stem or self.reference_file.stem == self.name:
            return ""
        return (f"{self.path}: [reference] file = {self.reference_file_text!r} is the reference of {owner} (its "
                f"provenance line says so): give this scenario its own file, e.g. file = "
                f'"references/{self.name}.csv", and make it with `ujfmu references {self.path}`')

    def reference_output(self):
        """Where `ujfmu references` writes the reference: the reference file if it resolves (symlinks followed)
        inside the scenario's folder, else a ScenarioError, so a scenario file cannot make it write elsewhere."""
        folder = self.file_path.parent.resolve()
        path = self.reference_file.resolve()
        if not path.is_relative_to(folder):
            raise ScenarioError(f"{self.path}: reference.file = {str(self.reference_file)!r} is outside the "
                                f"scenario's folder {folder}; `ujfmu references` writes only inside it (give a "
                                f"relative path such as references/{self.name}.csv)")
        return path

    def _order_tolerances(self, ref) -> dict:
        """{signal: rel} of [reference.orders]: each a recorded signal whose running-speed orders the run must match
        within rel of the reference's over the steady window, which needs output.steady_from, output.running_speed
        and a reference file (``scenario_run.check_orders``)."""
        table = ref.get("orders", {})
        if not isinstance(table, dict):
            raise ScenarioError(f"{self.path}: [reference.orders] must be a table")
        start = getattr(self, "start_time", 0.0)
        missing = [what for what, lacking in (
            ("a reference file (reference.file)", self.reference_file is None),
            ("output.running_speed (the speed whose revolutions the orders count)",
             getattr(self, "running_speed", None) is None),
            ("output.steady_from after start_time (where the window starts, after the start-up)",
             not getattr(self, "steady_from", math.inf) > start)) if lacking]   # unread: [experiment] is wrong
        if table and missing:
            raise ScenarioError(f"{self.path}: [reference.orders] compares the running-speed orders over the steady "
                                f"window, so it needs {' and '.join(missing)}")
        orders = {}
        for name, tol in table.items():
            field = f"reference.orders.{name}"
            if name not in self.record:
                raise ScenarioError(f"{self.path}: {field}: not a recorded signal{self._recorded_hint(name)}")
            from .steady import grows
            if grows(name):
                raise ScenarioError(f"{self.path}: {field}: a running angle or an energy integral grows along the "
                                    "run, and its orders over a window describe that ramp, not a vibration")
            if not isinstance(tol, dict) or set(tol) != {"rel"}:
                raise ScenarioError(f"{self.path}: {field} = {tol!r} must be {{ rel = ... }}: the error allowed on "
                                    "each order's amplitude as a fraction of the reference's")
            rel = self._number(tol, f"{field}.rel")
            if not 0.0 < rel < 1.0:
                raise ScenarioError(f"{self.path}: {field}.rel = {rel:g} must lie in (0, 1)")
            orders[name] = rel
        return orders

    def _tolerances(self, ref, key):
        """{signal: Tolerance} of [reference.<key>]; each a recorded signal with finite, non-negative bounds."""
        table = ref.get(key, {})
        if not isinstance(table, dict):
            raise ScenarioError(f"{self.path}: [reference.{key}] must be a table")
        tolerances = {}
        for name, tol in table.items():
            field = f"reference.{key}.{name}"
            if name not in self.record:
                raise ScenarioError(f"{self.path}: {field}: not a recorded signal{self._recorded_hint(name)}")
            if not isinstance(tol, dict) or not tol or set(tol) - TOLERANCE_KEYS:
                raise ScenarioError(f"{self.path}: {field} = {tol!r} must be {{ rel_range = ..., abs = ... }}")
            values = {k: self._number(tol, f"{field}.{k}") for k in tol}
            if any(v < 0 for v in values.values()):
                raise ScenarioError(f"{self.path}: {field}: bounds must not be negative, got {tol!r}")
            if not any(values.values()):
                raise ScenarioError(f"{self.path}: {field} = {tol!r} allows no error at all, which no computation "
                                    "meets (round-off differs between any two): give the accuracy the study needs "
                                    "(`ujfmu run --check-step` estimates this step's)")
            if values.get("rel_range", 0.0) >= MAX_REL_RANGE:
                raise ScenarioError(f"{self.path}: {field}: rel_range = {values['rel_range']:g} allows an error of "
                                    f"{values['rel_range']:g} of the signal's range, which a flat line through the "
                                    "middle of the range passes: it checks nothing of the signal's course; give the "
                                    "accuracy the study needs (`ujfmu run --check-step` estimates this step's)")
            tolerances[name] = Tolerance(**values)
        return tolerances

    def _table(self, data, key):
        if not isinstance(data.get(key), dict):
            raise ScenarioError(f"{self.path}: missing table [{key}]")
        return data[key]

    def _number(self, table, field, default=None):
        value = table.get(field.split(".")[-1], default)
        if value is None:
            raise ScenarioError(f"{self.path}: {field} is missing: give it a number (seconds)")
        if not isinstance(value, (int, float)) or isinstance(value, bool) or not math.isfinite(value):
            raise ScenarioError(f"{self.path}: {field} = {value!r} must be a finite number")
        return float(value)

    def _check_signal(self, name, field, causality=None):
        comp, _, var = (name or "").partition(".")
        if comp not in self.components:
            raise ScenarioError(f"{self.path}: {field} = {name!r}: unknown component '{comp}'")
        variables = {v.name: v for v in fmu_class(self.components[comp][0]).VARIABLES}
        if var not in variables:
            kinds = [causality] if causality else ["output", "input"]
            offered = [n for n, v in variables.items() if v.causality in kinds]
            close = difflib.get_close_matches(var, offered, n=1)
            raise ScenarioError(f"{self.path}: {field} = {name!r}: {self.components[comp][0]} has no variable "
                                f"'{var}'{f' (did you mean {comp}.{close[0]}?)' if close else ''}; its "
                                f"{' and '.join(k + 's' for k in kinds)}: {', '.join(offered)}")
        if causality and variables[var].causality != causality:
            fmu = self.components[comp][0]
            wiring = ""
            if var in ("omega_in", "tau_in") and fmu.endswith("TorqueDriven"):
                wiring = (f" ({fmu} is the torque-driven variant: tau_in is its input and omega_in its output; wire a "
                          "MotorController's tau_motor to tau_in and its omega from omega_in, as the bundled "
                          "*_torque_driven scenarios do, or use the speed-driven "
                          f"{fmu.removesuffix('TorqueDriven')})")
            elif var in ("omega_in", "tau_in") and fmu + "TorqueDriven" in FMUS:
                wiring = (f" ({fmu} is driven by speed: omega_in is its input and tau_in its output; "
                          f"{fmu}TorqueDriven takes tau_in)")
            raise ScenarioError(f"{self.path}: {field} = {name!r} is an {variables[var].causality}, "
                                f"not an {causality}{wiring}")
        return variables[var]

    def check_fmus(self, fmu_dir=DEFAULT_FMU_DIR):
        """ScenarioError naming the component if an FMU file is missing, or holds another model than its name says
        (its modelDescription's modelName: a file copied over another), before anything runs."""
        for cname, (fmu, _) in self.components.items():
            path = Path(fmu_dir) / f"{fmu}.fmu"
            if not path.is_file():
                raise ScenarioError(f"{self.path}: components.{cname}.fmu = {fmu!r}: {path.absolute()} not found "
                                    f"({build_hint(fmu_dir)})")
            if not zipfile.is_zipfile(path):
                raise ScenarioError(f"{self.path}: components.{cname}.fmu = {fmu!r}: {path.absolute()} is not an "
                                    f"FMU (not a zip archive: truncated, or overwritten by another file); rebuild it "
                                    f"({build_hint(fmu_dir)})")
            model = description_attribute(path, "modelName")
            if model is not None and model != fmu:
                raise ScenarioError(f"{self.path}: components.{cname}.fmu = {fmu!r}: {path.absolute()} holds the "
                                    f"model {model!r} (its modelDescription.xml says so), not {fmu!r}: a file copied "
                                    f"or renamed over it; rebuild it ({build_hint(fmu_dir)})")
            built, now = stale_build(path, fmu)
            if built != now:
                raise ScenarioError(f"{self.path}: components.{cname}.fmu = {fmu!r}: {path.absolute()} was built from "
                                    f"other sources than this ujfmu's ({PACKAGE_DIR}): its build hash {built}, these "
                                    f"sources' {now} (the model's equations or the FMU layer changed since, or it was "
                                    f"built by another checkout, ujfmu or pythonfmu version); rebuild it "
                                    f"({build_hint(fmu_dir)}), so "
                                    "that what is checked is the code you have")
            edited = edited_members(path, fmu)
            if edited:
                raise ScenarioError(f"{self.path}: components.{cname}.fmu = {fmu!r}: {path.absolute()} was changed "
                                    f"after its build: {', '.join(edited[:3])}"
                                    + (f" and {len(edited) - 3} more" if len(edited) > 3 else "")
                                    + " differ from what a build from this ujfmu's sources ships (an FMU edited by "
                                    "hand, or another build's files copied into it); rebuild it "
                                    f"({build_hint(fmu_dir)}), so that what is checked is the code you have")

    def model_problems(self, component) -> list:
        """What the component's model refuses in its parameters as a whole (``MODEL.check``, which the FMU runs at
        initialization: e.g. a ramp to a negative speed), with the FMU's defaults for those not set; [] for an FMU
        without a model, or parameters its derived quantities fail on (its initialization reports those)."""
        return self._ask_model(component, "check")

    def model_advice(self) -> list:
        """'component: warning' for valid parameters that are likely not what was meant (``MODEL.advice``, which
        the FMU logs at initialization: e.g. a ring coupling's c_s left at the default ring's); where the speed of a
        Load's drive reaches rest within the run (a Motor's ramp from 0, a set speed of 0, a step or ramp between
        speeds from, to or through 0: a start, a hold at rest, a stop or a reversal), a Load that chatters as its
        shaft comes near rest (:meth:`load_chatter`, ``LOAD_CHATTER_ADVICE``; but where the implicit scheme
        iterates the loop, ``LoadChatter.iterated``); and a Load whose friction is smoothed
        at its drive's running speed (:meth:`smoothed_friction`), with one remedy for both where both apply."""
        smoothed = self._smoothed()
        chatter = [c for c in self.load_chatter() if c.ratio > LOAD_CHATTER_ADVICE
                   and not (c.iterated and self.coupling == "implicit")
                   and any(lo <= 0.0 <= hi for lo, hi in (self._drive_speeds(d)[1] for d in self._load_drives(c.load)))]
        both = {c.load: c for c in chatter if c.load in smoothed}
        return ([f"{name}: {message}" for name in self.components for message in self._ask_model(name, "advice")]
                + self._stepped_at_start() + self._launched_from_elsewhere() + self._sampled_loops()
                + [c.text() for c in chatter if c.load not in both]
                + [self._smoothed_text(load, *found, both.get(load)) for load, found in smoothed.items()])

    def _controlled_shafts(self) -> list:
        """[(controller, driven)]: each MotorController whose tau_motor feeds a component's tau_in (a torque-driven
        FMU's input shaft)."""
        feeds = {c.source: c.target for c in self.connections}
        pairs = []
        for name, (fmu, _) in self.components.items():
            driven, _, port = feeds.get(f"{name}.tau_motor", "").partition(".")
            if fmu == "MotorController" and port == "tau_in" and driven in self.components:
                pairs.append((name, driven))
        return pairs

    def _sampled_loops(self) -> list:
        """'controller: warning' for a MotorController whose PI, sampled at the step, cannot hold its loop:
        Kp h / J >= SAMPLED_LOOP_LIMIT, J the inertia its torque accelerates at once (the driven FMU's
        input shaft up to its first compliance, J_drive included: 1 / d(alpha_in)/d(tau_in) of its model), the
        smallest over a turn of the input shaft (a joint's reflected inertia swings with its angle), the sampled
        loop's pole 1 - Kp h / J then at or beyond -1 somewhere in the turn."""
        from .models.protocol import Torques
        found = []
        for name, driven in self._controlled_shafts():
            try:
                model, p = fmu_class(self.components[driven][0]).MODEL, self.model_parameters(driven)
                y = tuple(model.initial_state(p, self.start_time, Torques(0.0, 0.0)))
                inertias = []
                for k in range(SAMPLED_LOOP_ANGLES):   # the input angle (the state's first entry) over a turn
                    at = (y[0] + 2.0 * math.pi * k / SAMPLED_LOOP_ANGLES,) + y[1:]
                    accelerations = [model.derivatives(p, self.start_time, at, Torques(torque, 0.0))[1]
                                     for torque in (1.0, -1.0)]
                    inertias.append(2.0 / (accelerations[0] - accelerations[1]))
                inertia = min(inertias)
            except (ArithmeticError, ValueError, TypeError, IndexError):
                continue
            kp = float(self.parameters_with_defaults(name)["Kp"])
            ratio = kp * self.step_size / inertia
            if ratio >= SAMPLED_LOOP_LIMIT:
                found.append(f"{name}: its PI reads the speed once a step (a sampled controller): Kp h / J = "
                             f"{kp:g} x {self.step_size:g} / {inertia:.4g} = {ratio:.3g}, at or above "
                             f"{SAMPLED_LOOP_LIMIT:g}, where the sampled loop is unstable (J the inertia its torque "
                             f"accelerates at once: {driven}'s J_drive and input shaft, up to its first compliance; "
                             "where the step is long against that compliance's mode, the inertia behind it takes "
                             "part within a step, which may hold the loop: `ujfmu modes` gives the mode). "
                             "Explicitly coupled the run may grow, as a digital PI at this rate would; the implicit "
                             "scheme iterates the loop to a smoother one no such controller is. Lower Kp below "
                             f"{SAMPLED_LOOP_LIMIT * inertia / self.step_size:.4g} or the step below "
                             f"{SAMPLED_LOOP_LIMIT * inertia / kp:.3g} s")
        return found

    def _stepped_at_start(self) -> list:
        """'motor: warning' for a Motor whose step is at or before the start: its rotor starts at the profile's
        speed there (``initial_state``), omega_set, so what it drives starts turning with it: no launch (a
        MotorController's torque-driven shaft starts from its own omega_in_start instead)."""
        found = []
        for name, (fmu, _) in self.components.items():
            v = self.parameters_with_defaults(name) if fmu == "Motor" else {}
            if v and v["profile"] == 2 and v["t_step"] <= self.start_time and v["omega_set"] != v["omega_initial"]:
                found.append(f"{name}: its step profile steps at t_step = {v['t_step']:g} s, not after the start "
                             f"({self.start_time:g} s): the Motor starts at omega_set = {v['omega_set']:g} rad/s, what "
                             "it drives already turning with it (no step, no launch); for a step during the run, set "
                             "t_step after the start")
        return found

    def _launched_from_elsewhere(self) -> list:
        """'controller: warning' for a MotorController driving a torque-driven FMU's tau_in whose reference at the
        start differs from that FMU's omega_in_start: the input shaft starts there and the controller launches it (a
        run meant to start at speed starts at 0 rad/s, the default; the controller's omega_initial is its
        reference's only)."""
        found = []
        for name, driven in self._controlled_shafts():
            shaft = self.parameters_with_defaults(driven).get("omega_in_start")
            reference = self._reference_at(name, self.start_time)
            if shaft is not None and abs(reference - shaft) > 1e-6 * max(abs(reference), 1.0):
                found.append(f"{name}: its speed reference starts at {reference:g} rad/s, {driven}'s input shaft at "
                             f"omega_in_start = {shaft:g} rad/s: the controller launches the shaft from there (for a "
                             f"run at speed from the start, set {driven}.omega_in_start = {reference:g}; a "
                             "MotorController's omega_initial sets its reference, not the shaft it drives)")
        return found

    def _reference_at(self, drive: str, t: float) -> float:
        """The speed reference [rad/s] of a Motor's or MotorController's profile at time t: constant, a ramp from
        rest at t = 0, a step at t_step (omega_set from it on), a slew from omega_initial at t_step, at accel."""
        v = self.parameters_with_defaults(drive)
        profile, target = v["profile"], float(v["omega_set"])
        if profile == 0:
            return target
        if profile == 2:
            return float(v["omega_initial"]) if float(v["t_step"]) > t else target
        t0, initial = (0.0, 0.0) if profile == 1 else (float(v["t_step"]), float(v["omega_initial"]))
        change = target - initial
        return initial + math.copysign(min(abs(change), float(v["accel"]) * max(0.0, t - t0)), change)

    def smoothed_friction(self) -> list:
        """'load: warning' for each Load with a constant torque (T0, or T0 + T_change where larger) whose smooth
        sign s = omega / sqrt(omega^2 + omega_smooth^2) is below ``SMOOTH_SIGN`` at a speed its drive settles at
        within the run (its set speed, or a step's first speed; rest is :meth:`load_chatter`'s): the friction there
        is s T0, not T0."""
        return [self._smoothed_text(load, *found) for load, found in self._smoothed().items()]

    def _smoothed(self) -> dict:
        """{load: (speed's name, speed, smooth sign, torque, torque's name)} of :meth:`smoothed_friction`."""
        found = {}
        for name, (fmu, _) in self.components.items():
            law = self.parameters_with_defaults(name) if fmu == "Load" else {}
            if not law or not law["omega_smooth"] > 0.0:
                continue
            # the torques the run meets: T0 before the change, T0 + T_change from it (a change within the run)
            met = ([(law["T0"], "T0")] if not law.get("T_change") or law["t_change"] > self.start_time else []) + \
                  ([(law["T0"] + law["T_change"], "T0 + T_change")] if law.get("T_change") and
                   law["t_change"] < self.stop_time else [])
            torque, named = max(met, key=lambda item: abs(item[0])) if met else (0.0, "T0")
            speeds = [(f"{drive}.{label}", abs(speed)) for drive in self._load_drives(name)
                      for label, speed in self._drive_speeds(drive)[0] if speed]
            if not torque or not speeds:
                continue
            where, speed = min(speeds, key=lambda item: item[1])
            sign = speed / math.hypot(speed, law["omega_smooth"])
            if sign < SMOOTH_SIGN:
                found[name] = (where, speed, sign, torque, named)
        return found

    def _smoothed_text(self, load: str, where: str, speed: float, sign: float, torque: float, named: str,
                       chatter: "LoadChatter | None" = None) -> str:
        """The advice of :meth:`smoothed_friction` for one Load; with its chatter near rest (:meth:`load_chatter`),
        one remedy for both (a wider omega_smooth would cure the chatter and smooth the friction more)."""
        smooth = self.parameters_with_defaults(load)["omega_smooth"]
        text = (f"{load}: its constant torque {named} = {torque:g} N.m reverses smoothly within omega_smooth = "
                f"{smooth:g} rad/s of rest (s = omega / sqrt(omega^2 + omega_smooth^2)): at {where} = {speed:g} rad/s "
                f"it gives {sign:.3g} {named}, not {named}, and less where a joint slows the shaft within a "
                f"revolution. For the full torque there, lower omega_smooth to at most {speed / 10:.3g} rad/s "
                "(0.995 of it)")
        if chatter is None:
            return text + "; a shaft that stops then needs a smaller step, which `ujfmu run` names"
        return text + (f", with a step of at most {chatter.inertia * speed / 10 / abs(torque):.3g} s: where its "
                       f"drive passes rest, one step of it moves {chatter.driven}'s output inertia J = "
                       f"{chatter.inertia:g} kg.m2 by {named} h / J, which must stay below omega_smooth, or the "
                       "torque reverses at every step (chatter)")

    def _load_drives(self, load: str) -> list:
        """The drive (Motor, MotorController) whose speed the Load's shaft follows, as a list: the one feeding its
        omega, or, through each machine whose omega_out feeds it, the one upstream (by the machine's omega_in, or by
        its tau_in from a MotorController's tau_motor); none where the wiring leads elsewhere."""
        drives = {name for name, (fmu, _) in self.components.items() if fmu in ("Motor", "MotorController")}
        feeds = {c.target: c.source for c in self.connections}
        source, seen = feeds.get(f"{load}.omega", ""), set()
        while source and source not in seen:
            seen.add(source)
            component, _, port = source.partition(".")
            if component in drives and port == "omega":
                return [component]
            if port != "omega_out":
                return []
            driver, _, out = feeds.get(f"{component}.tau_in", "").partition(".")
            if driver in drives and out == "tau_motor":
                return [driver]
            source = feeds.get(f"{component}.omega_in", "")
        return []

    def _drive_speeds(self, drive: str) -> tuple:
        """([(parameter, speed)] the drive's profile settles at within [start_time, stop_time], (lowest, highest)
        speed it takes there): a step's or slew's omega_initial where t_step is after the start, the omega_set a
        profile reaches by the stop (a ramp or slew that has not reached it settles at no speed), and the range from
        the speed at the start to the speed at the stop."""
        v = self.parameters_with_defaults(drive)
        profile, target = v["profile"], float(v["omega_set"])
        start, stop = self.start_time, self.stop_time
        if profile == 0:
            return [("omega_set", target)], (target, target)
        if profile == 2:
            t_step, initial = float(v["t_step"]), float(v["omega_initial"])
            taken = ([("omega_initial", initial)] if t_step > start else []) + \
                    ([("omega_set", target)] if t_step < stop else [])
            speeds = [speed for _, speed in taken] or [target]
            return taken, (min(speeds), max(speeds))
        # a ramp from rest at t = 0, or a slew from omega_initial at t_step: piecewise linear at accel
        t0, initial = (0.0, 0.0) if profile == 1 else (float(v["t_step"]), float(v["omega_initial"]))
        change, accel = target - initial, float(v["accel"])
        settled = ([("omega_initial", initial)] if profile == 3 and t0 > start else []) + \
                  ([("omega_set", target)] if accel * max(0.0, stop - t0) >= abs(change) else [])
        ends = self._reference_at(drive, start), self._reference_at(drive, stop)
        return settled, (min(ends), max(ends))

    def load_chatter(self) -> list:
        """``LoadChatter`` of each Load fed from a component's ``omega_out`` whose model has an output inertia of
        its own (the protocol's ``free_output_inertia``), or whose output follows its input (:meth:`_input_inertia`:
        the load then acts on the driver's inertia): one step of the Load's constant torque T0 moves that inertia
        by T0 h / J, and where that exceeds omega_smooth, the band within which T0 reverses, a shaft near rest sees
        the torque reverse at every step (README, "Port and sign conventions"); T0 the larger of its values before
        and after a change (T_change)."""
        found = []
        for conn in self.connections:
            load, _, port = conn.target.partition(".")
            driven, _, out = conn.source.partition(".")
            if port != "omega" or out != "omega_out" or self.components.get(load, ("",))[0] != "Load":
                continue
            inertia, holder, gain, iterated = self._ask_model(driven, "free_output_inertia"), "", 0.0, False
            if not (isinstance(inertia, numbers.Real) and inertia > 0.0):
                inertia, holder, gain, iterated = self._input_inertia(driven)
            law = self.parameters_with_defaults(load)
            changed = law.get("T_change", 0.0) > 0.0
            torque = law["T0"] + law.get("T_change", 0.0) if changed else law["T0"]
            if iterated:   # a load the drive may not break away (a stall at rest) rings at the step rate still
                iterated = torque <= BREAKAWAY_SHARE * self._drive_limit(driven)
            if isinstance(inertia, numbers.Real) and inertia > 0.0 and torque > 0.0:
                reach = LoadChatter.reach_of(torque, self.step_size, inertia, gain)
                found.append(LoadChatter(load, driven, inertia, float(torque), float(law["omega_smooth"]),
                                         self.step_size, reach / law["omega_smooth"],
                                         "T0 + T_change" if changed else "T0", holder, gain, iterated))
        return found

    def _driving_motor(self, component) -> str:
        """The Motor whose omega drives the component's omega_in, "" without one."""
        for conn in self.connections:
            motor, _, out = conn.source.partition(".")
            if conn.target == f"{component}.omega_in" and out == "omega" and self.components[motor][0] == "Motor":
                return motor
        return ""

    def _drive_limit(self, component) -> float:
        """The torque limit tau_max of the Motor that drives the component's omega_in (inf without one)."""
        motor = self._driving_motor(component)
        return float(self.parameters_with_defaults(motor)["tau_max"]) if motor else math.inf

    def _input_inertia(self, component) -> tuple:
        """(J, what it is, the gain Kp of a speed loop on it, whether the load reaches it through an input the
        implicit scheme iterates) that a load on the output of a component whose output follows its input acts on:
        its own driven input shaft's J_drive (a torque-driven FMU, its MotorController's loop left out: its torque
        is held over the step), or the rotor inertia J_rotor of the PI Motor that drives its omega_in, with its Kp,
        through the Motor's tau_load (not an ideal speed source, whose speed ignores any torque); (None, "", 0,
        False) otherwise."""
        own = self.parameters_with_defaults(component)
        if "J_drive" in own:
            return own["J_drive"], "its driven input shaft's J_drive", 0.0, False
        motor = self._driving_motor(component)
        drive = self.parameters_with_defaults(motor) if motor else {}
        if not motor or drive.get("ideal_speed_source", False):
            return None, "", 0.0, False
        fed_back = any(c.source == f"{component}.tau_in" and c.target == f"{motor}.tau_load" for c in self.connections)
        return drive["J_rotor"], f"{motor}'s rotor inertia J_rotor", float(drive.get("Kp", 0.0)), fed_back

    def _ask_model(self, component, what) -> list:
        model = getattr(fmu_class(self.components[component][0]), "MODEL", None)
        if model is None or not hasattr(model, what):
            return []
        try:
            return getattr(model, what)(self.model_parameters(component))
        except (ArithmeticError, ValueError):   # parameters the model cannot even derive from: the FMU names them
            return []

    def model_parameters(self, component):
        """The component's model's Parameters at its values here (``parameters_with_defaults``); ArithmeticError
        or ValueError where the model cannot derive from them (the FMU names them)."""
        model = fmu_class(self.components[component][0]).MODEL
        values = self.parameters_with_defaults(component)
        return model.Parameters(**{f.name: values[f.name] for f in dataclasses.fields(model.Parameters) if f.init})

    def parameters_with_defaults(self, component):
        """All parameter values of a component: the FMU's declared defaults updated by the scenario."""
        fmu, params = self.components[component]
        values = {v.name: v.start for v in fmu_class(fmu).VARIABLES if v.causality == "parameter"}
        values.update(params)
        return values

    @property
    def compares(self) -> bool:
        """Whether a run compares signals with a reference: a [reference] file and bands (a changed copy has no
        reference; ``run_scenario`` compares exactly then)."""
        return self.reference_file is not None and bool(self.tolerances)

    def check_experiment(self) -> None:
        """ScenarioError unless the experiment as it stands now (a caller may have set step_size, start_time or
        stop_time after loading) has finite times, step_size > 0 and stop_time > start_time a whole number of steps
        apart, as a file must, and steady_from is a finite number (None: unset, taken as 0) before stop_time."""
        for name in ("start_time", "stop_time", "step_size"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, numbers.Real) or not math.isfinite(value):
                raise ScenarioError(f"{self.path}: experiment {name} = {value!r} must be a finite number [s]")
            setattr(self, name, float(value))   # a numpy float32's arithmetic would stay in float32
        if self.steady_from is None:   # unset, as 0 is (a caller's None)
            self.steady_from = 0.0
        if (isinstance(self.steady_from, bool) or not isinstance(self.steady_from, numbers.Real)
                or not math.isfinite(self.steady_from)):
            raise ScenarioError(f"{self.path}: output steady_from = {self.steady_from!r} must be a finite number [s] "
                                "(0 or None: no steady window)")
        if not self.step_size > 0 or not self.stop_time > self.start_time:
            raise ScenarioError(f"{self.path}: experiment step_size = {self.step_size!r} s must be > 0 and stop_time "
                                f"= {self.stop_time!r} s after start_time = {self.start_time!r} s")
        if self.steady_from > self.start_time and not self.steady_from < self.stop_time:
            raise ScenarioError(f"{self.path}: output steady_from = {self.steady_from!r} s is not before stop_time = "
                                f"{self.stop_time!r} s: the steady window would be empty; set steady_from before it "
                                "(0 or None: no steady window) or run longer (Scenario.with_stop_time drops a window "
                                "the run ends before)")
        self._check_output_interval()
        self._check_steps()

    def _check_output_interval(self) -> None:
        """ScenarioError unless output_interval is a whole number of steps >= 1 (None, a caller's: every step)."""
        interval = self.output_interval
        if interval is not None and (isinstance(interval, bool) or not isinstance(interval, numbers.Integral)
                                     or interval < 1):
            raise ScenarioError(f"{self.path}: experiment.output_interval = {interval!r} must be a whole number of "
                                "communication steps >= 1 (1: record every step)")

    def _check_steps(self) -> None:
        """ScenarioError unless stop_time - start_time is a finite whole number (1 to ``master.MAX_STEPS``) of
        steps of step_size, with two stop times that would be and a round step where it is not."""
        steps = (self.stop_time - self.start_time) / self.step_size
        if not steps <= MAX_STEPS:
            raise ScenarioError(f"{self.path}: [experiment] stop_time - start_time = "
                                f"{self.stop_time - self.start_time:g} s at step_size = {self.step_size:g} s is "
                                f"{steps:.3g} steps, more than the {MAX_STEPS:.0e} a run may take")
        if round(steps) < 1 or not math.isclose(round(steps), steps, rel_tol=1e-9, abs_tol=1e-9):
            span = self.stop_time - self.start_time
            hint = ""
            if span > 0.0:
                stops = dict.fromkeys(f"{self.start_time + n * self.step_size:.12g}"
                                      for n in (math.floor(steps), math.ceil(steps)) if n >= 1)
                hint = (f" (e.g. stop_time = {' or '.join(stops)} s, or a step_size that divides {span:g} s such as "
                        f"{_round_step(span, self.step_size):.12g} s)")
            raise ScenarioError(f"{self.path}: [experiment] stop_time - start_time = {span:g} s must be a whole "
                                f"number (at least 1) of communication steps of step_size = {self.step_size:.12g} s"
                                + hint)

    def time_grid(self):
        n = int(round((self.stop_time - self.start_time) / self.step_size))
        return self.start_time + self.step_size * np.arange(n + 1)

    def master_components(self, fmu_dir=DEFAULT_FMU_DIR):
        return [Component(name, Path(fmu_dir) / f"{fmu}.fmu", self.start_values(name))
                for name, (fmu, _) in self.components.items()]


def running_angle_of(scenario, running_speed: str) -> str:
    """The angle output of the shaft whose speed is running_speed (a Motor's phi for its omega, a machine's phi_in
    or phi_out for its omega_in or omega_out), "" where its component has none."""
    comp, _, var = (running_speed or "").partition(".")
    if comp not in scenario.components or not var.startswith("omega"):
        return ""
    angle = "phi" + var[len("omega"):]
    declared = {v.name: v for v in fmu_class(scenario.components[comp][0]).VARIABLES}
    return f"{comp}.{angle}" if angle in declared and declared[angle].causality == "output" else ""
