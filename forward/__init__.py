"""The forward model: one indentation simulation (spec, mesh, material, solver, results)."""
