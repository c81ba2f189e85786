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
