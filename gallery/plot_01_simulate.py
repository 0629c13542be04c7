"""
One simulation
==============

A spherical indenter (R = 4.77 mm) pressed 2 mm into the block on the coarse mesh, in 4 load steps
of 0.5 mm, at c1 = 10 kPa and c5 = 350 kPa: the force-depth curve and the surface displacement
that the 3D-DIC would see. The paper's model is the ``default`` mesh with 28 steps
(:doc:`../guide/simulate`).
"""

import indentation_studio as ins

spec = ins.ModelSpec(mesh=ins.MeshChoice("coarse"), protocol=ins.Protocol(step_size=0.5, steps=4))
result = ins.simulate(spec.with_material(c1=10.0, c5=350.0))
print(f"force at {result.depth[-1]:g} mm: {result.force[-1]:.1f} mN")

# %%
# The force at each depth (the first point, at zero depth, is left out).
fig = ins.figures.force_depth_figure(result.depth[1:], {"coarse": result.force[1:]})

# %%
# The displacement of the top surface at the last step: stiffer along the fibers (+y).
fig = ins.figures.displacement_maps_figure(result.top_xyz, result.displacement[-1])
