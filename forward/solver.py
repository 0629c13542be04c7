"""The embedded FE solver of one indentation simulation (paper 2.4.1).

Quasi-static, displacement-controlled: the rigid sphere descends in the protocol's steps (each
split into ``substeps`` increments); each increment is solved by Newton-Raphson with the exact
tangent of the three-field hex8 (:mod:`forward.hex8_mean_dilatation`, :mod:`forward.newton`),
starting from a predictor (the last increment's displacement extrapolated). The contact, exact
node-wise stick or a penalty (stick or Coulomb friction, node by node or integrated over the top
faces), is met through one interface (:mod:`forward.indenter_contact`); it solves each increment
until its contact set settles. An increment that fails (no convergence, an inverted element,
a contact set that does not settle) is cut in half; the run fails when an increment of the
step / 2^``max_cutbacks`` fails (or a step has failed ``CUTBACK_BUDGET`` x ``max_cutbacks``
increments in all). After a converged increment the next is doubled, up to the step.

With ``sensitivities=True`` the converged tangent of each step also gives d(force)/d(theta) and
d(top displacements)/d(theta) for theta = (c1, c5) (and mu with friction): one extra solve per
parameter with right-hand side -dR/dtheta (the internal force is linear in c1 and c5).
"""

from __future__ import annotations

import hashlib
import logging
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from .. import __version__
from . import checkpoint as checkpoint_file
from .checkpoint import CheckpointMismatch, read_checkpoint, run_identity, write_checkpoint
from .element_moduli import element_moduli
from .hex8_mean_dilatation import ReferenceGeometry
from .indenter_contact import IndenterContact
from .linear_solver import ConstrainedSymmetricSolver
from .linear_steps import LINEAR_STEP_STATS
from .mesh import BlockMesh, build_mesh
from .newton import NewtonSystem
from .node_stick import NodeStickContact
from .penalty_contact import PenaltyContact
from .protocol_step import CUTBACK_BUDGET, ProtocolSteps, SimulationError
from .result import SimulationResult
from .run_records import IncrementState, RunRecords
from .sparse_assembly import SparsePattern
from .spec import ModelSpec
from .stick_contact import RigidSphere
from .threads import solver_threads, thread_limits

__all__ = [
    "CUTBACK_BUDGET",
    "CheckpointMismatch",
    "EmbeddedSolver",
    "SimulationError",
    "mesh_structures",
    "simulate",
]

log = logging.getLogger(__name__)


#: Meshes with at least this many dofs factorise in single precision (PARDISO): the factorisation
#: only preconditions CG and makes corrections that Newton's residual checks, and costs half.
#: Smaller meshes stay in double: single precision would save 13 to 19 % there but make the result
#: depend on the thread count up to Newton's tolerance (1 against 2 threads on FEBio's mesh:
#: 1.1e-8 mm stick, 1.6e-5 mm with mu = 0.3, against 1e-14 in double; docs/validation/solver-and-speed.md).
SINGLE_PRECISION_DOFS = 20_000

_STRUCTURES: dict[bytes, tuple[ReferenceGeometry, SparsePattern]] = {}


def mesh_structures(mesh: BlockMesh) -> tuple[ReferenceGeometry, SparsePattern]:
    """The reference geometry (shape-function gradients, Gauss weights) and the CSR pattern of a
    mesh, kept for the last few meshes of the process: a campaign worker solves the same mesh
    hundreds of times."""
    digest = hashlib.blake2b(digest_size=16)
    for array in (mesh.nodes, mesh.elements):
        digest.update(np.ascontiguousarray(array).tobytes())
    key = digest.digest()
    if key not in _STRUCTURES:
        if len(_STRUCTURES) >= 4:
            _STRUCTURES.pop(next(iter(_STRUCTURES)))
        edofs = (3 * mesh.elements[:, :, None] + np.arange(3)).reshape(-1, 24)
        _STRUCTURES[key] = (ReferenceGeometry.of(mesh), SparsePattern(edofs, 3 * mesh.n_nodes))
    return _STRUCTURES[key]


class EmbeddedSolver(ProtocolSteps, NewtonSystem):
    """Solves one :class:`ModelSpec` on its mesh (module docstring).

    Parameters
    ----------
    spec : ModelSpec
        The model.
    mesh : BlockMesh or None, optional
        The mesh to solve on; None: the spec's (:func:`forward.mesh.build_mesh`).
    linear_solver : str or None, optional
        A backend of :mod:`forward.linear_solver` (None: PARDISO where MKL loads, else SuperLU).

    Examples
    --------
    >>> from indentation_studio.forward import EmbeddedSolver, ModelSpec, MeshChoice, Protocol
    >>> spec = ModelSpec(mesh=MeshChoice("coarse"), protocol=Protocol(steps=2))
    >>> result = EmbeddedSolver(spec).run()
    >>> result.force.shape
    (3,)
    """

    name = "embedded"

    def __init__(self, spec: ModelSpec, mesh: BlockMesh | None = None, linear_solver: str | None = None):
        self.spec = spec
        self.mesh = mesh if mesh is not None else build_mesh(spec)
        n = self.mesh.n_nodes
        self.n_dofs = 3 * n
        self.geometry, self.pattern = mesh_structures(self.mesh)
        self.edofs = self.pattern.edofs
        fixed = np.zeros((n, 3), dtype=bool)
        fixed[self.mesh.bottom] = True
        fixed[self.mesh.xsym, 0] = True
        fixed[self.mesh.ysym, 1] = True
        self.bc_fixed = fixed
        #: Coulomb's mu, or None for stick
        self.friction = spec.contact.friction
        self.stats = {
            "assemblies": 0,
            "tangent_assemblies": 0,
            "parameter_assemblies": 0,
            "assembly_s": 0.0,
            **LINEAR_STEP_STATS,
        }
        self.linear = ConstrainedSymmetricSolver(
            self.pattern,
            linear_solver,
            permanent=fixed.ravel(),
            single_precision=self.n_dofs >= SINGLE_PRECISION_DOFS,
            stats=self.stats,  # its counters of factorisations and back-substitutions join the run's
            # with friction the factorisation is of the tangent's symmetric part; the contact
            # blocks' changes since (slip, points in or out) are put back by the contact's correction
        )
        self.linear_solver = self.linear.backend
        self.top = self.mesh.top
        top_z = float(self.mesh.nodes[:, 2].max())
        self.sphere = RigidSphere(spec.indenter.radius, top_z)
        #: per-element moduli (the composite's two materials, or the spec's one)
        self._mat = element_moduli(spec, self.mesh)
        # scale of forces for tolerances: c1 * (first top cell size)^2 (the matrix's c1 in a composite)
        c1 = spec.composite.matrix.c1 if spec.composite is not None else spec.material.c1
        top_xy = self.mesh.nodes[self.top, :2]
        h = np.sort(np.unique(np.round(top_xy[:, 0], 9)))
        self.force_scale = c1 * float(h[1] - h[0]) ** 2 if h.size > 1 else c1
        self.want_sensitivities = False
        #: the indenter's contact (forward.indenter_contact): exact node-wise stick, or a penalty
        self.contact: IndenterContact = (
            PenaltyContact(self) if spec.contact.penalised else NodeStickContact(self)
        )

    # ------------------------------------------------------------------ numerics
    def assemble(self, u: np.ndarray, tangent: bool = True, parameter_derivatives: bool = False):
        """The global internal force, tangent and (if asked) dR/dtheta at a state.

        In an increment the contact takes its forces off the internal force and their derivative
        off the tangent (:meth:`IndenterContact.add_to_system`; nothing for the exact stick, whose
        forces are the reactions).

        Parameters
        ----------
        u : ndarray, shape (n, 3)
            Displacements, mm.
        tangent : bool, optional
            Whether to assemble the tangent.
        parameter_derivatives : bool, optional
            Whether to assemble dR/dtheta for theta = (c1, c5).

        Returns
        -------
        tuple
            R (3n,), K (CSR or None), dR (3n, 2) or None.

        Raises
        ------
        InvertedElementError
            An element turned inside out at ``u``.
        """
        t = time.perf_counter()
        st = self._mat.element_state(
            self.geometry,
            u[self.mesh.elements],
            tangent=tangent,
            parameter_derivatives=parameter_derivatives,
            fiber_mean=self.spec.solver.fiber_stretch == "mean",
        )
        R = self.pattern.vector(st.force)
        K = self.pattern.matrix(st.stiffness) if tangent else None
        if tangent:
            self.fiber_taut = st.fiber_taut
        dR = None
        if parameter_derivatives:
            dR = np.stack([self.pattern.vector(st.dforce_dtheta[:, k]) for k in range(2)], axis=1)
        self.contact.add_to_system(u, R, K)
        self.stats["assemblies"] += 1
        self.stats["tangent_assemblies"] += int(tangent)
        self.stats["parameter_assemblies"] += int(parameter_derivatives)
        self.stats["assembly_s"] += time.perf_counter() - t
        return R, K, dR

    # ------------------------------------------------------------------ driver
    def run(
        self,
        sensitivities: bool = False,
        progress: Callable[[int, int, float], None] | None = None,
        full_field: bool = False,
        *,
        threads: int | None = None,
        checkpoint: str | Path | None = None,
        checkpoint_every_s: float = 0.0,
    ) -> SimulationResult:
        """Run the protocol.

        Parameters
        ----------
        sensitivities : bool, optional
            Also d(force)/d(theta) and d(top displacements)/d(theta) at every step (the
            homogeneous model's (c1, c5), and mu with friction).
        progress : callable, optional
            ``progress(step, steps, force)`` after each step.
        full_field : bool, optional
            Keep every node's displacement per step (for VTU export).
        threads : int or None, optional
            numba's and MKL's thread count for this run; None takes the idle cores
            (:func:`forward.threads.solver_threads`), a campaign worker passes 1.
        checkpoint : str or pathlib.Path, optional
            A restart file, as FEBio's dump: the run's whole state is written there after every
            step (atomically), and a run given a file that exists resumes after its last step
            instead of starting again. The caller deletes it once the result is kept. It is a
            pickle: load only checkpoints your own runs wrote.
        checkpoint_every_s : float, default 0
            Write the checkpoint after a step only when this long has passed since the last one
            was written (or the run started): 0, after every step; a campaign of many short runs
            passes tens of seconds, so that a run of seconds writes none.

        Returns
        -------
        SimulationResult

        Raises
        ------
        ValueError
            Sensitivities asked of a composite.
        SimulationError
            The protocol's final depth not reached (with the finished steps).
        CheckpointMismatch
            ``checkpoint`` holds another run's state.

        Notes
        -----
        The linear solver's memory (PARDISO keeps its factors outside Python) is freed at the end.
        """
        if sensitivities and not self._mat.homogeneous:
            raise ValueError(
                "sensitivities are those of the homogeneous model's (c1, c5); a composite has none"
            )
        try:
            with thread_limits(solver_threads() if threads is None else threads):
                result = self._run(
                    sensitivities,
                    progress,
                    full_field,
                    Path(checkpoint) if checkpoint is not None else None,
                    checkpoint_every_s,
                )
        finally:
            self.linear.release()
        return result

    def _run(
        self,
        sensitivities: bool,
        progress: Callable[[int, int, float], None] | None,
        full_field: bool = False,
        checkpoint: Path | None = None,
        checkpoint_every_s: float = 0.0,
    ) -> SimulationResult:
        t_start = time.perf_counter()
        self.want_sensitivities = sensitivities
        proto = self.spec.protocol
        n_p = len(self.contact.parameters)  # theta = (c1, c5), and mu with friction
        state = IncrementState.start(
            self.mesh.n_nodes, self.contact.start(), n_p, sensitivities=sensitivities
        )
        records = RunRecords.start(self.mesh.n_nodes, self.top.size, n_p, full_field=full_field)
        mid_step = None
        identity = self._checkpoint_identity(sensitivities, full_field) if checkpoint is not None else None
        if checkpoint is not None and checkpoint.is_file():
            saved = read_checkpoint(checkpoint, identity)
            records = RunRecords.from_checkpoint(saved)
            self.stats.update(saved["stats"])
            t_start -= saved["elapsed_s"]
            mid_step = saved.get("mid_step")  # the increments of the next step done before the stop
            depth = records.depths[-1] if mid_step is None else mid_step["depth"]
            state = IncrementState.from_checkpoint(saved, depth)
            log.info("resumed from %s after step %d (%.4g mm)", checkpoint, records.steps_done, depth)
        written = time.perf_counter()

        def save(state: IncrementState, mid: dict | None) -> None:
            # the run's state after its last whole step, and (mid) the increments of the next
            # step converged since, whose state ``state`` already is: after every step, and inside
            # one at most every MID_STEP_CHECKPOINT_S
            nonlocal written
            least = checkpoint_file.MID_STEP_CHECKPOINT_S if mid is not None else checkpoint_every_s
            if checkpoint is None or time.perf_counter() - written < least:
                return
            fields = {**state.checkpoint_fields(), **records.checkpoint_fields()}
            fields.update(stats=self.stats, elapsed_s=time.perf_counter() - t_start, mid_step=mid)
            write_checkpoint(checkpoint, identity, fields)
            written = time.perf_counter()

        try:
            for k, d_target in enumerate(proto.depths, start=1):
                if k <= records.steps_done:
                    continue
                state, eq, counts, counted, t_step = self._step(
                    state, d_target, mid_step, save, lambda: self._result(records, sensitivities, t_start)
                )
                mid_step = None
                self._record_step(records, state, eq, counts, counted, t_step)
                save(state, None)
                if progress is not None:
                    progress(k, proto.steps, records.forces[-1])
        except KeyboardInterrupt as exc:  # Ctrl-C (or SIGTERM under run_simulation): keep the steps done
            records.keep_whole_steps()
            exc.partial = self._result(records, sensitivities, t_start) if records.steps_done > 0 else None
            raise
        return self._result(records, sensitivities, t_start)

    def _checkpoint_identity(self, sensitivities: bool, full_field: bool) -> dict:
        mesh = self.mesh
        return run_identity(
            self.spec.to_dict(),
            {"source": mesh.source, "nodes": mesh.n_nodes, "elements": mesh.n_elements},
            sensitivities=sensitivities,
            full_field=full_field,
        )

    def _result(self, records: RunRecords, sensitivities: bool, t_start: float) -> SimulationResult:
        mesh = self.mesh
        return SimulationResult(
            depth=np.asarray(records.depths),
            force=np.asarray(records.forces),
            top_node_ids=mesh.node_ids[self.top],
            top_xyz=mesh.nodes[self.top],
            displacement=np.asarray(records.disp),
            full_displacement=np.asarray(records.full) if records.full is not None else None,
            spec=self.spec.to_dict(),
            solver={
                "name": self.name,
                "version": __version__,
                "element": "hex8 three-field (mean dilatation), 2x2x2 Gauss",
                "contact": self.contact.describe(),
                "sensitivity_parameters": list(self.contact.parameters),
                "linear_solver": self.linear_solver,
                "factorisation": "single precision" if self.linear.single_precision else "double precision",
                "mesh": {"source": mesh.source, "nodes": mesh.n_nodes, "elements": mesh.n_elements},
                "stats": dict(self.stats),
            },
            convergence={k: np.asarray(v) for k, v in records.conv.items()},
            wall_s=time.perf_counter() - t_start,
            force_sensitivity=np.asarray(records.f_sens) if sensitivities else None,
            displacement_sensitivity=np.asarray(records.u_sens) if sensitivities else None,
            parameters=tuple(self.contact.parameters),
            contact_status=np.asarray(records.status, np.int8),
        )


def simulate(
    spec: ModelSpec, mesh: BlockMesh | None = None, sensitivities: bool = False, **kwargs
) -> SimulationResult:
    """Run one simulation of ``spec`` on the embedded solver.

    Parameters
    ----------
    spec : ModelSpec
        The model.
    mesh : BlockMesh or None, optional
        The mesh (None: the spec's).
    sensitivities : bool, optional
        Also the sensitivities (:meth:`EmbeddedSolver.run`).
    **kwargs
        :class:`EmbeddedSolver`'s other arguments (``linear_solver``).

    Returns
    -------
    SimulationResult
    """
    return EmbeddedSolver(spec, mesh, **kwargs).run(sensitivities=sensitivities)
