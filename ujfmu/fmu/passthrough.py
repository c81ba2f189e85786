"""Pass-through twins of the ujfmu FMUs, for measuring the FMI call floor (``ujfmu bench``).

``pass_through(Model)`` is an FMU with exactly Model's variables, ports and FMI plumbing (UjfmuSlave: input
checks, lazy outputs) but no physics: each output copies the first input it is declared to depend on, or stays 0.
A co-simulation of pass-through twins makes the same FMI calls as the real one, so its cost is the floor that
the models' own work adds to.
"""

from .base import UjfmuSlave


def pass_through(model):
    """A UjfmuSlave subclass named <Model>PassThrough with model's VARIABLES and no physics."""
    copies = tuple((v.name, v.depends_on[0] if v.depends_on else None)
                   for v in model.VARIABLES if v.causality == "output")

    def initialize(self, start_time):
        pass

    def compute_outputs(self):
        for name, source in copies:
            setattr(self, name, getattr(self, source) if source else 0.0)

    def advance(self, t, h):
        pass

    return type(f"{model.__name__}PassThrough", (UjfmuSlave,), {
        "__doc__": f"Pass-through twin of {model.__name__} (same variables, no physics) for FMI cost benchmarks.",
        "__module__": model.__module__, "PHYSICS": model.PHYSICS, "VARIABLES": model.VARIABLES,
        "DEFAULT_EXPERIMENT": model.DEFAULT_EXPERIMENT, "check_parameters": lambda self: [],
        "initialize": initialize, "compute_outputs": compute_outputs, "advance": advance})
