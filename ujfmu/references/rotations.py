"""Elementary rotation matrices for the references' symbolic kinematics (sympy): R_x, R_y, R_z of an angle."""

import sympy as sp


def rx(a):
    """Rotation by a about x."""
    return sp.Matrix([[1, 0, 0], [0, sp.cos(a), -sp.sin(a)], [0, sp.sin(a), sp.cos(a)]])


def ry(a):
    """Rotation by a about y."""
    return sp.Matrix([[sp.cos(a), 0, sp.sin(a)], [0, 1, 0], [-sp.sin(a), 0, sp.cos(a)]])


def rz(a):
    """Rotation by a about z."""
    return sp.Matrix([[sp.cos(a), -sp.sin(a), 0], [sp.sin(a), sp.cos(a), 0], [0, 0, 1]])
