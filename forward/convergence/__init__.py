"""Grid convergence: one home for the mesh studies of the forward model.

The paper's mesh errors against a reference mesh (eq. 1a, 1b: :mod:`.mesh_study`), the families of
systematically refined meshes (:mod:`.mesh_family`), the observed order, Richardson's extrapolated
value and Roache's GCI (:mod:`.gci`), and the Predictor of two meshes extrapolated
(:mod:`.richardson`). The names are exported by :mod:`indentation_studio.forward`.
"""
