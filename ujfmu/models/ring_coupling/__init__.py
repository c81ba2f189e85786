"""RingCoupling: equations (model.py), FMU declaration (fmu.py), reference derivation, published values, README."""
