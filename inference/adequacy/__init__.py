"""Model adequacy: can the fitted model explain the data within their measurement noise?

The bounds of eq. 6 to 8 take s from the fit's own residuals, so a model that misses the data
(the wrong contact, a composite fitted as homogeneous, a force scale off) still gets narrow
bounds. Here the fit's residuals are whitened by the noise the data carry and summed into a
chi-square statistic with n - p degrees of freedom (n the data points the fit used, p the
fitted parameters); beyond its upper 0.1 % tail (``ALPHA``) the fit is flagged: the model
cannot explain these data, and its bounds are not meaningful.

The noise the data carry (:mod:`.noise`), the chi-square statistic and its verdict
(:mod:`.chi_square`), the other readings of the registration and the interpolation's own bias
(:mod:`.registration`), and the test of a fit with the parameters it names (:mod:`.of_fit`). The
names are exported by :mod:`indentation_studio.inference`.
"""
