"""Shared FMI plumbing of every ujfmu FMU: the pythonfmu base (base.py), the RK4 integrator (rk4.py), the base of
the torque-driven FMUs (torque_driven.py) and the pass-through twins of the benchmark (passthrough.py).

Standard library and pythonfmu only: ``ujfmu.build`` copies this package into every FMU, with that FMU's own model
(``ujfmu/models/<stem>/model.py`` and ``fmu.py``).
"""
