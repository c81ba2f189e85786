"""Optional dependencies (pip extras): a clear message naming the extra when one is missing.

A plain ``pip install ujfmu`` builds, runs and checks scenarios. The extras add:
``plot`` (matplotlib: result figures), ``sweep`` (dask.distributed: parameter sweeps, with plot),
``references`` (scipy, sympy: regenerating reference solutions, the benchmark's monolithic solve),
``report`` (docs/validation.md: sweep, references and plot), ``test`` (everything the test suite needs).
"""

import importlib


class MissingExtraError(ImportError):
    """An optional dependency is not installed; the message names the pip extra that brings it."""


def require(module: str, extra: str, purpose: str):
    """Import module, or raise MissingExtraError naming ``ujfmu[extra]`` and what needed it."""
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        raise MissingExtraError(f"{purpose} needs {module.split('.')[0]}, which is not installed: "
                                f"pip install 'ujfmu[{extra}]' (in a clone: pip install -e '.[{extra}]')") from exc


def available(module: str) -> bool:
    """True when module can be imported."""
    try:
        importlib.import_module(module)
        return True
    except ImportError:
        return False


#: compiled modules of the extras that the tooling uses after FMUs are loaded (fmpy's validate_result needs
#: scipy.ndimage; the reference generators scipy.integrate, scipy.special and sympy; the tests scipy.linalg and
#: scipy.spatial.transform)
PRELOAD = ("scipy.ndimage", "scipy.integrate", "scipy.special", "scipy.linalg", "scipy.spatial.transform", "sympy")


def preload() -> None:
    """Import the installed extras' compiled modules now, before any FMU is loaded.

    Importing scipy's compiled modules for the first time after a pythonfmu FMU has been loaded into the process
    aborts the interpreter at exit now and then ("corrupted double-linked list", exit status 134; measured on one
    test file: 2 of 10 runs, none of 34 with the modules imported first). Missing extras are skipped."""
    for module in PRELOAD:
        available(module)
