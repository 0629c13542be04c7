"""The held-out errors a multi-fidelity surrogate carries (:mod:`surrogate.multi_fidelity`): the
low level's, kept in its file on the low top nodes and moved to the high ones by the same
interpolation W that carries the low prediction (eq. 1b), and the discrepancy's own k-fold
errors (:func:`.discrepancy_errors.k_fold_discrepancy_errors`)."""

from __future__ import annotations

__all__ = ["CarriedEmulationError"]


class CarriedEmulationError:
    """The held-out errors of a two-level surrogate, a base of
    :class:`~surrogate.multi_fidelity.MultiFidelitySurrogate` (which holds ``low``, ``n_nodes``,
    ``emulation_error`` and ``_carried``, W applied along the nodes' axis)."""

    #: The low level's held-out errors on its own top nodes: what the file keeps (a few times fewer
    #: numbers than on the high nodes), moved to the high nodes when it is read.
    low_emulation_error = None
    #: The discrepancy's own held-out errors (:func:`.discrepancy_errors.k_fold_discrepancy_errors`: the multi-fidelity
    #: prediction's errors at the high-fidelity points, an EmulationError on the high top nodes);
    #: None where it was trained without folds or read from a file made before they were kept.
    discrepancy_error = None

    def kept_emulation_error(self):
        """The held-out errors its file keeps: the low level's, on the low top nodes.

        Returns
        -------
        EmulationError or None
            The low level's errors when it had them, else :attr:`emulation_error`.
        """
        return self.low_emulation_error if self.low_emulation_error is not None else self.emulation_error

    def restore_emulation_error(self, kept) -> None:
        """Set :attr:`emulation_error`: errors on the low top nodes are moved to the high ones.

        The low surrogate's own error is this one's (the discrepancy is learned on top of it), and
        the interpolation W carries it to the high nodes as it carries the low prediction (eq. 1b).

        Parameters
        ----------
        kept : EmulationError or None
            The low level's errors (on its top nodes) or errors already on the high nodes.
        """
        low_nodes = len(self.low.top_xyz)
        if (
            kept is not None
            and low_nodes != self.n_nodes
            and kept.directions.shape[1] == kept.width(low_nodes)
        ):
            self.low_emulation_error, self.emulation_error = kept, kept.carried(self._carried)
        else:
            self.emulation_error = kept
