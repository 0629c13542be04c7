"""Experiment data: the folder, its processing and its checks, and the experiments the studio makes.

The folder's format, reader and writer (:mod:`.data`, :mod:`.folder`, :mod:`.errors`), the processing
into the model's frame (eq. 9, registration, DIC to nodes: :mod:`.processing`, :mod:`.relaxation`,
:mod:`.specimen_frame`) and its part of the bounds (:mod:`.processing_error`), the data check
(:mod:`.data_check`, :mod:`.dic_checks`, :mod:`.hold_checks`), and the experiments made from a
model (:mod:`.synthetic`), from a FEBio run (:mod:`.febio`) and from the composite phantom
(:mod:`.composite`). The names are exported by :mod:`indentation_studio.inference`; a lab's own
files are read by :mod:`indentation_studio.inference.lab`.
"""
