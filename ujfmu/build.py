"""Build the FMUs: pythonfmu packaging plus what pythonfmu lacks (units, ranges, dependencies, InitialUnknowns,
documentation), all taken from each FMU class's ``VARIABLES`` declaration.

Packaging. pythonfmu imports the FMU's entry module by name into the host's one Python interpreter, which all
Python FMUs in a process share. So every FMU carries its own copy of the shared plumbing ``ujfmu.fmu`` and of its
own model's ``model.py`` and ``fmu.py`` (``ujfmu.models.<stem>``; no other model's code) in a package whose name
holds the FMU name and a hash of what it ships (``ujfmu_cardanjoint_<hash>``): two different FMUs, or two builds
of one FMU, never shadow each other's modules.
"""

import hashlib
import html
import importlib
import os
import shutil
import sys
import tempfile
import time
import uuid
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

from . import __version__
from .bibliography import BY_KEY, FMU_SOURCES, REFERENCES

PACKAGE_DIR = Path(__file__).resolve().parent
REPO_DIR = PACKAGE_DIR.parent   # the clone, for an editable install (the report and the benchmark use its files)
#: relative: fmus/ of the current directory, like the scenarios/ and results/ folders
DEFAULT_FMU_DIR = Path("fmus")

#: FMU name -> (model folder ujfmu/models/<stem>, class name in its fmu.py)
FMUS = {
    "CardanJoint": ("cardan_joint", "CardanJoint"),
    "Motor": ("motor", "Motor"),
    "Load": ("load", "Load"),
    "DoubleCardanDriveline": ("double_cardan_driveline", "DoubleCardanDriveline"),
    "TwinJeffcottRotor": ("twin_jeffcott_rotor", "TwinJeffcottRotor"),
    "RingCoupling": ("ring_coupling", "RingCoupling"),
    "CardanJointTorqueDriven": ("cardan_joint", "CardanJointTorqueDriven"),
    "DoubleCardanDrivelineTorqueDriven": ("double_cardan_driveline", "DoubleCardanDrivelineTorqueDriven"),
    "MotorController": ("motor", "MotorController"),
    "TwinJeffcottRotorTorqueDriven": ("twin_jeffcott_rotor", "TwinJeffcottRotorTorqueDriven"),
    "RingCouplingTorqueDriven": ("ring_coupling", "RingCouplingTorqueDriven"),
}

#: unit -> ((kg, m, s, rad) exponents, {display unit: factor})
UNITS = {
    "1": ((0, 0, 0, 0), {}),
    "s": ((0, 0, 1, 0), {"ms": 1.0e3}),
    "rad": ((0, 0, 0, 1), {"deg": 57.29577951308232}),
    "rad/s": ((0, 0, -1, 1), {"rpm": 9.549296585513721}),
    "rad/s2": ((0, 0, -2, 1), {}),
    "N.m": ((1, 2, -2, 0), {}),
    "kg.m2": ((1, 2, 0, 0), {}),
    "N.m.s/rad": ((1, 2, -1, -1), {}),
    "N.m/rad": ((1, 2, -2, -1), {}),
    "N.m.s2/rad2": ((1, 2, 0, -2), {}),
    "kg": ((1, 0, 0, 0), {}),
    "m": ((0, 1, 0, 0), {"mm": 1.0e3}),
    "N/m": ((1, 0, -2, 0), {}),
    "N.s/m": ((1, 0, -1, 0), {}),
    "Pa": ((1, -1, -2, 0), {"GPa": 1.0e-9}),
    "J": ((1, 2, -2, 0), {}),
    "m/s": ((0, 1, -1, 0), {}),
    "m/s2": ((0, 1, -2, 0), {}),
    "W": ((1, 2, -3, 0), {}),
}


def build_hint(fmu_dir) -> str:
    """The command that builds the FMUs into fmu_dir, for "not found" messages."""
    built = REPO_DIR / DEFAULT_FMU_DIR   # this checkout's (an editable install): where `ujfmu build` there put them
    if Path(fmu_dir).absolute() == DEFAULT_FMU_DIR.absolute():
        there = (f"; this checkout's are in {built}: --fmu-dir {built}" if (built / "Motor.fmu").is_file()
                 and built.resolve() != DEFAULT_FMU_DIR.resolve() else "")
        return ("run `ujfmu build` first, or give --fmu-dir DIR (from Python: fmu_dir=DIR) where they were built: "
                f"fmus/ is the current directory's{there}")
    if Path(fmu_dir).absolute() == (DEFAULT_FMU_DIR / "fmi3").absolute():
        return ("run `ujfmu build --fmi 3` first, or give --fmu-dir DIR (from Python: fmu_dir=DIR) where they were "
                "built")
    if Path(fmu_dir).suffix == ".fmu":
        return (f"{fmu_dir} names one FMU: give the folder that holds them all, e.g. --fmu-dir {Path(fmu_dir).parent} "
                "(from Python: fmu_dir=...)")
    if Path(fmu_dir).name == "fmi3":   # the FMI 3.0 FMUs' folder
        return (f"a folder named as the FMI 3.0 FMUs' is: `ujfmu build --fmi 3 --fmu-dir {fmu_dir}` builds them for "
                "an FMI 3.0 run (--fmi 3); an FMI 2.0 run takes the folder `ujfmu build` writes (fmus/ by default)")
    return f"run `ujfmu build --fmu-dir {fmu_dir}` first"


def fmu_class(name: str) -> type:
    """The FMU class of the FMU called name (a key of FMUS)."""
    stem, cls = FMUS[name]
    return getattr(importlib.import_module(f"ujfmu.models.{stem}.fmu"), cls)


#: the modules that write what an FMU ships besides its runtime sources (the modelDescription): in its build hash
WRITERS = (Path(__file__),)


def source_hash(stem: str) -> str:
    """Hash of everything an FMU of model stem ships: the version, the build digest of its runtime sources (which
    also tags the FMU's serialized states), pythonfmu's version (whose files it carries) and this module, which
    writes its modelDescription; so a changed model never reuses an old module name, and an FMU built before a
    change of any is found stale."""
    import pythonfmu

    from .fmu.base import sources_digest
    digest = hashlib.sha256(f"{__version__} {sources_digest(stem)} pythonfmu {pythonfmu.__version__}".encode())
    for path in WRITERS:
        digest.update(b"\0" + path.read_bytes())
    return digest.hexdigest()[:10]



def build_all(dest=DEFAULT_FMU_DIR, names=None):
    """Build the named FMUs (default: all) into dest; returns their paths."""
    return [build_fmu(name, dest) for name in (names or FMUS)]


def runtime_title(name: str, fmi3: bool = False) -> str:
    """The docstring of the runtime package of ujfmu's FMU ``name`` (its ``__init__.py``: ``stage_runtime``)."""
    return f"ujfmu {__version__} runtime for {name}.fmu" + (" (FMI 3.0)." if fmi3 else ".")


def stage_runtime(package: Path, title: str, files: list) -> Path:
    """An FMU's runtime package: folder package holding ``files`` (paths relative to ujfmu) under a docstring."""
    package.mkdir()
    (package / "__init__.py").write_text(f'"""{title}"""\n')
    for rel in files:
        (package / rel).parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(PACKAGE_DIR / rel, package / rel)
    return package


def entry_source(name: str, import_line: str) -> str:
    """The text of an FMI 2.0 FMU's pythonfmu entry point (``resources/<unique>_entry.py``): import_line
    imports its class from the runtime package."""
    return (f'"""pythonfmu entry point of {name}.fmu (generated by ujfmu.build)."""\n' + import_line + "\n"
            "# pythonfmu 0.7.0 executes this file again at every fmi2Instantiate and then releases a reference to\n"
            "# this module's globals that it never took; one more reference per execution keeps them alive.\n"
            'globals().setdefault("_PYTHONFMU_GLOBALS_REFS", []).append(globals())\n')


def shipped_entry(name: str, unique: str) -> str:
    """The entry point a build of ujfmu's FMU ``name`` (FMI 2.0) with runtime package ``unique`` ships."""
    stem, cls_name = FMUS[name]
    return entry_source(name, f"from {unique}.models.{stem}.fmu import {cls_name}\n")


def build_fmu(name, dest=DEFAULT_FMU_DIR, pass_through=False):
    """Build fmus/<name>.fmu and return its path; pass_through=True builds <name>PassThrough.fmu, the model's
    twin without physics (ujfmu.fmu.passthrough), for the benchmark's FMI call floor."""
    from pythonfmu.builder import FmuBuilder

    from .fmu.base import runtime_files

    stem, cls_name = FMUS[name]
    cls = fmu_class(name)
    import_line = None   # the shipped entry point (shipped_entry), or the pass-through twin's
    if pass_through:
        from .fmu.passthrough import pass_through as twin
        cls = twin(cls)
        import_line = (f"from {{unique}}.models.{stem} import fmu as _model\n"
                       f"from {{unique}}.fmu.passthrough import pass_through as _twin\n"
                       f"{name}PassThrough = _twin(_model.{cls_name})\n")
        name = f"{name}PassThrough"
    dest = Path(dest)
    dest.mkdir(parents=True, exist_ok=True)
    target = dest / f"{name}.fmu"
    unique = f"ujfmu_{name.lower()}_{source_hash(stem)}"
    with tempfile.TemporaryDirectory(prefix="ujfmu_build_") as tmp:
        stage = Path(tmp)
        package = stage_runtime(stage / unique, runtime_title(name), runtime_files(stem))
        entry = stage / f"{unique}_entry.py"
        entry.write_text(shipped_entry(name, unique) if import_line is None
                         else entry_source(name, import_line.format(unique=unique)))
        docs = stage / "documentation"
        docs.mkdir()
        (docs / "index.html").write_text(documentation_html(name, cls))
        sys.path.insert(0, str(stage))
        try:
            built = FmuBuilder.build_FMU(entry, dest=target, project_files=[package], documentation_folder=docs)
        finally:
            sys.path.remove(str(stage))
            for mod in [m for m in sys.modules if m == unique or m.startswith(unique + ".")
                        or m == entry.stem]:
                del sys.modules[mod]
    _rewrite_model_description(Path(built), cls, unique)
    return Path(built)


def _rewrite_model_description(fmu_path, cls, guid_key: str):
    """Add unit definitions, units, ranges, output dependencies and InitialUnknowns from cls.VARIABLES; the guid
    from guid_key (the FMU's runtime package name: its name and build hash) instead of pythonfmu's random one."""
    with zipfile.ZipFile(fmu_path) as zf:
        entries = {info: zf.read(info) for info in zf.infolist()}
    md_info = next(i for i in entries if i.filename == "modelDescription.xml")
    root = ET.fromstring(entries[md_info])
    declared = {v.name: v for v in cls.VARIABLES}

    units_used = sorted({v.unit for v in cls.VARIABLES if v.type is float})
    unit_defs = ET.Element("UnitDefinitions")
    for unit in units_used:
        exponents, display = UNITS[unit]
        u = ET.SubElement(unit_defs, "Unit", name=unit)
        base = {k: str(e) for k, e in zip(("kg", "m", "s", "rad"), exponents) if e}
        ET.SubElement(u, "BaseUnit", base)
        for dname, factor in display.items():
            ET.SubElement(u, "DisplayUnit", name=dname, factor=repr(factor))
    root.insert(list(root).index(root.find("CoSimulation")) + 1, unit_defs)
    root.set("guid", "{" + str(uuid.uuid5(uuid.NAMESPACE_URL, f"ujfmu/{guid_key}")) + "}")   # the same for a rebuild
    root.attrib.pop("generationDateAndTime", None)   # optional; the archive's dates are archive_date()
    root.set("generationTool", f"ujfmu {__version__} ({root.get('generationTool', 'pythonfmu')})")   # as FMI 3.0's
    root.set("version", __version__)
    cs = root.find("CoSimulation")   # UjfmuSlave saves, restores and serializes its whole state
    cs.set("canGetAndSetFMUstate", "true")
    cs.set("canSerializeFMUstate", "true")

    index = {}
    for i, sv in enumerate(root.find("ModelVariables"), start=1):
        var = declared[sv.get("name")]
        index[var.name] = i
        typed = sv[0]
        if var.type is float:
            typed.set("unit", var.unit)
        if var.type is not bool:
            for attr in ("min", "max"):
                if getattr(var, attr) is not None:
                    typed.set(attr, repr(var.type(getattr(var, attr))))
        if var.type is float and typed.get("start") is not None:
            typed.set("start", repr(float(var.start)))   # pythonfmu writes 16 digits; repr round-trips exactly

    structure = root.find("ModelStructure")
    for child in list(structure):
        structure.remove(child)
    outputs = [v for v in cls.VARIABLES if v.causality == "output"]
    if outputs:
        out_el = ET.SubElement(structure, "Outputs")
        for v in outputs:
            deps = " ".join(str(index[d]) for d in v.depends_on)
            ET.SubElement(out_el, "Unknown", index=str(index[v.name]), dependencies=deps)
        init_el = ET.SubElement(structure, "InitialUnknowns")
        for v in outputs:
            ET.SubElement(init_el, "Unknown", index=str(index[v.name]))

    ET.indent(root)
    entries[md_info] = b'<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="utf-8")
    write_archive(fmu_path, {info.filename: data for info, data in entries.items()})


#: the dates a zip file can hold (its DOS date field)
ZIP_DATES = ((1980, 1, 1, 0, 0, 0), (2107, 12, 31, 23, 59, 58))


def archive_date() -> tuple:
    """The date every file of an FMU archive carries: SOURCE_DATE_EPOCH's where it is set (the reproducible-builds
    convention: seconds since 1970, UTC), within the dates a zip file can hold; else 1980-01-01. ValueError naming the
    variable where it is set to anything but a whole number."""
    epoch = os.environ.get("SOURCE_DATE_EPOCH", "")
    if not epoch.strip():
        return ZIP_DATES[0]
    if not epoch.strip().isdigit():
        raise ValueError(f"SOURCE_DATE_EPOCH = {epoch!r} must be a whole number of seconds since 1970-01-01 UTC "
                         "(the reproducible-builds convention), or unset")
    seconds = min(int(epoch), 4354819199)   # 2107-12-31 23:59:59 UTC: gmtime of a far later time fails
    return min(max(time.gmtime(seconds)[:6], ZIP_DATES[0]), ZIP_DATES[1])


def write_archive(path, entries: dict) -> None:
    """The FMU archive at path of entries (file name -> bytes), reproducible: sorted by name, every file dated
    :func:`archive_date`, so that a build of the same sources gives the same bytes (a CI cache, a checksum)."""
    date = archive_date()
    partial = Path(path).with_name(Path(path).name + ".partial")   # an FMU there stays whole if writing fails
    with zipfile.ZipFile(partial, "w", zipfile.ZIP_DEFLATED) as zf:
        for name in sorted(entries):
            info = zipfile.ZipInfo(name, date_time=date)
            info.compress_type = zipfile.ZIP_DEFLATED
            info.external_attr = 0o100644 << 16   # a regular file, rw-r--r--
            zf.writestr(info, entries[name])
    os.replace(partial, path)


def documentation_html(name, cls):
    """documentation/index.html: equations and sources, variables with units, defaults and ranges, ports."""
    physics = cls.PHYSICS
    rows = {"parameter": [], "input": [], "output": []}
    for v in cls.VARIABLES:
        default = "" if v.start is None else html.escape(repr(v.start))
        deps = ", ".join(v.depends_on) if v.causality == "output" else ""
        rng = "" if v.causality == "output" else html.escape(v.range_text())
        rows[v.causality].append(
            f"<tr><td><code>{v.name}</code></td><td>{html.escape(v.unit or '')}</td><td>{default}</td>"
            f"<td>{rng}</td><td>{html.escape(deps)}</td><td>{html.escape(v.description)}</td></tr>")
    head = ("<tr><th>name</th><th>unit</th><th>default</th><th>allowed range</th>"
            "<th>direct feedthrough from</th><th>description</th></tr>")
    tables = "".join(f"<h2>{title}</h2><table>{head}{''.join(rows[key])}</table>"
                     for key, title in (("parameter", "Parameters"), ("input", "Inputs"), ("output", "Outputs")))
    start, stop, step = cls.DEFAULT_EXPERIMENT
    keys = FMU_SOURCES.get(name.removesuffix("PassThrough"), ())
    sources = ("<p>" + "; ".join(f"[{k}] {html.escape(BY_KEY[k].authors)} ({BY_KEY[k].year}): "
                                 f"{html.escape(BY_KEY[k].used_for)}" for k in keys) + "</p>" if keys else
               "<p>No paper: a generic component of the ujfmu library (see its equations above).</p>")
    bibliography = ("<h2>Bibliography</h2><p>The sources of the ujfmu library's models; this FMU cites those under "
                    "Sources, if any.</p><ul>" + "".join(f"<li>[{r.key}] {html.escape(r.text())}</li>"
                                                          for r in REFERENCES) + "</ul>")
    half = (", and smaller than half of it for this FMU, whose acceleration estimate is second order"
            if getattr(cls, "ACCELERATION_ORDER", 1) == 2 else "")
    ports = {v.name for v in cls.VARIABLES}
    if "omega_in" in ports and "tau_in" in ports:   # a drivetrain FMU, either causality
        coupling = f"""A drivetrain FMU driven by the speed <code>omega_in</code> answers with <code>tau_in</code>, which
contains the inertia torques of what it drives (an inertia times the acceleration it estimates from the speed
history). With an explicit master (no iteration) this is stable only when the inertia
reflected through <code>tau_in</code> is smaller than the driver's own inertia (a motor rotor, say), whatever the
step{half}: give the driver the larger inertia, use an iterating master, or use the torque-driven variant (driving
torque <code>tau_in</code> in, <code>omega_in</code> out). A stiff spring between two FMUs needs h well below
2/omega_n of that spring. Set <code>omega_in</code> to the speed at the start of the step (transfer at the
communication point, then step every FMU: Jacobi): a host that steps the driver first and hands this FMU the
speed at the step's end (sequential Gauss-Seidel) runs it one step ahead, an error first order in the step."""
    elif "omega" in ports and "tau_motor" in ports and "J_rotor" not in ports:   # MotorController
        coupling = """Its speed controller sees the speed at the start of each communication step (a PI sampled at
the host's step): closed through a torque-driven FMU, the torque it commands is a step late, which holds while
Kp h / J is below about 2 with ordered transfers and 1 in a master that transfers after all steps, J the inertia
on the motor's side of the driveline's first compliance (the torque-driven FMU's J_drive and its own input
inertia), not the whole driveline's. An iterating master smooths the sampling away and runs a loop that a digital
PI at this rate could not."""
    elif "tau_motor" in ports:   # Motor
        coupling = """Its rotor and PI speed controller are integrated together inside each step (the controller
sees the rotor's own speed continuously), against the load torque <code>tau_load</code> held over the step: the
loop's own gains do not limit the step. What does is the coupling of <code>tau_load</code> with the FMU it drives
(see its documentation: a speed-driven FMU reflects its inertias into <code>tau_in</code>)."""
    else:   # Load
        coupling = """Its torque follows the speed it reads at each communication point: where the law's slope
d(tau)/d(omega) is large against J/h (J the inertia it acts on), or where its constant torque T0 moves that inertia
across omega_smooth within one step (T0 h / J above omega_smooth), a shaft near rest sees the torque reverse at every
step: widen omega_smooth or take a smaller step."""
    return f"""<!DOCTYPE html>
<html><head><meta charset="utf-8"><title>{name} (ujfmu {__version__})</title>
<style>body{{font-family:sans-serif;max-width:60em}}table{{border-collapse:collapse}}
td,th{{border:1px solid #999;padding:2px 6px;vertical-align:top}}pre{{background:#f4f4f4;padding:6px}}</style>
</head><body>
<h1>{name}</h1>
<p>ujfmu {__version__}: FMI 2.0 Co-Simulation FMU built with pythonfmu. All quantities in SI units, angles in rad.</p>
<h2>Model and equations</h2><pre>{html.escape(cls.__doc__ or '')}</pre>
<h2>Physics module <code>{physics.__name__}</code></h2><pre>{html.escape(physics.__doc__ or '')}</pre>
{tables}
<h2>Default experiment</h2><p>start {start} s, stop {stop} s, communication step {step} s.</p>
<h2>Running this FMU</h2>
<p>The FMU runs Python code: the host needs a Python 3 runtime (the FMU was built with Python
{sys.version_info.major}.{sys.version_info.minor}). Python hosts (fmpy, libcosimpy) work as they are. On Linux a
non-Python host must preload libpython, e.g. <code>LD_PRELOAD=/usr/lib/x86_64-linux-gnu/libpython3.11.so</code>.</p>
<h2>Step size and stability</h2>
<p>Inside each communication step the FMU integrates its own states by the method the physics module above names
(classical RK4, Dormand-Prince, an exponential Runge-Kutta or Adams method, or exactly), in as many substeps as its
fastest rates need to stay stable and accurate; its error still falls with the host's step (fourth order or higher:
halving the step divides it by 16 or more), and the coupling with the other FMUs depends on the step too.
{coupling} The default experiment's step ({step} s) is what the ujfmu scenarios use;
they are checked against independent reference solutions at 1 ms. Check a new layout by halving the step: the
results must not change beyond your tolerance.</p>
<h2>Errors and logging</h2>
<p>Errors appear only with FMU logging enabled: pythonfmu, which runs this FMU, drops every log message when
logging is off, errors included. Turn on the FMU's logging in the host (fmi2Instantiate with loggingOn = true; in
fmpy <code>debug_logging=True</code>) to see them. An invalid parameter makes fmi2ExitInitializationMode fail
with a message naming the parameter and its allowed range; a non-finite or out-of-range input, a step size that
is not finite and positive, a step that would need more than 100000 substeps, or (a torque-driven FMU) a step that
would take its input shaft out of its speed range refuses the step (fmi2Discard) with a logged error naming the
cause; the instance stays usable.</p>
<h2>Sources</h2>
{sources}
{bibliography}
</body></html>
"""

