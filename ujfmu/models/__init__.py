"""The models, one folder each under the FMU's name in snake_case: ``model.py`` (the equations, standard library
only), ``fmu.py`` (the FMU declaration), ``reference.py`` (the independent reference derivation, scipy/sympy),
``published.toml`` (the papers' published values) and ``README.md`` (derivation and interpretation of the sources).

Only ``model.py`` and ``fmu.py`` of its own folder go into an FMU (with the shared plumbing in ``ujfmu.fmu``).
"""
