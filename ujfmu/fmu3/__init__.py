"""Thin FMI 3.0 layer: the ujfmu models as pythonfmu3 Co-Simulation (and, where the causality allows, Model
Exchange) FMUs, from the same declarations and equations as the FMI 2.0 FMUs (``ujfmu/models/<stem>``).

Standard library and pythonfmu3 only (the shared declarations in ``ujfmu.fmu`` import pythonfmu's pure-Python part,
which ``ujfmu.build3`` ships with them): ``ujfmu.build3`` copies this package into every FMI 3.0 FMU with the files
of its FMI 2.0 twin.
"""
