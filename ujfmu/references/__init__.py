"""Reference trajectories from computations independent of the co-simulation they check.

Each generator takes a scenario (ujfmu.scenario.Scenario) and returns a structured array sampled on the
scenario's communication grid. Reference CSV files start with one '#' line saying how they were made; the rest is
fmpy's cross-check CSV format. Regenerate all with ``ujfmu references``.
"""

import importlib
import io
from pathlib import Path

import numpy as np

#: generator name -> (module in ujfmu.references, function); imported when used (they need scipy and sympy,
#: the ``references`` extra; reading a reference CSV needs neither)
GENERATORS = {
    "cardan_chain": ("cardan_chain", "generate"),
    "double_cardan": ("double_cardan", "generate"),
    "twin_jeffcott": ("twin_jeffcott", "generate"),
    "ring_coupling": ("ring_coupling", "generate"),
    "ring_coupling_pendulum": ("ring_coupling", "generate_pendulum"),
}


def write_reference(path, table, provenance):
    """Write '# provenance' then fmpy's cross-check CSV (quoted header, %.17g values)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    names = table.dtype.names
    with open(path, "w") as f:
        f.write("# " + " ".join(provenance.split()) + "\n")
        f.write(",".join(f'"{n}"' for n in names) + "\n")
        np.savetxt(f, np.column_stack([table[n] for n in names]), delimiter=",", fmt="%.17g")


def read_reference(path):
    """Read a reference CSV (skipping '#' lines) into a structured array; returns (table, provenance)."""
    lines = Path(path).read_text().splitlines()
    provenance = " ".join(line[1:].strip() for line in lines if line.startswith("#"))
    body = [line for line in lines if not line.startswith("#")]
    names = [n.strip().strip('"') for n in body[0].split(",")]
    data = np.loadtxt(io.StringIO("\n".join(body[1:])), delimiter=",", ndmin=2)
    return np.rec.fromarrays(data.T, names=names), provenance


def generate(scenario):
    """(table, provenance) for a scenario, by its [reference] generator."""
    name = scenario.reference_generator
    if name not in GENERATORS:
        raise KeyError(f"{scenario.path}: unknown reference generator '{name}' (known: {', '.join(GENERATORS)})")
    for dependency in ("scipy", "sympy"):
        try:
            importlib.import_module(dependency)
        except ImportError:
            raise ModuleNotFoundError(f"regenerating a reference solution needs {dependency}, which is not installed: "
                                      "pip install 'ujfmu[references]'", name=dependency) from None
    module, function = GENERATORS[name]
    return getattr(importlib.import_module(f"{__name__}.{module}"), function)(scenario)
