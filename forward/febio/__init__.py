"""The FEBio backend: the model as a FEBio 4 input (``writer``), a run of ``febio4`` (``runner``), its
log read back (``log``, ``readback``) and the check of the steps FEBio accepted off equilibrium
(``equilibrium``). The mesh reader of ``.feb`` files is the forward model's own
(:mod:`indentation_studio.forward.feb_mesh`)."""

import lazy_loader as lazy

__getattr__, __dir__, __all__ = lazy.attach(
    __name__,
    submod_attrs={
        "writer": ["FebSettings", "write_feb"],
        "runner": ["FebioNotFoundError", "FebioSolver", "find_febio", "require_equilibrium"],
        "log": ["FebioLog", "FebioLogError", "read_febio_log"],
        "readback": ["FebioRunError", "read_febio_run"],
        "equilibrium": ["EquilibriumTolerance", "check_equilibrium", "equilibrium_notes"],
    },
)
