"""Thin FMU layer: one module per FMU, each a pythonfmu slave over a model in ujfmu.physics.

Standard library and pythonfmu only: ``ujfmu.build`` copies this package and ujfmu.physics into every FMU.
"""
