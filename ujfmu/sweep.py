"""Parameter sweeps: every point a full co-simulation of a scenario's FMUs run to steady state and reduced to
per-point figures, run on dask.distributed (a local pool of worker processes, or an existing cluster).

A point sets the swept parameters, co-simulates ``settle_time`` seconds, reads the running speed, then records
``revolutions`` whole revolutions of the outputs and reduces each to max, min, peak-to-peak, mean, RMS and the
amplitudes of chosen running-speed orders (least squares on the running angle, ``analysis.order_amplitudes``).
Steady state is checked, not assumed, and the settle time extended until it holds (``ujfmu.steady``: the figures
over the last quarter of the settle time agree within ``steady_tol``); so is the operating point (a Motor's speed
against its set point).
A point's status is ``ok``, ``not_steady``, ``off_target`` or ``error``. An order amplitude the step does not
resolve at the point's speed is NaN, with a note saying why (``steady.unresolved_orders``).

The FMUs go to each dask worker once (a WorkerPlugin writes them to a local folder), so a cluster needs no
shared file system; the workers need ujfmu installed. Resumable: every finished point is appended at once to
``<name>.jsonl`` next to the CSV; a rerun with the same settings, the same FMU builds and the same code (ujfmu
version and the modules of POINT_CODE) skips the points already there (failed points are tried again), so an
interrupted sweep loses nothing and a changed model or master never reuses stale points. A failing point is
recorded with its error and the sweep goes on. One journal holds one grid: a sweep of another grid under the same
name is refused (``SweepGridConflict``), so results of different grids never mix; the same axes in another order are
the same grid.

From Python (keyword arguments of ``SweepSettings.from_scenario`` override the scenario's [sweep] table)::

    scenario = Scenario("scenarios/double_cardan_omar_torsional.toml")
    sweep = Sweep(scenario, [Axis.span("motor.omega_set", 600, 700, 50, "rpm")],
                  SweepSettings.from_scenario(scenario, revolutions=2))
    sweep.run()            # local dask workers; no ``if __name__ == "__main__":`` guard needed
    rows = sweep.table()   # flat dicts, as the CSV
"""

import atexit
import contextlib
import copy
import csv
import difflib
import hashlib
import io
import itertools
import json
import math
import numbers
import os
import queue
import re
import signal
import sys
import threading
import time
import uuid
import warnings
import zipfile
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path

from .build import DEFAULT_FMU_DIR, build_hint, fmu_class
from .extras import require
from .master import (Component, Connection, Cosimulation, FmuWarning, RunStopped, made_here, remove_folder,
                     temporary_folder)
from .scenario import SWEEP_KEYS, Scenario, ScenarioError, file_name_problem, plain_number, running_angle_of
from .steady import (ERROR, FIGURES, FINAL, OK, PEAK_NOTE, PHASE_FLOOR, STATUSES, coupling_noise, grows,
                     settle_and_measure)

#: human units accepted after a --param range, and their factor to SI (rad and rad/s: the SI units, named)
UNITS = {"rpm": math.pi / 30.0, "deg": math.pi / 180.0, "rad": 1.0, "rad/s": 1.0, "": 1.0}
#: the declared (SI) unit a parameter must have for each human unit
UNIT_OF = {"rpm": "rad/s", "deg": "rad", "rad": "rad", "rad/s": "rad/s"}


def unit_problem(unit: str, declared: str | None) -> str:
    """'' if values given in unit (a key of UNITS) may set a parameter declared in declared (its SI unit), else
    why not: rpm converts to rad/s and deg to rad only; any other parameter takes SI values without a suffix."""
    if not unit or UNIT_OF[unit] == declared:
        return ""
    accepted = [u for u, si in UNIT_OF.items() if si == declared]
    takes = f"a suffix {' or '.join(accepted)} or none (SI)" if accepted else "SI values without a suffix"
    what = f"'{unit}' is {UNIT_OF[unit]}" if UNITS[unit] == 1.0 else f"'{unit}' converts to {UNIT_OF[unit]}"
    return f"{what}, but the parameter's unit is {declared or 'dimensionless'}; it takes {takes}"


#: the human unit a sweep axis can be given in, by the parameter's SI unit
HUMAN_UNIT = {"rad/s": "rpm", "rad": "deg"}


@dataclass
class Axis:
    """One sweep axis: the parameters it sets together (``component.parameter``) and their SI values.

    Build one with :meth:`span` or :meth:`of` (values in a human unit converted to SI); ``parse_axis`` makes one
    from the command line's text. :meth:`check` validates it against a scenario (Sweep does)."""
    names: tuple
    values: list
    unit: str = ""      # the human unit the values were given in ("rpm", "deg" or "")
    short_of: float = math.nan   # a span's STOP (in unit) when its steps end before it
    negated: tuple = ()   # the names after the first set to minus the axis's value (written -comp.par)

    @classmethod
    def of(cls, names, values, unit: str = "") -> "Axis":
        """An axis over the given values in unit ("rpm", "deg" or "" for SI); names: one ``component.parameter``
        or several set together (a sequence, or one string joined by commas as on the command line), any after the
        first written ``-component.parameter`` to set it to minus the value (beta2 = -beta1)."""
        names, negated = _signed(names)
        unit = unit.lower()
        if unit not in UNITS:
            raise ValueError(f"unknown unit {unit!r}: use 'rpm' or 'rad/s' (rad/s parameters), 'deg' or 'rad' (rad "
                             "parameters) or '' (SI)")
        if isinstance(values, (str, bytes)) or not hasattr(values, "__iter__") or getattr(values, "ndim", 1) == 0:
            raise ValueError(f"the axis of {', '.join(names)} takes a sequence of numbers, not {values!r}"
                             + ("" if isinstance(values, (str, bytes)) else f": give [{plain_number(values)!r}] for "
                                "one point"))
        values = [plain_number(v) for v in values]   # numpy numbers and bools as the Python ones they hold
        if not values:
            raise ValueError(f"the axis of {', '.join(names)} has no values: give at least one")
        rows = [isinstance(v, (tuple, list)) or getattr(v, "ndim", 0) == 1 for v in values]
        if any(rows):   # one row of values a point, a value per name: sampled points, not a grid
            if not all(rows) or negated or any(len(v) != len(names) for v in values):
                raise ValueError(f"an axis of rows gives each of its {len(names)} names a value in every row "
                                 f"(rows of {len(names)} numbers, no negated name)")
            return cls(names, [tuple(float(x) * UNITS[unit] for x in v) for v in values], unit)
        return cls(names, [v if isinstance(v, bool) else float(v) * UNITS[unit] for v in values], unit,
                   negated=negated)

    @classmethod
    def rows(cls, names, rows, unit: str = "") -> "Axis":
        """An axis of sampled points: each row sets every name to its own value (a Monte Carlo sample of several
        parameters; :meth:`of` with rows); a sweep over it runs the rows, not their grid."""
        names, negated = _signed(names)
        if negated:   # a row gives each name its own value, signs included
            raise ValueError(f"a sampled row sets {', '.join(negated)} to its own value: give it with its sign in the "
                             "rows, not a negated name")
        rows = [row.tolist() if hasattr(row, "tolist") else row for row in rows]
        if len(names) == 1:   # one name: a row may be its bare value
            rows = [row if isinstance(row, (list, tuple)) else [row] for row in rows]
        if not all(isinstance(row, (list, tuple)) and all(isinstance(x, numbers.Real) for x in row)
                   for row in rows):
            raise ValueError(f"rows of {len(names)} numbers, one per name ({', '.join(names)}), e.g. an N x "
                             f"{len(names)} array")
        return cls.of(names, [tuple(row) for row in rows], unit)

    @property
    def sampled(self) -> bool:
        """Whether the axis's values are rows, a value per name (:meth:`rows`)."""
        return bool(self.values) and isinstance(self.values[0], tuple)

    def assignments(self, value) -> dict:
        """{component.parameter: its value} at the axis's value (minus it for the negated names; for a Boolean axis
        the opposite; a row's own value per name)."""
        if isinstance(value, tuple):
            return dict(zip(self.names, value))
        other = (not value) if isinstance(value, bool) else -value
        return {name: other if name in self.negated else value for name in self.names}

    def value_of(self, point: dict):
        """The axis's value at a point of its sweep (the inverse of :meth:`assignments`)."""
        return tuple(point[name] for name in self.names) if self.sampled else point[self.names[0]]

    @property
    def signed_names(self) -> tuple:
        """The names as given: the negated ones with their '-'."""
        return tuple("-" + name if name in self.negated else name for name in self.names)

    @classmethod
    def span(cls, names, start: float, stop: float, step: float, unit: str = "") -> "Axis":
        """start, start + step, ... up to stop inclusive (to 1e-9 of a step), in unit (see :meth:`of`)."""
        if not step > 0 or stop < start:
            raise ValueError("need STEP > 0 and STOP >= START")
        count = int(math.floor((stop - start) / step + 1e-9)) + 1
        axis = cls.of(names, [start + k * step for k in range(count)], unit)
        if stop - (start + (count - 1) * step) > 1e-9 * step:
            axis.short_of = stop
        return axis

    @property
    def label(self):
        return ",".join(self.signed_names)

    def display(self, value):
        """value in the unit it was given in."""
        return value / UNITS[self.unit]

    def describe(self, scenario) -> str:
        """'count label first..last unit' in SI, with the human unit the values were given in, or a hint when a
        speed or angle was given without one (a plain number is taken as rad/s or rad)."""
        comp, _, par = self.names[0].partition(".")
        declared = {v.name: v for v in fmu_class(scenario.components[comp][0]).VARIABLES}
        if any(isinstance(v, bool) for v in self.values):
            return f"{len(self.values)} {self.label} {', '.join(str(v).lower() for v in self.values)}"
        if self.sampled:
            return f"{len(self.values)} sampled points of ({self.label})"
        si = declared[par].unit if par in declared and declared[par].unit != "1" else ""
        text = f"{len(self.values)} {self.label} {min(self.values):.4g}..{max(self.values):.4g} {si}".rstrip()
        if self.unit:
            text += f" (given as {self.display(min(self.values)):g}..{self.display(max(self.values)):g} {self.unit})"
        elif si in HUMAN_UNIT:
            text += f" (no unit after the values: taken as {si}; write e.g. ...{HUMAN_UNIT[si]} for {HUMAN_UNIT[si]})"
        if not math.isnan(self.short_of):
            last, unit = (self.display(max(self.values)), self.unit) if self.unit else (max(self.values), si)
            text += (f" (ends at {last:g} {unit}: STOP {self.short_of:g} {unit} is not START plus a whole number "
                     "of STEPs, and a range includes STOP only then)").replace("  ", " ").replace(" :", ":")
        return text

    def value_text(self, scenario, value: float) -> str:
        """One of the axis's values with its SI unit, and in the unit it was given in."""
        if isinstance(value, bool):
            return str(value).lower()
        comp, _, par = self.names[0].partition(".")
        declared = {v.name: v for v in fmu_class(scenario.components[comp][0]).VARIABLES}
        si = declared[par].unit if par in declared and declared[par].unit != "1" else ""
        text = f"{value:.6g} {si}".rstrip()
        return text + (f" ({self.display(value):.6g} {self.unit})" if self.unit else "")

    def problems(self, scenario, what: str = "") -> list:
        """Every reason the axis cannot run on scenario, each prefixed by what (default 'axis <label>'): a name that
        is not a parameter of a component of scenario, a unit suffix its unit does not take, values outside its
        declared range (the first named, the others counted)."""
        what = what or f"axis {self.label}"
        found = []
        for name in self.names:
            comp, _, par = name.partition(".")
            if comp not in scenario.components:
                found.append(f"{what}: {scenario.path} has no component '{comp}' "
                             f"(it has {', '.join(scenario.components)})")
                continue
            fmu = scenario.components[comp][0]
            declared = {v.name: v for v in fmu_class(fmu).VARIABLES if v.causality == "parameter"}
            if par not in declared:
                other = next((v.causality for v in fmu_class(fmu).VARIABLES if v.name == par), None)
                close = [] if other else ([n for n in declared if n.lower() == par.lower()]
                                          or difflib.get_close_matches(par, declared, n=1))
                found.append(f"{what}: {fmu} has no parameter '{par}'"
                             + (f" (it is an {other}: a connection feeds it, or the scenario's inputs set it)"
                                if other == "input" else f" (it is an {other})" if other else "")
                             + f"{f' (did you mean {comp}.{close[0]}?)' if close else ''} (it has {', '.join(declared)})")
                continue
            problem = unit_problem(self.unit, declared[par].unit)
            if problem:
                found.append(f"{what}: {comp}.{par}: {problem}")
                continue
            var = declared[par]
            sign = -1.0 if name in self.negated else 1.0
            column = self.names.index(name)
            values = [v[column] for v in self.values] if self.sampled else self.values
            fed = {c.target for c in scenario.connections}
            reads = [f"{comp}.{v.name}" for v in fmu_class(fmu).VARIABLES
                     if v.causality == "input" and v.used_if == par and f"{comp}.{v.name}" not in fed]
            if reads and any(values):   # a Load's T_h reads its phi, which must then be connected
                found.append(f"{what}: {comp}.{par} != 0 reads {', '.join(reads)}, which {scenario.path} does not "
                             f"connect: connect it (e.g. from the machine's phi_out) in the scenario first")
            bad = [(v, p) for v, p in ((v, var.check(var.type(sign * v))) for v in values) if p]
            if bad:
                more = f" (and {len(bad) - 1} more of its {len(values)} values)" if len(bad) > 1 else ""
                value, problem = bad[0]
                if self.unit and math.isfinite(value):   # in the unit the values were given in, not a slip's hint
                    value *= sign
                    lo, hi = (infinity + "inf" if x is None else f"{self.display(x):.6g}"
                              for infinity, x in (("-", var.min), ("+", var.max)))
                    problem = (f"{par} = {self.display(value):.6g} {self.unit} ({value:.6g} {var.unit}) is outside "
                               f"its allowed range [{lo}, {hi}] {self.unit} ({var.range_text()})")
                found.append(f"{what}: {comp}.{problem}{more}")
        units = {}
        for name in self.names:   # every declared parameter's, whatever else is wrong with the axis
            comp, _, par = name.partition(".")
            if comp in scenario.components and _declared_type(scenario, name) is not None:
                units[name] = scenario.unit(name)
        if not self.sampled and len(set(units.values())) > 1:   # one value set into quantities of different units
            found.append(f"{what}: names set together take one value, but their units differ ("
                         + ", ".join(f"{name} [{unit or '1'}]" for name, unit in units.items())
                         + "): give each its own axis")
        if not self.sampled and len(set(_grid_values(self.values))) < len(self.values):
            found.append(f"{what}: a value repeats (each would run the same point again)")
        return found

    def check(self, scenario, what: str = "") -> None:
        """ScenarioError listing every problem of :meth:`problems` (prefixed by what, default 'axis <label>')
        unless every name is a parameter of a component of scenario and every value is within its declared
        range."""
        problems = self.problems(scenario, what)
        if problems:
            raise SweepSettingsError(problems)


class SweepSettingsError(ScenarioError):
    """Everything wrong with a sweep's axes and settings at once (``problems``), so that one run lists it all."""

    def __init__(self, problems: list):
        self.problems = list(problems)
        if len(self.problems) == 1:
            super().__init__(self.problems[0])
        else:
            super().__init__(f"{len(self.problems)} problems with the sweep's axes and settings:\n  - "
                             + "\n  - ".join(self.problems))


def _signed(names) -> tuple:
    """(names, negated) of an axis's names (a sequence, or one string joined by commas): each stripped, those after
    the first written ``-comp.par`` also in negated, without the '-'. ValueError for a negated first name (the first
    name's value is the axis's, in its table and plots) or a name given twice."""
    names = tuple(n.strip() for n in names.split(",")) if isinstance(names, str) else tuple(n.strip() for n in names)
    if names and names[0].startswith("-"):
        raise ValueError(f"the first name ({names[0]}) is the axis's own value and cannot be negated: put "
                         f"{names[0][1:]} after a name that takes the value as given, or negate the values")
    plain = tuple(n[1:].strip() if n.startswith("-") else n for n in names)
    twice = sorted({n for n in plain if plain.count(n) > 1})
    if twice:
        raise ValueError(f"{', '.join(twice)} named more than once in one axis")
    return plain, tuple(p for n, p in zip(names, plain) if n.startswith("-"))


#: an output whose order amplitudes are all below this share of its size carries no vibration the step check can
#: judge (an ideal speed source's speed, 1e-15 of itself; a twin rotor's tau_in without load or joint angle, 1e-7):
#: it leaves their orders out, as the table leaves out their phases (``steady.PHASE_FLOOR``)
ROUND_OFF_ORDERS = PHASE_FLOOR


def _csv_number(value) -> str:
    """A swept parameter's value in the CSV: a Boolean 1 or 0, a whole number as itself, a real number in full."""
    if isinstance(value, bool):
        return "1" if value else "0"
    return str(value) if isinstance(value, int) else repr(float(value))


def _grid_values(values: list) -> list:
    """An axis's values as its grid's identity takes them: numbers as floats (an Integer axis's 1 is the 1.0 it
    was before), Booleans as they are, a sampled row as its list of floats."""
    return [v if isinstance(v, bool) else [float(x) for x in v] if isinstance(v, tuple) else float(v)
            for v in values]


#: the values a Boolean parameter's axis takes (``parse_axis``)
_BOOLEANS = {"true": True, "false": False, "1": True, "0": False}


def _declared(scenario, name: str):
    """The declaration (``Var``) of the parameter ``component.parameter`` of scenario; None where it has none
    (:meth:`Axis.problems` says why)."""
    comp, _, par = name.partition(".")
    if comp not in scenario.components:
        return None
    return next((var for var in fmu_class(scenario.components[comp][0]).VARIABLES
                 if var.name == par and var.causality == "parameter"), None)


def _declared_unit(scenario, name: str) -> str | None:
    """The declared unit of the parameter ``component.parameter`` of scenario; None where it has none."""
    var = _declared(scenario, name)
    return None if var is None else var.unit


def _declared_type(scenario, name: str):
    """The type (float, int, bool) of the parameter ``component.parameter`` of scenario; None where it has none."""
    var = _declared(scenario, name)
    return None if var is None else var.type


def parse_axis(text: str, scenario, option: str = "--param") -> Axis:
    """``comp.par[,comp.par...]=START:STOP:STEP[unit]`` (inclusive) or ``=V1,V2,...[unit]``; unit rpm (for a
    parameter in rad/s) or deg (for one in rad), in any letter case. A name after the first written ``-comp.par``
    takes minus the value (``driveline.beta1,-driveline.beta2=10:30:5deg``: beta2 = -beta1). A Boolean parameter
    takes ``=true,false`` (or 1, 0; a negated one the opposite).

    scenario: a Scenario or the path of a scenario file. Values are checked against the parameters' declared
    ranges; a ScenarioError names the argument (as ``option``) otherwise.
    """
    scenario = scenario if isinstance(scenario, Scenario) else Scenario(scenario)
    names_text, sep, values_text = text.partition("=")
    if not sep:
        raise ScenarioError(f"{option} {text!r}: expected component.parameter=START:STOP:STEP")
    match = re.fullmatch(r"\s*(.*?)\s*(rpm|deg|rad/s|rad)?\s*", values_text, re.IGNORECASE)
    body, unit = match.group(1), (match.group(2) or "").lower()
    names = tuple(n.strip() for n in names_text.split(","))
    try:
        plain = _signed(names)[0]
    except ValueError as exc:
        raise ScenarioError(f"{option} {text!r}: {exc}") from None
    boolean = [name for name in plain if _declared_type(scenario, name) is bool]
    if boolean:
        if len(boolean) < len(plain) or unit or ":" in body:
            raise ScenarioError(f"{option} {text!r}: {', '.join(boolean)} take{'s' if len(boolean) == 1 else ''} "
                                "true or false: write COMP.PAR=true,false (no range, no unit; a Boolean parameter "
                                "and a number cannot share an axis)")
        try:
            values = [_BOOLEANS[x.strip().lower()] for x in body.split(",")]
        except KeyError:
            raise ScenarioError(f"{option} {text!r}: bad values {values_text!r}: {', '.join(boolean)} take"
                                f"{'s' if len(boolean) == 1 else ''} true or false (or 1, 0)") from None
        axis = Axis.of(names, values)
        axis.check(scenario, f"{option} {text!r}")
        return axis
    try:
        if ":" in body:
            start, stop, step = (float(x) for x in body.split(":"))
            axis = Axis.span(names, start, stop, step, unit)
        else:
            axis = Axis.of(names, [float(x) for x in body.split(",")], unit)
    except ValueError as exc:
        suffixes = "rpm or rad/s (rad/s parameters), deg or rad (rad parameters)"
        expected = (f"a number, optionally followed by {suffixes}" if option == "--set" else
                    f"numbers START:STOP:STEP or V1,V2,..., optionally followed by {suffixes}")
        why = f"({exc})"
        if re.search(r"[a-df-z]", body, re.IGNORECASE):   # a unit, or part of one (e: an exponent)
            declared = _declared_unit(scenario, plain[0]) if plain else None
            unit = f", {plain[0]} is " + (f"in {declared}" if declared and declared != "1" else "dimensionless") \
                if plain else ""
            why = f"(not a number: a unit other than those below? give SI values without one{unit})"
        raise ScenarioError(f"{option} {text!r}: bad values {values_text!r} {why}; expected {expected}, in any "
                            "case: 1000RPM is 1000rpm") from None
    if all(_declared_type(scenario, name) is int for name in plain):   # whole numbers, as the FMU declares them
        fractional = [v for v in axis.values if not float(v).is_integer()]
        if fractional:
            raise ScenarioError(f"{option} {text!r}: {', '.join(plain)} take{'s' if len(plain) == 1 else ''} whole "
                                f"numbers, not {fractional[0]:g}")
        axis.values = [int(v) for v in axis.values]
    axis.check(scenario, f"{option} {text!r}")
    return axis


def sweep_setup(scenario, specs, **overrides) -> tuple:
    """(axes, settings) of a sweep of scenario: specs are ``--param`` texts (``parse_axis``), overrides the
    keywords of ``SweepSettings.from_scenario``. Every axis and every setting is checked before one
    SweepSettingsError lists all that is wrong, so that one run shows every fix needed."""
    scenario = scenario if isinstance(scenario, Scenario) else Scenario(scenario)
    axes, problems = [], []
    if not specs:
        problems.append(f"{scenario.path}: nothing to sweep: give --param comp.par=START:STOP:STEP or [sweep] "
                        "params in the scenario")
    for spec in specs:
        try:
            axes.append(parse_axis(spec, scenario))
        except SweepSettingsError as exc:
            problems += exc.problems
        except ScenarioError as exc:
            problems.append(str(exc))
    names = [name for axis in axes for name in axis.names]
    twice = sorted({name for name in names if names.count(name) > 1})
    if twice:   # a later axis would overwrite an earlier one's values at every point
        problems.append(f"{', '.join(twice)} on more than one axis (--param): sweep each parameter on one")
    try:
        settings = SweepSettings.from_scenario(scenario, **overrides)
    except SweepSettingsError as exc:
        problems += exc.problems
    if problems:
        raise SweepSettingsError(problems)
    return axes, settings


#: the command-line option of each [sweep] setting, for messages
OPTION = {"settle_time": "--settle", "revolutions": "--revolutions", "steady_tol": "--steady-tol",
          "max_settle_time": "--max-settle"}


@dataclass
class SweepSettings:
    """What each point does; from the scenario's [sweep] table, overridden by the command line."""
    outputs: list
    running_speed: str
    settle_time: float
    revolutions: float = 4.0
    orders: tuple = (1, 2, 4)
    steady_tol: float = 1e-3            # 0: no steady-state check (a measurement during a transient)
    max_settle_time: float = None       # s; default 8x the first settle time
    operating_point: tuple = ()         # (signal, set point signal) pairs; default every Motor's and MotorController's omega, omega_ref
    operating_tol: float = 0.01         # relative to the set point
    running_angle: str = ""             # the running shaft's angle the orders' phases refer to ("": no phases)

    @classmethod
    def from_scenario(cls, scenario, **overrides) -> "SweepSettings":
        """Settings from the scenario's [sweep] table (optional), overridden by keyword arguments of the same
        names: outputs (default: the compared, else the recorded signals, but for those that grow in any steady
        state, ``steady.grows``: running angles, energy integrals), running_speed (default: [output]
        running_speed), settle_time [s] (needed), revolutions (default 4), orders (default (1, 2, 4) and the whole
        orders of the Loads' periodic torques, ``analysis.load_orders``). scenario: a Scenario or the path of a
        scenario file."""
        scenario = scenario if isinstance(scenario, Scenario) else Scenario(scenario)
        known = SWEEP_KEYS - {"params"}
        unknown = []
        for key in sorted(set(overrides) - known):
            close = difflib.get_close_matches(key, known, n=1)
            unknown.append(f"SweepSettings.from_scenario: no setting {key!r}"
                           + (f" (did you mean {close[0]!r}?)" if close else "")
                           + f"; the settings are {', '.join(sorted(known))}")
        if unknown:
            raise SweepSettingsError(unknown)
        table = dict(scenario.sweep)
        table.update({k: v for k, v in overrides.items() if v is not None})
        where = f"{scenario.path}: [sweep]"
        problems = []

        def number(key, default=None, test=lambda x: True, needs=""):
            value = table.get(key, default)
            field = f"{where} {key} ({OPTION[key]})"
            try:
                value = None if value is None else float(value)
            except (TypeError, ValueError):
                problems.append(f"{field} = {value!r} must be a number{needs}")
                return None
            if value is not None and not (math.isfinite(value) and test(value)):
                problems.append(f"{field} = {value:g} must be{needs}")
                return None
            return value

        outputs = list(table.get("outputs") or [name for name in scenario.tolerances or scenario.record
                                                 if not grows(name)])
        running_speed = table.get("running_speed") or scenario.running_speed
        if not running_speed:
            problems.append(f"{where} running_speed (or output.running_speed; --running-speed on the command "
                            "line, running_speed=... from Python) is needed to measure whole revolutions")
        for name in dict.fromkeys(outputs + ([running_speed] if running_speed else [])):   # each once
            try:
                scenario._check_signal(name, "sweep signal")
            except ScenarioError as exc:
                problems.append(str(exc))
            else:
                if name == running_speed and scenario.unit(name) != "rad/s":
                    problems.append(f"{where} running_speed (--running-speed) = {name} is in "
                                    f"{scenario.unit(name) or 'no unit'}, not rad/s: whole revolutions are counted "
                                    f"from a shaft's speed; this scenario's speeds: "
                                    f"{', '.join(scenario.speed_signals())}")
        settle = number("settle_time", test=lambda x: x >= 0, needs=" >= 0 [s]")
        if "settle_time" not in table:
            problems.append(f"{where} settle_time (--settle on the command line, settle_time=... from Python) "
                            "is needed: the time to reach steady state")
        revolutions = number("revolutions", 4.0, lambda x: x > 0, " > 0")
        tol = number("steady_tol", 1e-3, lambda x: x >= 0, " >= 0 (0: no steady-state check)")
        cap = number("max_settle_time", None, lambda x: settle is None or x >= settle,
                     f" >= settle_time ({settle:g} s)" if settle is not None else " a time [s]")
        from .analysis import load_orders
        forced = sorted({int(k) for loads in load_orders(scenario).values() for _, k in loads if k == int(k)})
        try:
            given = table.get("orders", tuple(sorted({1, 2, 4, *forced})))
            orders = tuple(int(k) for k in given)
            if not orders or any(k <= 0 for k in orders) or any(isinstance(k, bool) or k != int(k) for k in given):
                raise ValueError
        except (TypeError, ValueError):
            problems.append(f"{where} orders (--orders) = {table.get('orders')!r} must be positive whole numbers, "
                            "e.g. 1,2,4")
            orders = ()
        if problems:
            raise SweepSettingsError(problems)
        settings = cls(outputs, running_speed, settle, revolutions, orders)
        settings.steady_tol, settings.max_settle_time = tol, cap
        settings.running_angle = running_angle_of(scenario, running_speed)
        settings.operating_point = tuple((f"{name}.omega", f"{name}.omega_ref") for name, (fmu, _) in
                                         scenario.components.items() if fmu in ("Motor", "MotorController"))
        return settings

    def columns(self):
        phases = tuple(f"ph{k}" for k in self.orders) if self.running_angle else ()
        return [f"{out}.{fig}" for out in self.outputs
                for fig in FIGURES + tuple(f"h{k}" for k in self.orders) + phases]


@dataclass
class PointJob:
    """Everything a worker needs for the points of one sweep (picklable; no paths of the submitting machine)."""
    components: list      # (name, fmu name, parameters)
    connections: list     # (from, to)
    step_size: float
    settings: SweepSettings
    fmu_hashes: dict = field(default_factory=dict)
    coupling: str = "implicit"   # the scenario's [experiment] coupling


def run_point(job, point, fmu_blobs=None):
    """One sweep point: returns a record dict: figures, status ('ok', 'not_steady' or 'off_target' with the
    reason, see ``ujfmu.steady``; 'error' with the message) and the settle time used.

    point: {"comp.par": value}. The FMUs come from fmu_blobs ({fmu name: bytes}) when given, else from the
    folder this worker process received them in (``FmuInstaller``).
    """
    started = time.perf_counter()
    record = {"point": point, "status": OK, "error": ""}
    logged = []
    try:
        fmu_dir = _worker_fmu_dir(job.fmu_hashes, fmu_blobs)
        params = {}
        for name, value in point.items():
            comp, par = name.split(".", 1)
            params.setdefault(comp, {})[par] = value
        components = [Component(name, fmu_dir / f"{fmu}.fmu", {**parameters, **params.get(name, {})})
                      for name, fmu, parameters in job.components]
        s = job.settings
        signals = list(dict.fromkeys(s.outputs + [s.running_speed] + [x for pair in s.operating_point for x in pair]
                                     + ([s.running_angle] if s.running_angle else [])))
        with warnings.catch_warnings(record=True) as logged:   # the FMUs' warnings go into the record
            warnings.simplefilter("always", FmuWarning)
            with Cosimulation(components, [Connection(a, b) for a, b in job.connections], job.step_size,
                              signals, coupling=job.coupling) as cosim:
                record.update(settle_and_measure(cosim, s))
    except Exception as exc:  # a failing point is data, not the end of the sweep
        record.update(status=ERROR, error=f"{type(exc).__name__}: {exc}".replace("\n", " | ")[:2000],
                      repeatable=repeatable(exc))
    fmu = [str(w.message) for w in logged if issubclass(w.category, FmuWarning)]
    if fmu:
        record["warnings"] = " | ".join(dict.fromkeys(fmu))[:2000]
    for w in logged:   # the others as they would have been
        if not issubclass(w.category, FmuWarning):
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    record["wall_s"] = time.perf_counter() - started
    return record


class WorkerSetupError(RuntimeError):
    """A worker process could not take a point: the sweep's FMUs are not there (the cluster's, not the point's)."""


def repeatable(exc: BaseException) -> bool:
    """True for a point's failure that its configuration gives again (an FMU's refusal, a coupling going unstable, a
    figure that cannot be formed: the co-simulation is deterministic); False for what the machine or the cluster
    caused (a full disk, memory, a worker without the FMUs), anywhere in the chain of errors that raised it."""
    transient = (OSError, MemoryError, RunStopped, WorkerSetupError)
    seen = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, transient):
            return False
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return True


_WORKER_DIRS = {}


def _worker_fmu_dir(hashes, fmu_blobs=None):
    """The FMUs in this process: written once per content hash into a temporary folder, reused across points and
    removed when the process exits."""
    key = json.dumps(hashes, sort_keys=True)
    if key not in _WORKER_DIRS:
        if fmu_blobs is None:
            raise WorkerSetupError("this worker has not received the sweep's FMUs (FmuInstaller plugin missing)")
        if not _WORKER_DIRS:
            atexit.register(lambda: [remove_folder(d) for d in list(_WORKER_DIRS.values()) if made_here(d)])
        folder = temporary_folder("ujfmu_worker_fmus_")
        for name, blob in fmu_blobs.items():
            (folder / f"{name}.fmu").write_bytes(blob)
        _WORKER_DIRS[key] = folder
    return _WORKER_DIRS[key]


def fmu_installer(blobs, hashes):
    """A dask WorkerPlugin that writes the FMUs on every worker of the cluster, present and future, once (per
    worker process and FMU set: a second sweep's plugin of the same FMUs finds them written). Its name is the
    sweep run's own, so a sweep removes its plugin at its end (:func:`remove_fmu_installer`) without removing that
    of another sweep running on the same cluster."""
    from distributed import WorkerPlugin

    class FmuInstaller(WorkerPlugin):
        name = (f"ujfmu-fmus-{hashlib.sha256(json.dumps(hashes, sort_keys=True).encode()).hexdigest()[:16]}-"
                f"{uuid.uuid4().hex[:12]}")

        def setup(self, worker):
            _worker_fmu_dir(hashes, blobs)

    return FmuInstaller()


def install_fmus(client, plugin) -> None:
    """Register the FMU plugin (:func:`fmu_installer`) with the client's cluster; SweepWorkersUnfit naming the
    cause and the workers that are not running where the cluster cannot (a worker stuck as it closes answers no
    broadcast: the registration had ended in an internal error after the connection's timeout)."""
    try:
        within(WORKER_PROBE_TIMEOUT, lambda: client.register_plugin(plugin), "ujfmu-install-fmus")
    except Exception as exc:   # noqa: BLE001 (a CommClosedError, a timeout: the cluster's, named)
        try:
            workers = client.scheduler_info().get("workers", {})
        except Exception:   # noqa: BLE001 (the scheduler itself gone: the error above says so)
            workers = {}
        stuck = sorted(a for a, w in workers.items() if w.get("status", "running") != "running")
        raise SweepWorkersUnfit(
            f"the cluster could not install the sweep's FMUs on its workers ({type(exc).__name__}: {exc})"
            + (f"; not running: {', '.join(stuck)} (a worker that failed as it started, one without ujfmu say, can "
               "stay stuck closing and answer nothing)" if stuck else "")
            + ": restart the cluster's workers, each in an environment with ujfmu installed, or run the sweep on "
            "local workers (--workers N without --scheduler) or in this process (--workers 0)") from exc


def remove_fmu_installer(client, plugin) -> None:
    """Remove the sweep's FMU plugin from a cluster it does not end with it (``--scheduler``, a client given):
    the scheduler would otherwise send it to every worker that joins later, and a worker without ujfmu, unable to
    unpickle it, fails to start and stays stuck closing (the next sweep's registration then failed on it). The
    workers keep the FMUs they wrote. A removal that fails is a SweepWarning (the sweep's results stand); one the
    scheduler does not hold (its registration failed before it) is nothing to remove."""
    try:
        within(PLUGIN_REMOVAL_TIMEOUT, lambda: client.unregister_worker_plugin(plugin.name), "ujfmu-remove-fmus")
    except ValueError:   # the scheduler does not hold it
        pass
    except NoAnswer:   # the scheduler drops a plugin before it tells the workers: only a worker is not told
        warnings.warn(f"removing the sweep's FMU plugin {plugin.name} from the cluster was not confirmed in "
                      f"{PLUGIN_REMOVAL_TIMEOUT:g} s: a worker that answers nothing holds the scheduler's broadcast "
                      "(see the scheduler's log); the scheduler drops a plugin before it tells the workers, so a "
                      "worker that joins later does not receive it", SweepWarning, stacklevel=3)
    except Exception as exc:   # noqa: BLE001 (said; the points are computed and kept)
        warnings.warn(f"removing the sweep's FMU plugin {plugin.name} from the cluster failed "
                      f"({type(exc).__name__}: {exc}): if the scheduler still holds the plugin, it sends it to each "
                      "worker that joins, and one without ujfmu fails to start; restart the scheduler to clear it",
                      SweepWarning, stacklevel=3)


#: the modules that compute a point outside the FMUs: the master, the steady-state check, the reductions, this one
POINT_CODE = ("master.py", "steady.py", "analysis.py", "sweep.py")
#: the runtime package an FMU built by ujfmu ships: its name carries the FMU's build digest (``build.source_hash``)
_RUNTIME_ENTRY = re.compile(r"resources/(ujfmu_\w+_[0-9a-f]{10})_entry\.py")


def code_digest(package: Path = Path(__file__).parent) -> str:
    """SHA-256 (16 hex digits) of the ujfmu version and the sources of POINT_CODE as they are now: the points of
    a journal are reused only by the code that computed them."""
    from . import __version__
    digest = hashlib.sha256(__version__.encode())
    for name in POINT_CODE:
        digest.update(b"\0" + name.encode() + b"\0" + (package / name).read_bytes())
    return digest.hexdigest()[:16]


def fmu_build_digest(blob: bytes) -> str:
    """The build digest of an FMU file: the source hash (ujfmu version and the model's runtime sources) that a
    ujfmu build puts in its runtime package's name, so a rebuild of unchanged sources keeps it; the SHA-256 of the
    file for an FMU built otherwise."""
    with zipfile.ZipFile(io.BytesIO(blob)) as fmu:
        names = [m.group(1) for m in map(_RUNTIME_ENTRY.fullmatch, fmu.namelist()) if m]
    return names[0] if len(names) == 1 else hashlib.sha256(blob).hexdigest()[:16]


#: the error of an order amplitude a sweep's step check allows, as a fraction of the amplitude
STEP_CHECK_TOL = 0.02
#: a mode crossing within this fraction of its speed from a point of the grid is read there
CROSSING_READ = 0.01
#: points a span suggested to resolve a stepped-over crossing has (``SteppedOverCrossing``)
CROSSING_POINTS = 21


@dataclass
class SteppedOverCrossing:
    """An order of an output whose largest amplitude over the speeds read (one curve of the other axes' values) is
    at one of the two points between which a mode crossing lies, farther than ``CROSSING_READ`` from both (a Campbell
    diagram's crossing, ``analysis.Mode.critical_speed``): a resonance there peaks between the points, possibly far
    higher than read, by as much as the mode's damping lets it (``Sweep.stepped_over_crossings``)."""
    output: str
    order: int
    amplitude: float   # the largest read, in the output's unit
    unit: str
    component: str
    mode: float        # its natural frequency [rad/s]
    kind: str
    speed: float       # the crossing's running speed [rad/s]
    axis: "Axis"
    low: float         # the axis's values at the two points around the crossing (SI)
    high: float
    at: float          # the axis's value where the amplitude read is largest
    fixed: dict = field(default_factory=dict)   # the other axes' values of the curve

    @property
    def key(self) -> tuple:
        """The crossing and the curve: equal for the outputs peaking next to one crossing."""
        return (self.order, self.component, self.mode, self.axis.label, self.low, self.high,
                tuple(self.fixed.items()))

    def text(self, scenario, peers: list = ()) -> str:
        """What was read and where the crossing lies, with a span that resolves it; peers: the other outputs'
        orders at the same crossing (:attr:`key`), named in the same line."""
        def value(v):
            return self.axis.value_text(scenario, v)
        lo, hi = self.axis.display(self.low), self.axis.display(self.high)
        step = (hi - lo) / (CROSSING_POINTS - 1)
        where = "".join(f", {name} = {v:.6g}" for name, v in self.fixed.items())
        read = "; ".join(f"{c.output} {c.amplitude:.4g} {c.unit} at {value(c.at)}" for c in [self, *peers])
        return (f"the {self.order}x order of {', '.join(c.output for c in [self, *peers])} peaks next to the "
                f"crossing of {self.component}'s {self.mode:.5g} rad/s {self.kind} mode at a running speed of "
                f"{self.speed:.5g} rad/s{where}, which the grid steps over (its points {value(self.low)} and "
                f"{value(self.high)}; largest read, zero-to-peak: {read}): a resonance there peaks between them, "
                "possibly far higher than read (how much, the mode's damping sets, which the grid cannot tell); "
                f"sweep that span finely, e.g. --param {self.axis.label}={lo:.6g}:{hi:.6g}:{step:.3g}{self.axis.unit}")


@dataclass
class StepCheck:
    """A sweep's step-halving estimate at its peak point (``Sweep.step_check``): per figure (column, amplitude at
    the step, at half the step), the error at the step estimated as 2 |a(h) - a(h/2)| (exact for an error first
    order in the step, as the explicit coupling's; twice too large for a second-order one), against ``rel_tol`` of
    the amplitude at half the step."""
    point: dict
    step: float
    figures: list
    rel_tol: float
    status: str = OK
    error: str = ""
    units: dict = field(default_factory=dict)   # of the point's parameters and the figures' outputs, by name
    peaking: list = field(default_factory=list)   # the outputs whose largest order peaks at the point

    @staticmethod
    def estimate(coarse: float, fine: float) -> float:
        return 2.0 * abs(coarse - fine)

    @property
    def passed(self) -> bool:
        return self.status == OK and all(self.estimate(c, f) <= self.rel_tol * abs(f) for _, c, f in self.figures)

    def lines(self, scenario=None) -> list:
        """The report: the point (its angles in deg too, its speeds in rpm), then one line a figure, flagged HIGH
        where the estimate passes rel_tol. scenario: where ``units`` lacks a name's unit."""
        def unit(name):
            return self.units.get(name) or (scenario.unit(name) if scenario is not None else "")

        def value_text(name, value):
            text = f"{value:.6g}" + (f" {unit(name)}" if unit(name) not in ("", "1") else "")
            if unit(name) == "rad" and not isinstance(value, bool):
                text += f" ({math.degrees(value):.6g} deg)"
            elif unit(name) == "rad/s" and not isinstance(value, bool):
                text += f" ({value * 30.0 / math.pi:.6g} rpm)"
            return text
        where = ", ".join(f"{name} = {value_text(name, value)}" for name, value in self.point.items())
        of = f" of {', '.join(self.peaking)}" if self.peaking else ""
        head = (f"step check at the peak{of} ({where}): order amplitudes at {self.step:g} s against "
                f"{self.step / 2:g} s, error estimated as 2 |a(h) - a(h/2)| (allowed {100 * self.rel_tol:g}% of "
                "the amplitude)")
        if self.status != OK:
            return [head, f"  the run at half the step is {self.status}: {self.error}"]
        lines = [head]
        for column, coarse, fine in self.figures:
            error = self.estimate(coarse, fine)
            flag = "ok  " if error <= self.rel_tol * abs(fine) else "HIGH"
            lines.append(f"  {flag} {column:30s} {coarse:.5g} at h, {fine:.5g} at h/2: error about "
                         f"{100 * error / abs(fine):.3g}% ({error:.3g} {unit(column.rsplit('.', 1)[0])})")
        if not self.passed:
            lines.append("  the order amplitudes depend on the step: sweep at a smaller step (--step), or, where the "
                         "coupling is explicit, with the implicit scheme (the estimate is of the coupling's error as "
                         "much as of the FMUs')")
        return lines


class SweepGridConflict(ScenarioError):
    """The sweep's journal holds points of another grid; the message says how to keep both."""


class SweepBusy(ScenarioError):
    """Another process runs a sweep of the same name into the same folder now (its journal, CSV and figures)."""


#: seconds a dask sweep waits for a point before it looks for workers, and seconds without any worker after which
#: it stops (its workers died and none came back: they had kept the sweep waiting all night)
WORKER_CHECK, NO_WORKERS_TIMEOUT = 10.0, 120.0
#: seconds the workers of a cluster not started here have to answer ujfmu's check (``check_workers``) and the FMU
#: plugin's registration (``install_fmus``)
WORKER_PROBE_TIMEOUT = 60.0
#: seconds the removal of a sweep's FMU plugin from such a cluster may take after the sweep (``remove_fmu_installer``;
#: the scheduler drops it at once, then tells each worker)
PLUGIN_REMOVAL_TIMEOUT = 10.0


class SweepWorkersLost(ScenarioError):
    """Every dask worker of a sweep is gone and none came back; the finished points are in the journal."""


class SweepWarning(UserWarning):
    """What a sweep warns of that is not a point's: workers of several threads."""


class SweepWorkersUnfit(ScenarioError):
    """Workers of the cluster given (``--scheduler``, ``client=``) cannot run this sweep's points: ujfmu missing, of
    other code, or another Python than the FMUs' (checked before any point is sent)."""


class NoAnswer(Exception):
    """A call to the cluster (:func:`within`) gave neither a result nor an error in its time (dask's own timeouts
    are TimeoutErrors, raised as the call's error)."""


def within(seconds: float, call: Callable, name: str):
    """call() in a daemon thread: its result, or its exception raised here; NoAnswer after seconds without either
    (a cluster's call that a worker never answers waits for ever; the thread is left to it)."""
    answer = queue.SimpleQueue()

    def ask():
        try:
            answer.put((True, call()))
        except BaseException as exc:   # noqa: BLE001 (raised in the caller's thread)
            answer.put((False, exc))
    threading.Thread(target=ask, name=name, daemon=True).start()
    try:
        done, value = answer.get(timeout=seconds)
    except queue.Empty:
        raise NoAnswer(f"no answer in {seconds:g} s") from None
    if not done:
        raise value
    return value


def check_workers(client) -> list:
    """SweepWorkersUnfit naming each worker of the client's cluster that cannot import ujfmu, runs other ujfmu code
    (``code_digest``) or another Python minor version than this process (the FMUs' runtime); the notes for workers
    that can (a worker of several threads runs one point at a time in effect: the points share its GIL)."""
    def probe():   # pickled by value: it runs where ujfmu cannot be imported
        import sys
        try:
            from ujfmu.sweep import code_digest as digest
            return digest(), list(sys.version_info[:2]), ""
        except Exception as exc:   # noqa: BLE001 (reported, with the worker's address)
            return "", list(sys.version_info[:2]), f"{type(exc).__name__}: {exc}"

    ours, python = code_digest(), list(sys.version_info[:2])
    problems, notes = [], []
    workers = client.scheduler_info().get("workers", {})
    running = sorted(a for a, w in workers.items() if w.get("status", "running") == "running")
    if not running:
        return notes
    try:
        answers = within(WORKER_PROBE_TIMEOUT, lambda: client.run(probe, workers=running), "ujfmu-check-workers")
    except NoAnswer:
        raise SweepWorkersUnfit(f"the cluster's workers ({', '.join(running)}) did not answer ujfmu's check in "
                                f"{WORKER_PROBE_TIMEOUT:g} s: see their logs (a worker that cannot import ujfmu "
                                "may hang as it starts)") from None
    except Exception as exc:   # noqa: BLE001 (a worker that broke off as it was asked)
        raise SweepWorkersUnfit(f"the cluster's workers ({', '.join(running)}) could not be checked "
                                f"({type(exc).__name__}: {exc}): see their logs") from exc
    for address, (digest, version, error) in sorted(answers.items()):
        if error:
            problems.append(f"{address} cannot import ujfmu ({error}): install ujfmu in the workers' environment, "
                            "the same version as here (`pip install` from this repository)")
        elif version != python:
            problems.append(f"{address} runs Python {'.'.join(map(str, version))}, the FMUs' Python "
                            f"{'.'.join(map(str, python))}: start the workers with the same Python minor version")
        elif digest != ours:
            problems.append(f"{address} runs other ujfmu code (digest {digest}, here {ours}): install ujfmu from "
                            "the same source (the same commit) in the workers' environment")
    if problems:
        raise SweepWorkersUnfit("the cluster's workers cannot run this sweep: " + "; ".join(problems))
    threaded = sorted(a for a in running if workers[a].get("nthreads", 1) > 1)
    if threaded:
        notes.append(f"{len(threaded)} worker(s) run several threads (e.g. {threaded[0]}): a worker's threads share "
                     "one Python interpreter lock, so its points run no faster than one at a time; start workers "
                     "with `dask worker ADDRESS --nworkers N --nthreads 1`")
    return notes


class SweepWriteError(ScenarioError):
    """A sweep's journal, table or figure could not be written (a full disk); what was written before is kept."""


@contextlib.contextmanager
def _writing(what: str, path: Path):
    """SweepWriteError naming path and the system's reason where writing it fails (OSError: a full disk, no
    permission), instead of a traceback."""
    try:
        yield
    except OSError as exc:
        raise SweepWriteError(f"cannot write {what} {path}: {exc.strerror or exc} (a full disk?); the points "
                              "computed so far are in the journal: free the space and run the same sweep again, "
                              "which reuses them") from exc


def _replace_atomically(path: Path, write: Callable) -> None:
    """write(file) into path's sibling path.partial, then move it over path: a failed write (a full disk) leaves
    the previous file whole, never a truncated one that still reads."""
    partial = path.with_name(path.name + ".partial")
    try:
        with open(partial, "w", newline="") as f:
            write(f)
        os.replace(partial, path)
    finally:
        if partial.exists():
            partial.unlink()


@contextlib.contextmanager
def _sole_writer(lock_path: Path, journal: Path):
    """Hold an exclusive lock on lock_path (``fcntl.flock``, released by the system when the process ends, even
    killed) while the block runs; SweepBusy if another process holds it. Two sweeps of one name into one folder had
    both run, mixing two grids in one journal (every later run refused) or computing every point twice, and the
    CSV was the last finisher's. The lock file is removed when the block ends, while still locked; a process that
    locked a file removed since (it opened it before the removal) takes the lock again on the new one. Without fcntl
    (Windows) nothing is locked."""
    try:
        import fcntl
    except ImportError:
        yield
        return
    while True:
        handle = open(lock_path, "a")
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            handle.close()
            raise SweepBusy(f"another process is running a sweep into {journal} now: wait for it to finish, or give "
                            "this one another name (--name, or Sweep(..., name=...)) or folder (--out)") from None
        try:
            same = os.stat(lock_path).st_ino == os.fstat(handle.fileno()).st_ino
        except FileNotFoundError:
            same = False
        if same:
            break
        handle.close()   # the lock of a file its holder removed: lock the one at lock_path now
    try:
        yield
    finally:
        with contextlib.suppress(OSError):
            lock_path.unlink()
        handle.close()   # releases the lock


class Sweep:
    """A sweep of one scenario over a grid of axes; ``run()`` computes what the journal lacks, ``table()``."""

    def __init__(self, scenario, axes, settings, out_dir=Path("results"), name=None, fmu_dir=DEFAULT_FMU_DIR):
        self.scenario = scenario if isinstance(scenario, Scenario) else Scenario(scenario)
        self.axes, self.settings = list(axes), settings
        problems = [p for axis in self.axes for p in axis.problems(self.scenario)]
        if problems:
            raise SweepSettingsError(problems)
        self.name = name or f"{self.scenario.name}_sweep"
        if file_name_problem(self.name):
            raise ScenarioError(f"sweep name {file_name_problem(self.name)} in {out_dir}")
        self.out_dir = Path(out_dir)
        self.fmu_dir = Path(fmu_dir)
        self.csv = self.out_dir / f"{self.name}.csv"
        self.journal = self.out_dir / f"{self.name}.jsonl"
        #: the journal's lines the last reading (:meth:`done`) could not take as a point record
        self.damaged = 0
        self.points = [{name: value for v, ax in zip(combo, self.axes) for name, value in ax.assignments(v).items()}
                       for combo in itertools.product(*(ax.values for ax in self.axes))]
        resting = self._drives_at_rest()
        if resting:
            raise SweepSettingsError(resting)
        fmus = sorted({fmu for fmu, _ in self.scenario.components.values()})
        missing = [f for f in fmus if not (self.fmu_dir / f"{f}.fmu").is_file()]
        if missing:
            raise FileNotFoundError(f"FMU {', '.join(missing)} not found in {self.fmu_dir.absolute()} "
                                    f"({build_hint(self.fmu_dir)})")
        self.scenario.check_fmus(self.fmu_dir)   # each holds its model, built from these sources
        self.fmu_blobs = {f: (self.fmu_dir / f"{f}.fmu").read_bytes() for f in fmus}
        hashes = {f: hashlib.sha256(b).hexdigest()[:16] for f, b in self.fmu_blobs.items()}
        self.job = PointJob([(n, fmu, self.scenario.start_values(n)) for n, (fmu, _) in
                             self.scenario.components.items()],
                            [(c.source, c.target) for c in self.scenario.connections], self.scenario.step_size,
                            settings, hashes, self.scenario.coupling)
        # the grid whatever the order of its axes (the points are the same; the table and plots follow the order
        # given), and as journals before that recorded it (the axes in order)
        axes = [json.dumps([ax.signed_names, _grid_values(ax.values)]) for ax in self.axes]
        self.grid = hashlib.sha256(json.dumps(sorted(axes)).encode()).hexdigest()[:16]
        self._ordered_grid = hashlib.sha256(json.dumps([json.loads(a) for a in axes]).encode()).hexdigest()[:16]
        # results are only reused for the same FMU builds, code, scenario setup and settings
        builds = {f: fmu_build_digest(b) for f, b in self.fmu_blobs.items()}
        self.config = hashlib.sha256(json.dumps([asdict(settings), self.job.components, self.job.connections,
                                                 self.job.step_size, builds, self.job.coupling, code_digest()],
                                                sort_keys=True, default=str).encode()).hexdigest()[:16]

    def _drives_at_rest(self) -> list:
        """A problem for each drive of the operating point check (``SweepSettings.operating_point``) set to rest
        (omega_set = 0) at some point: its figures are measured over whole revolutions at its set speed, which a
        shaft at rest never completes, and no speed is within operating_tol of 0."""
        problems = []
        for signal, _ in self.settings.operating_point:
            comp = signal.partition(".")[0]
            name = f"{comp}.omega_set"
            if comp not in self.scenario.components:
                continue
            fixed = self.scenario.parameters_with_defaults(comp).get("omega_set")
            at_rest = [p for p in self.points if p.get(name, fixed) == 0]
            if at_rest:
                on_axis = name in self.points[0]
                where = f"at {len(at_rest)} of the {len(self.points)} points" if on_axis else "for every point"
                remedy = (f"start the axis at a speed, e.g. {name}=10:...rpm" if on_axis else
                          f"give the drive a speed (the scenario's {name}, or --set {name}=...)")
                problems.append(f"{name} = 0 {where}: a point's figures are measured over whole revolutions of "
                                f"the running speed at the drive's set speed, and a drive set to rest turns none "
                                f"(nor can its speed be within {100 * self.settings.operating_tol:g}% of 0): "
                                f"{remedy}; a run at rest is `ujfmu run {self.scenario.path} --set {name}=0`")
        return problems

    @staticmethod
    def key(point):
        """The journal's key of a point: its values to 12 significant digits, so that a grid made finer meets the
        points of the coarser one (0.3 * 3 and 0.1 * 9 differ in their last bits)."""
        return json.dumps({k: float(f"{float(v):.12g}") for k, v in sorted(point.items())})

    def done(self, others: set | None = None):
        """{point key: record} of the finished points in the journal made with the same configuration; others:
        a set that receives the keys of points the journal holds from another configuration (settings, FMU
        builds, code or scenario setup)."""
        records = {}
        self.damaged = 0
        if self.journal.is_file():
            for line in self.journal.read_text(errors="replace").splitlines():
                try:
                    record = json.loads(line)
                    if not isinstance(record, dict):
                        raise TypeError("not a record")
                    if (record.get("config") == self.config and record["status"] in STATUSES
                            and isinstance(record["error"], str) and isinstance(record.get("wall_s", 0.0), float)):
                        records[self.key(record["point"])] = record
                    elif (others is not None and record.get("config") != self.config
                          and isinstance(record.get("point"), dict)):
                        others.add(self.key(record["point"]))
                except (ValueError, TypeError, KeyError, AttributeError):   # a line cut by an interruption
                    self.damaged += line.strip() != ""                      # or not a point record: skipped
        return records

    def run(self, workers=None, scheduler=None, progress: Callable[[int, int], None] | None = None,
            client=None, extend: bool = False):
        """Run the missing points; returns the path of the CSV. workers: local worker processes (default: the
        number of cores); 0 runs the points in this process without dask. scheduler: address of an existing
        dask.distributed scheduler (its workers need ujfmu installed; the FMUs are sent to them). client: a
        dask.distributed Client to use instead (kept open). progress: optional callable(points_done,
        points_total), called as points finish (points reused from the journal count as done). extend: take over
        a journal of another grid over the same parameters (a grid made finer or wider): its points on this grid
        are reused, and its CSV and plots become this grid's (:meth:`_check_grid`)."""
        if client is None and (workers != 0 or scheduler is not None):
            require("distributed", "sweep", "Sweep.run with dask workers (sweep.run(workers=0) runs in this process "
                    "without it)")
        self.out_dir.mkdir(parents=True, exist_ok=True)
        with _sole_writer(self.out_dir / f"{self.name}.lock", self.journal):
            return self._run(workers, scheduler, progress, client, extend)

    def _run(self, workers, scheduler, progress, client, extend=False):
        """:meth:`run` as the journal's sole writer."""
        self._check_grid(extend)
        others = set()
        done = self.done(others)
        finished = {k for k, r in done.items() if r["status"] in FINAL or r.get("repeatable")}
        todo = [p for p in self.points if self.key(p) not in finished]
        self.reused = len(self.points) - len(todo)
        #: of those, the failed points whose failure the same configuration gives again (not rerun)
        self.reused_failures = sum(done[self.key(p)]["status"] == ERROR for p in self.points
                                   if self.key(p) in finished)
        #: points to run that the journal holds from another configuration only (recomputed, not reused)
        self.superseded = sum(self.key(p) in others for p in todo)
        count = [self.reused]
        if progress:
            progress(count[0], len(self.points))
        with open(self.journal, "a+b") as journal:
            journal.seek(0, os.SEEK_END)
            if journal.tell():
                journal.seek(-1, os.SEEK_END)
                if journal.read(1) != b"\n":   # a line cut by an interruption: end it, keep it unreadable
                    journal.write(b"\n")

            def keep(record):
                record["config"], record["grid"] = self.config, self.grid
                if record["status"] == ERROR and "coupling" in record["error"]:   # the wiring's remedy, as run's
                    from .scenario_run import torque_driven_hint
                    try:   # the point's own rotor inertia for the words
                        at = self.scenario.with_parameters(record["point"]) if record["point"] else self.scenario
                    except ScenarioError:
                        at = self.scenario
                    hint = torque_driven_hint(at, record["error"])
                    if hint:
                        record["error"] += " | " + hint
                with _writing("the journal", self.journal):
                    journal.write((json.dumps(record) + "\n").encode())
                    journal.flush()
                count[0] += 1
                if progress:
                    progress(count[0], len(self.points))

            try:
                if todo and workers == 0 and scheduler is None and client is None:
                    for point in todo:
                        keep(run_point(self.job, point, self.fmu_blobs))
                elif todo:
                    self._run_dask(todo, keep, workers, scheduler, client)
            except KeyboardInterrupt:   # the table of the points kept, the others missing, as the command's
                with contextlib.suppress(OSError, SweepWriteError):
                    self.write_csv()
                raise
        self.write_csv()
        return self.csv

    def _run_dask(self, todo, keep, workers, scheduler, client=None):
        own, futures, plugin = client is None, {}, None
        foreign = not (own and scheduler is None)   # a cluster not started here, from this environment
        if own:
            client = dask_client(workers, scheduler)
        try:
            if foreign:
                for note in check_workers(client):
                    warnings.warn(note, SweepWarning, stacklevel=4)
            # the FMUs travel once per worker in a plugin (not as scattered data, whose lifetime a shared client
            # and a long sweep make fragile); points then carry only their parameters
            plugin = fmu_installer(self.fmu_blobs, self.job.fmu_hashes)
            install_fmus(client, plugin)
            futures = {client.submit(run_point, self.job, point, pure=False): point for point in todo}
            # each future puts itself in the queue as it finishes (distributed.wait over the pending set had cost
            # the sweep's process a CPU time that grew with the points left, at every point)
            finished, alone_since, seen = queue.SimpleQueue(), None, bool(client.scheduler_info().get("workers"))
            for future in futures:
                future.add_done_callback(finished.put)
            left = len(futures)
            while left:
                try:
                    future = finished.get(timeout=WORKER_CHECK)
                except queue.Empty:   # nothing finished for a while: are there workers left to finish anything?
                    if client.scheduler_info().get("workers"):
                        alone_since, seen = None, True
                    elif alone_since is None:
                        alone_since = time.monotonic()
                    elif time.monotonic() - alone_since > NO_WORKERS_TIMEOUT and not seen:
                        raise SweepWorkersLost(
                            f"the dask cluster has had no worker since the sweep started ({NO_WORKERS_TIMEOUT:g} s "
                            "and more): start its workers (`dask worker ADDRESS --nworkers N --nthreads 1`, in an "
                            "environment with ujfmu installed) and run the same sweep again (--workers 0 runs it in "
                            "this process)") from None
                    elif time.monotonic() - alone_since > NO_WORKERS_TIMEOUT:
                        raise SweepWorkersLost(
                            f"no dask worker has been left for {NO_WORKERS_TIMEOUT:g} s (they died: killed, out of "
                            f"memory) with {left} of {len(futures)} points to run: the points finished are "
                            "in the journal; run the same sweep again, which reuses them (--workers 0 runs the "
                            "rest in this process)") from None
                    continue
                alone_since, left = None, left - 1
                try:
                    record = future.result()
                except Exception as exc:   # the worker itself died
                    record = {"point": futures[future], "status": ERROR, "wall_s": float("nan"),
                              "error": f"worker failed: {type(exc).__name__}: {exc}"}
                keep(record)
        finally:
            if not own:   # each callback holds its future: a shared cluster would run an interrupted sweep's rest
                unfinished = [f for f in futures if not f.done()]
                if unfinished:
                    client.cancel(unfinished)
            if foreign and plugin is not None:
                remove_fmu_installer(client, plugin)
            if own:
                close_client(client)

    def _check_grid(self, extend=False):
        """SweepGridConflict when the journal holds points of another grid (its CSV and plots would be replaced);
        with extend, a grid over the same parameters is taken over: every line of the journal becomes this grid's
        (its points on this grid are then reused; the others stay in the journal, out of the table)."""
        if not self.journal.is_file():
            return
        lines = []   # (line, its record where it is one)
        for line in self.journal.read_text(errors="replace").splitlines():
            try:
                record = json.loads(line)
            except json.JSONDecodeError:
                record = None
            lines.append((line, record if isinstance(record, dict) else None))
        mine = (self.grid, self._ordered_grid)
        others = [r for _, r in lines if r is not None and r.get("grid", self.grid) not in mine]
        if not others:
            return
        parameters = {frozenset(r["point"]) for r in others if isinstance(r.get("point"), dict)}
        same = parameters <= {frozenset(self.points[0])}
        if not extend or not same:
            raise SweepGridConflict(
                f"{self.journal} holds a sweep of {self.scenario.name} over another grid"
                + (f" over other parameters ({', '.join(sorted(set().union(*parameters)))}): --extend takes over a "
                   "grid over the same parameters only" if extend else "")
                + f": give this one another name (--name, or Sweep(..., name=...)) to keep both, or delete "
                f"{self.journal} to replace it" + ("; or, to make that grid finer or wider, --extend "
                                                   "(Sweep.run(extend=True)) reuses its points on this one"
                                                   if same and not extend else ""))
        taken = [json.dumps({**r, "grid": self.grid}) if r is not None and "grid" in r else line for line, r in lines]
        with _writing("the journal", self.journal):
            _replace_atomically(self.journal, lambda f: f.write("".join(line + "\n" for line in taken)))

    def records(self) -> list:
        """The journal records of the current grid, in grid order (axis values under "point"); missing points
        have status 'missing'."""
        done = self.done()
        return [done.get(self.key(p), {"point": p, "status": "missing", "error": ""}) for p in self.points]

    def table(self) -> list:
        """One flat dict a point, in grid order, as the CSV: the swept and fixed parameters by name (SI), status, the
        figures of every output (NaN for a point without them: failed or not run), speed_mean, settled_s,
        steady_change, wall_s, error, note, warnings, and the run's communication step_size and coupling (the
        record's "point" is kept as well)."""
        blank = dict.fromkeys(["speed_mean"] + self.settings.columns() + ["settled_s", "steady_change", "wall_s"],
                              math.nan)
        run = {"step_size": self.job.step_size, "coupling": self.job.coupling}
        return [{**r["point"], **self.fixed_parameters(), **blank, "note": "", "warnings": "",
                 **{k: v for k, v in r.items() if k not in ("config", "grid", "repeatable")}, **run}
                for r in self.records()]

    def fixed_parameters(self) -> dict:
        """{"component.parameter": value} of the parameters the scenario's copy changed from its file
        (``Scenario.changes``: ``--set``, ``with_parameters``) and no axis sweeps: every point's."""
        swept = {n for ax in self.axes for n in ax.names}
        return {k: v for k, v in self.scenario.changes.items() if k not in swept}

    def write_csv(self):
        """The tidy CSV: one row a point; swept parameters in SI units, the fixed ones changed from the scenario
        file (:meth:`fixed_parameters`, the same on every row), then the figures of every output."""
        fixed = self.fixed_parameters()
        param_cols = [n for ax in self.axes for n in ax.names]
        cols = ["speed_mean"] + self.settings.columns() + ["settled_s", "steady_change"]

        def write(f):
            writer = csv.writer(f)
            writer.writerow(param_cols + list(fixed) + ["status"] + cols
                            + ["wall_s", "error", "note", "warnings", "step_size", "coupling"])
            run = [repr(float(self.job.step_size)), self.job.coupling]
            fixed_values = [_csv_number(v) for v in fixed.values()]
            for record in self.records():
                writer.writerow([_csv_number(record["point"][n]) for n in param_cols] + fixed_values
                                + [record["status"]]
                                + [repr(record[c]) if c in record else "" for c in cols]
                                + [f"{record.get('wall_s', float('nan')):.3f}", record["error"],
                                   record.get("note", ""), record.get("warnings", "")] + run)
        with _writing("the table", self.csv):
            _replace_atomically(self.csv, write)
        self.write_columns()
        return self.csv

    #: what each figure of an output is (its column ``<output>.<figure>``), in that output's unit
    FIGURE_MEANINGS = {"max": "largest sample over the measured revolutions",
                       "min": "smallest sample over the measured revolutions",
                       "p2p": "max - min", "mean": "mean (least-squares fit of the orders against the running angle)",
                       "rms": "RMS, mean included: sqrt(mean^2 + sum of a_k^2 / 2 + the fit's residual mean square)"}

    def column_units(self) -> dict:
        """{CSV column: (unit, meaning)}: the swept parameters in their declared SI units, the figures of every output
        in the output's unit (an order's amplitude zero-to-peak), the bookkeeping columns in theirs ("" for none)."""
        columns = {}
        for axis in self.axes:
            boolean = any(isinstance(v, bool) for v in axis.values)
            for name in axis.names:
                columns[name] = ("", "swept parameter (1 true, 0 false)") if boolean else (
                    self.scenario.unit(name), "swept parameter (SI)")
        for name, value in self.fixed_parameters().items():
            columns[name] = (("", "fixed parameter changed from the scenario file (--set; 1 true, 0 false)")
                             if isinstance(value, bool) else
                             (self.scenario.unit(name), "fixed parameter changed from the scenario file (--set; SI)"))
        columns["status"] = ("", "ok, not_steady, off_target, error or missing")
        columns["speed_mean"] = ("rad/s", f"mean running speed ({self.settings.running_speed})")
        for column in self.settings.columns():   # <output>.<figure>, <output>.h<k>, <output>.ph<k>
            output, figure = column.rsplit(".", 1)
            if figure.startswith("ph"):
                columns[column] = ("rad", f"phase of the {figure[2:]}x running-speed order against the running "
                                          f"angle {self.settings.running_angle}: the signal ~ mean + sum_k h_k "
                                          "cos(k angle - ph_k), in (-pi, pi]")
                continue
            columns[column] = (self.scenario.unit(output), self.FIGURE_MEANINGS.get(figure) or
                               f"amplitude (zero to peak) of the {figure[1:]}x running-speed order")
        columns.update(settled_s=("s", "settle time used"),
                       steady_change=("1", "largest change of a figure between the last windows, of its size "
                                           "(0: every change within the coupling's resolution: "
                                           f"{coupling_noise(True):.2g} of the signal's size under the implicit "
                                           "scheme, none under the explicit one)"),
                       wall_s=("s", "wall time of the point"), error=("", "why the point is not ok"),
                       note=("", "what limits its figures"), warnings=("", "what its FMUs warned of"),
                       step_size=("s", "communication step of the co-simulation (every point's)"),
                       coupling=("", "coupling scheme: implicit (the steps iterate) or explicit"))
        return columns

    def write_columns(self) -> Path:
        """``<name>.columns.csv`` beside the table: column, unit, meaning, one row per column of the CSV, so a
        spreadsheet or a script reads the units with the numbers; returns its path."""
        path = self.csv.with_suffix(".columns.csv")

        def write(f):
            writer = csv.writer(f)
            writer.writerow(["column", "unit", "meaning"])
            writer.writerows([name, unit, meaning] for name, (unit, meaning) in self.column_units().items())
        with _writing("the columns file", path):
            _replace_atomically(path, write)
        return path

    def unresolved(self):
        """Records of the measured points whose order amplitudes are partly NaN, not resolved at their step and
        speed (the record's "note" says which and why: ``steady.unresolved_orders``)."""
        orders = [c for c in self.settings.columns() if c.rsplit(".", 1)[1].startswith("h")]
        return [r for r in self.table() if r.get("status") in FINAL and any(math.isnan(r[c]) for c in orders)]

    def coarse_peaks(self):
        """Records of the measured points whose max, min and p2p may fall short of the peaks by more than
        ``steady.PEAK_SHORTFALL`` (their note says how far, and the step that reads the peaks closely:
        ``steady.peak_note``)."""
        return [r for r in self.table() if r.get("status") in FINAL and PEAK_NOTE in r.get("note", "")]

    def stepped_over_crossings(self) -> list:
        """:class:`SteppedOverCrossing` of each output's order whose largest amplitude, over the ok points of a
        speed axis (rad/s; one curve per combination of the other axes, ordered by the running speed read, whose
        magnitude the axis must set, rising or falling), is at a point next to a crossing of that order with a
        natural frequency of the scenario's machines (``analysis.scenario_modes`` at the curve's parameters, and
        ``held_input_modes`` where a PI motor drives, the other bound of its closed loop's modes; the orders the
        mode's component carries) that lies between two points, farther than ``CROSSING_READ`` of its speed from
        both. Orders of round-off (below ``ROUND_OFF_ORDERS`` of the output's size) have no peak. The mode's damping
        is not known here, so a broad resonance is named too."""
        from .analysis import held_input_modes, scenario_modes
        speed_axes = [a for a in self.axes if not a.sampled and not any(isinstance(v, bool) for v in a.values)
                      and self.scenario.unit(a.names[0]) == "rad/s"]
        found = []
        for axis in speed_axes:
            others = [a for a in self.axes if a is not axis]
            curves = {}
            for row in self.table():
                if row["status"] == OK and not math.isnan(row.get("speed_mean", math.nan)):
                    key = tuple(json.dumps(a.value_of(row["point"]), default=str) for a in others)
                    curves.setdefault(key, []).append(row)
            for rows in curves.values():
                rows.sort(key=lambda r: abs(r["speed_mean"]))
                speeds = [abs(r["speed_mean"]) for r in rows]
                values = [axis.value_of(r["point"]) for r in rows]
                rising, falling = (all(op(b, a) for a, b in zip(values, values[1:]))
                                   for op in (float.__gt__, float.__lt__))
                if len(rows) < 2 or any(b <= a for a, b in zip(speeds, speeds[1:])) or not (rising or falling):
                    continue   # the axis does not set the running speed here
                point = {k: v for k, v in rows[0]["point"].items() if k not in axis.names}
                # a PI motor's loop puts each mode between its free and held input's: both bounds' crossings
                modes = scenario_modes(self.scenario, point) + held_input_modes(self.scenario, point)
                fixed = {a.label: a.value_of(point) for a in others}
                for output in self.settings.outputs:
                    size = max(max(abs(r[f"{output}.max"]), abs(r[f"{output}.min"])) for r in rows)
                    for order in self.settings.orders:
                        amplitudes = [r.get(f"{output}.h{order}", math.nan) for r in rows]
                        if all(math.isnan(a) for a in amplitudes):
                            continue
                        i = max((a, i) for i, a in enumerate(amplitudes) if not math.isnan(a))[1]
                        if not amplitudes[i] > ROUND_OFF_ORDERS * size:
                            continue
                        for mode in modes:
                            if order not in mode.orders:
                                continue
                            crossing = mode.critical_speed(order)
                            j = next((j for j in range(len(rows) - 1) if speeds[j] < crossing < speeds[j + 1]), None)
                            if (j is None or i not in (j, j + 1)
                                    or min(crossing - speeds[j], speeds[j + 1] - crossing) <= CROSSING_READ * crossing):
                                continue
                            found.append(SteppedOverCrossing(
                                output, order, amplitudes[i], self.scenario.unit(output), mode.component, mode.omega,
                                mode.kind.partition(",")[0], crossing, axis, *sorted((values[j], values[j + 1])),
                                values[i], fixed))
        return found

    def step_check(self, rel_tol: float = STEP_CHECK_TOL) -> "StepCheck | None":
        """The step-halving estimate of the order amplitudes' error at the peak of the sweep's first output
        (:meth:`step_checks` of that output alone); None without an ok point."""
        checks = self.step_checks(rel_tol, self.settings.outputs[:1])
        return checks[0] if checks else None

    def step_checks(self, rel_tol: float = STEP_CHECK_TOL, outputs=None) -> list:
        """The step-halving estimates of the order amplitudes' error at the sweep's peaks: for each output (default
        every one) the ok point where its largest order amplitude is largest (a resonance, where a step's or a
        coupling's error grows most), each such point once, is run again at half the step (in this process; their
        journal ``<name>_step_check.jsonl`` beside this one's), and every resolved order of every output that
        carries at least 1% of that output's largest is compared there (:class:`StepCheck`, naming the outputs
        that peak at it). An output whose orders are round-off at its peak (below ``ROUND_OFF_ORDERS`` of its size)
        has no peak to check. [] without an ok point."""
        ok = [r for r in self.table() if r["status"] == OK]
        peaks = {}   # the peak points' keys -> (row, outputs peaking there)
        for output in self.settings.outputs if outputs is None else outputs:
            columns = [c for c in self.settings.columns() if c.rsplit(".", 1)[0] == output
                       and c.rsplit(".", 1)[1].startswith("h")]
            if not ok or not columns:
                continue
            peak = max(ok, key=lambda r: max((r[c] for c in columns if not math.isnan(r[c])), default=-math.inf))
            largest = max((peak[c] for c in columns if not math.isnan(peak[c])), default=0.0)
            size = max(abs(peak[f"{output}.max"]), abs(peak[f"{output}.min"]))
            if outputs is None and not largest > ROUND_OFF_ORDERS * size:   # no vibration to peak
                continue
            key = json.dumps(peak["point"], sort_keys=True, default=str)
            peaks.setdefault(key, (peak, []))[1].append(output)
        if not peaks and ok and outputs is None:   # every output's orders round-off: the first output's peak,
            checks = self.step_checks(rel_tol, self.settings.outputs[:1])   # named as no output's
            for check in checks:
                check.peaking = []
            return checks
        return [self._step_check_at(peak, names, rel_tol) for peak, names in peaks.values()]

    def _step_check_at(self, peak: dict, peaking: list, rel_tol: float) -> "StepCheck":
        """:meth:`step_checks` at one peak point (its row; the outputs that peak there)."""
        half = copy.copy(self.scenario)
        half.step_size = self.scenario.step_size / 2.0
        axes = [Axis.of(axis.signed_names, [axis.value_of(peak["point"])]) for axis in self.axes]
        fine = Sweep(half, axes, self.settings, out_dir=self.out_dir, name=f"{self.name}_step_check",
                     fmu_dir=self.fmu_dir)
        fine.run(workers=0, extend=True)   # its own journal: the peak of another grid, or moved, is no conflict
        (row,) = fine.table()
        figures = []
        if row["status"] in FINAL:
            for output in self.settings.outputs:
                columns = [f"{output}.h{k}" for k in self.settings.orders]
                largest = max((abs(row[c]) for c in columns if not math.isnan(row[c])), default=0.0)
                size = max(abs(row[f"{output}.max"]), abs(row[f"{output}.min"]))
                if not largest > ROUND_OFF_ORDERS * size:   # a constant signal's orders are round-off
                    continue
                figures += [(c, peak[c], row[c]) for c in columns
                            if not (math.isnan(row[c]) or math.isnan(peak[c])) and abs(row[c]) >= 0.01 * largest]
        units = {name: self.scenario.unit(name) for name in [*peak["point"], *self.settings.outputs]}
        return StepCheck(peak["point"], self.scenario.step_size, figures, rel_tol, row["status"], row["error"],
                         units, peaking)

    def failed(self):
        """Records of the points that are not ok (failed, not steady, operating point missed or not run)."""
        return [r for r in self.table() if r["status"] != OK]

    def status_counts(self):
        """{status: number of points} of the current grid."""
        counts = {}
        for record in self.table():
            counts[record["status"]] = counts.get(record["status"], 0) + 1
        return counts

    def plot(self, out_dir=None):
        """Figures against the first axis (a swept speed if any): max/min of every output (one curve per
        combination of the other axes) and the running-speed order amplitudes (order tracks and a Campbell-style
        diagram), written to out_dir (default: next to the CSV; made where missing: before run(), the figures
        hold the model's natural frequencies alone). Returns the paths."""
        from .plotting import plot_sweep
        with _writing("the figures into", Path(out_dir or self.out_dir)):
            Path(out_dir or self.out_dir).mkdir(parents=True, exist_ok=True)
            return plot_sweep(self, Path(out_dir or self.out_dir))


#: dask settings of the local cluster's worker processes (given to them as they start; the caller's dask config,
#: the scheduler's, and a cluster given by its address or as a Client keep their own): no statistical profiler (it
#: samples the computing thread every 10 ms, for a dashboard the local cluster does not open) and the event loop's
#: monitors woken every second instead of every 20-500 ms. Each wake-up takes the GIL from the point being computed:
#: with dask's defaults a point took 1.2x its time in one process, with these about 1.05x (Omar's Fig. 4 sweep on 1
#: worker: 17.7-18.8 s of points against 14.8-16.0 s; 14.4-14.8 s in process; docs/performance.md).
LOCAL_WORKER_CONFIG = {"distributed.worker.profile.enabled": False, "distributed.admin.tick.interval": "1s",
                       "distributed.worker.memory.monitor-interval": "1s",
                       "distributed.admin.system-monitor.interval": "5s"}


def dask_client(workers=None, scheduler=None):
    """A dask.distributed Client: on the scheduler at that address, else on a new local cluster of worker
    processes (one thread each; default one per core). Both use dask's TLS settings from the dask config
    (``distributed.comm.tls.*``, ``distributed.comm.require-encryption``; docs/security.md): a cluster runs
    whatever its clients submit, so connect only to a trusted one."""
    from distributed import Client, LocalCluster, Security
    security = Security()   # from the dask config
    if scheduler:
        if security.require_encryption and not scheduler.startswith("tls://"):
            raise ScenarioError(f"--scheduler {scheduler!r}: the dask config requires encryption "
                                "(distributed.comm.require-encryption); give a tls:// address")
        try:
            return Client(scheduler, security=security)
        except (OSError, TimeoutError) as exc:   # nothing listening, a wrong address, a firewall
            raise ScenarioError(f"--scheduler {scheduler!r}: cannot reach a dask scheduler there ({exc}); start one "
                                "(`dask scheduler` prints its address) and its workers, or leave --scheduler out "
                                "to run on a local cluster (--workers N) or in this process (--workers 0)") from None
    import dask
    settings = copy.deepcopy(dask.config.config)   # the workers' own: this process's config stays as it is
    dask.config.set(LOCAL_WORKER_CONFIG, config=settings)
    with _main_script_hidden(), _interrupt_ignored():
        cluster = LocalCluster(n_workers=workers or os.cpu_count() or 1, threads_per_worker=1, processes=True,
                               dashboard_address=None, silence_logs=40, security=security,
                               config=settings,
                               # its HTTP routes on a free port: another cluster's 8787 had made dask warn
                               scheduler_kwargs={"dashboard_address": ":0"})
    return Client(cluster)


@contextlib.contextmanager
def _interrupt_ignored():
    """Start worker processes with Ctrl-C (SIGINT) ignored, a disposition they inherit and keep (Python installs
    its KeyboardInterrupt handler only where SIGINT is at its default): a terminal's Ctrl-C reaches the whole
    process group, and the workers had each printed their own traceback while the sweep's process closes them."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    before = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, before)


@contextlib.contextmanager
def _main_script_hidden():
    """Start worker processes without re-running the calling script in them.

    The workers start by "spawn", which imports the parent's main script (``__main__.__file__``) again in every
    worker: a script that calls ``Sweep.run()`` without an ``if __name__ == "__main__":`` guard would then start
    a sweep in each worker. The workers need nothing from the script (points run ``ujfmu.sweep.run_point``), so
    the script's path is hidden from multiprocessing while they start."""
    main = sys.modules.get("__main__")
    path = getattr(main, "__file__", None)
    if path is None or getattr(main, "__spec__", None) is not None:
        yield
        return
    del main.__file__
    try:
        yield
    finally:
        main.__file__ = path


def close_client(client):
    cluster = client.cluster
    client.close()
    if cluster is not None:
        cluster.close()
