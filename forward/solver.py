"""The embedded FE solver of one indentation simulation (paper 2.4.1).

Quasi-static, displacement-controlled: the rigid sphere descends in the protocol's steps (each
split into ``substeps`` increments); each increment is solved by Newton-Raphson with the exact
tangent of the three-field hex8 (:mod:`forward.hex8_mean_dilatation`), starting from a predictor
(the last increment's displacement extrapolated, then one tangent step that carries the
prescribed contact displacements into the body). The stick contact set
(:mod:`forward.stick_contact`) is settled by re-solving until no free node penetrates the sphere
and no attached node pulls on it. An increment that fails (no convergence, an inverted element,
a contact set that does not settle) is cut in half; the run fails when an increment of the
step / 2^``max_cutbacks`` fails (or a step has failed ``CUTBACK_BUDGET`` x ``max_cutbacks``
increments in all). After a converged increment the next is doubled, up to the step.

With ``sensitivities=True`` the converged tangent of each step also gives d(force)/d(theta) and
d(top displacements)/d(theta) for theta = (c1, c5): one extra back-substitution per parameter
with right-hand side -dR/dtheta (the internal force is linear in c1 and c5).
"""

from __future__ import annotations

import hashlib
import logging
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .. import __version__
from .contact_quadrature import ContactPoints, contact_points
from .coulomb_contact import FREE, FrictionContactState
from .element_moduli import element_moduli
from .hex8_mean_dilatation import ReferenceGeometry, element_state
from .linear_solver import ConstrainedSymmetricSolver, LinearSolveError, LowRankUpdate
from .material import InvertedElementError
from .mesh import BlockMesh, build_mesh
from .result import SYMMETRY_FACTOR, SimulationResult
from .sparse_assembly import SparsePattern
from .spec import ModelSpec
from .stick_contact import RigidSphere, StickContactState
from .threads import solver_threads, thread_limits

log = logging.getLogger(__name__)


class SimulationError(RuntimeError):
    """A simulation that could not reach its final depth; names the depth reached."""

    def __init__(self, message: str, depth_reached: float, partial: SimulationResult | None = None):
        super().__init__(message)
        self.depth_reached = depth_reached
        self.partial = partial


class _IncrementFailed(Exception):
    pass


#: A step may fail this many times ``max_cutbacks`` increments in all (halving and doubling back)
#: before the run is given up: a hard stretch (the composite's matrix pinched between the sphere
#: and a fiber) needs several small increments in a row, not one.
CUTBACK_BUDGET = 4
#: A correction keeps the current factorisation while the residual shrinks at least this much.
REFACTOR_RATIO = 0.3
#: ... and for at most this many corrections in a row.
MAX_STALE_STEPS = 6
#: A Newton step that inverts an element is halved at most this many times.
MAX_HALVINGS = 6
#: Newton steps are solved by CG preconditioned with the factorisation in hand to this relative
#: residual, in at most this many iterations, before a new factorisation is made.
KRYLOV_RTOL = 1e-2
KRYLOV_MAXITER = 8
#: ... or more where a factorisation costs many back-substitutions (large meshes).
KRYLOV_MAXITER_LARGE = 30
KRYLOV_DOFS_PER_ITERATION = 3000
#: Relative residual of the sensitivity solves (their CG runs on the exact converged tangent).
SENSITIVITY_RTOL = 1e-11
#: Meshes with at least this many dofs factorise in single precision (PARDISO): the factorisation
#: only preconditions CG and makes corrections that Newton's residual checks, and costs half.
SINGLE_PRECISION_DOFS = 20_000
#: With Coulomb friction, each Newton solve takes at most this many damped steps
#: (EmbeddedSolver._equilibrate_friction).
FRICTION_NEWTON = 60
#: A top node's contact block (its 3 x 3 share of the tangent) counts as changed since the
#: factorisation when it moved by more than this fraction of the node's penalty: a node that came
#: into contact, left it, or slips (EmbeddedSolver._contact_correction).
CONTACT_BLOCK_CHANGE = 1e-3
#: A penalty contact point changes status only where that changes its force by more than this
#: fraction of the indenter's force (EmbeddedSolver._status_tolerance).
STATUS_FORCE_FRACTION = 1e-7
#: From this contact pass of an increment on, a penalty contact point may come into contact but
#: not leave it (a set that wanders without repeating itself otherwise never settles).
HOLDING_PASS = 4
#: A penalty contact's statuses follow the state in the first this many Newton iterations of a
#: solve (EmbeddedSolver._statuses_follow), then stay as they are until the solve ends.
STATUS_NEWTON_UPDATES = 8
#: With friction, a step made with a fresh factorisation is GMRES on the tangent to this relative
#: residual, in at most this many iterations (EmbeddedSolver._fresh_step).
FRESH_RTOL = 1e-8
FRESH_MAXITER = 50


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


@dataclass
class _Equilibrium:
    u: np.ndarray  # (n, 3)
    R: np.ndarray  # (3n,) internal force = external force at equilibrium
    K: sp.csr_matrix
    iterations: int
    dR: np.ndarray | None = None  # (3n, p): d(internal force)/d(theta) at u


class EmbeddedSolver:
    """Solves one :class:`ModelSpec` on its mesh. ``linear_solver`` names a backend of
    :mod:`forward.linear_solver`."""

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
        #: a penalty contact (friction, or the surface-integrated stick: mu = inf) at contact
        #: points (forward.contact_quadrature), or the exact node-wise stick
        self._penalised = spec.contact.penalised
        self.linear = ConstrainedSymmetricSolver(
            self.pattern,
            linear_solver,
            permanent=fixed.ravel(),
            single_precision=self.n_dofs >= SINGLE_PRECISION_DOFS,
            # with friction the factorisation is of the tangent's symmetric part; the contact
            # blocks' changes since (slip, nodes in or out) are put back by _contact_correction
        )
        #: whether the tangent is symmetric (CG) or not (GMRES): the slip tangent is unsymmetric
        self._tangent_symmetric = self.friction is None
        #: with a penalty contact, its cells' blocks in the tangent (nc, k, 3, k, 3) at the last
        #: assembly, and (symmetrised) in the factorisation in hand
        self._contact_blocks: np.ndarray | None = None
        self._factored_contact_blocks: np.ndarray | None = None
        #: the last contact correction with the blocks and the factorisation count it was made for
        self._correction: tuple[np.ndarray, int, LowRankUpdate | None] | None = None
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
        self._force_scale = c1 * float(h[1] - h[0]) ** 2 if h.size > 1 else c1
        self._sensitivities = False
        #: the frictional contact's state of the increment being solved (its forces and tangent
        #: enter :meth:`assemble`), None outside an increment or with the stick contact
        self._friction_state: FrictionContactState | None = None
        self._friction_depth = 0.0
        #: late in an increment's contact passes, points may come into contact but not leave it
        self._holding = False
        self._points: ContactPoints | None = None
        if self._penalised:
            self._points = contact_points(self.mesh, spec.contact.integration, order=spec.contact.order)
            self._contact_eps = spec.contact.penalty * self._points.area  # mN/mm per point
            self._cell_eps = self._points.cell_scale(self._contact_eps)
            self._cell_slots = self._points.slots(self.pattern, self.top)

        self._full: list[np.ndarray] | None = None  # every node's displacement per step, when asked for
        self.stats = {
            "assemblies": 0,
            "tangent_assemblies": 0,
            "assembly_s": 0.0,
            "factorizations": 0,
            "factorize_s": 0.0,
            "solves": 0,
            "solve_s": 0.0,
            "krylov_steps": 0,
            "krylov_iterations": 0,
            "krylov_s": 0.0,
        }

    # ------------------------------------------------------------------ numerics
    def assemble(self, u: np.ndarray, tangent: bool = True, parameter_derivatives: bool = False):
        """Global internal force (3n,), tangent (CSR) and, if asked, dR/dtheta (3n, 2). With a
        penalty contact, in an increment, the sphere's forces (at the contact points, carried to
        the top nodes) are taken off the internal force and their derivative off the tangent
        (:mod:`forward.coulomb_contact`, :mod:`forward.contact_quadrature`)."""
        t = time.perf_counter()
        m = self._mat
        st = element_state(
            self.geometry,
            u[self.mesh.elements],
            m.c1,
            m.c5,
            m.kappa,
            m.fiber,
            tangent,
            parameter_derivatives,
            m.c2,
        )
        R = self.pattern.vector(st.force)
        K = self.pattern.matrix(st.stiffness) if tangent else None
        dR = None
        if parameter_derivatives:
            dR = np.stack([self.pattern.vector(st.dforce_dtheta[:, k]) for k in range(2)], axis=1)
        if self._friction_state is not None:
            pts = self._points
            resp = self._friction_state.response(pts.to_points(u[self.top]), self._friction_depth)
            R.reshape(-1, 3)[self.top] -= pts.to_nodes(resp.force)
            self._contact_blocks = -pts.cell_blocks(resp.df_dr)
            if K is not None:
                K.data += self._scatter_cells(self._contact_blocks)
        self.stats["assemblies"] += 1
        self.stats["tangent_assemblies"] += int(tangent)
        self.stats["assembly_s"] += time.perf_counter() - t
        return R, K, dR

    def _scatter_cells(self, blocks: np.ndarray) -> np.ndarray:
        """The contact cells' ``blocks`` (nc, k, 3, k, 3) summed into a CSR data array."""
        return np.bincount(self._cell_slots.ravel(), weights=blocks.ravel(), minlength=self.pattern.nnz)

    def _factorize(self, K: sp.csr_matrix, constrained: np.ndarray) -> None:
        """Factorise K; with friction, its symmetric part (the contact blocks of slipping points
        are K's only unsymmetric entries; :meth:`_contact_correction` puts them back)."""
        t = time.perf_counter()
        if self._penalised and self._contact_blocks is not None:
            contact = self._contact_blocks
            symmetric = 0.5 * (contact + contact.transpose(0, 3, 4, 1, 2))
            if not self._tangent_symmetric:
                K = K.copy()
                K.data += self._scatter_cells(symmetric - contact)
            self._factored_contact_blocks = symmetric
        self.linear.factorize(K, constrained)
        dt = time.perf_counter() - t
        self.stats["factorizations"] += 1
        self.stats["factorize_s"] += dt
        self.stats["solve_s"] += dt

    def _krylov_maxiter(self) -> int:
        """CG iterations worth trying before a factorisation. A factorisation's cost grows faster
        than a back-substitution's with the mesh, so larger meshes try more: one iteration per
        ``KRYLOV_DOFS_PER_ITERATION`` dofs, within ``KRYLOV_MAXITER`` .. ``KRYLOV_MAXITER_LARGE``
        (a fixed rule, not a timing, so that a run is reproducible to the last digit)."""
        return int(np.clip(self.n_dofs // KRYLOV_DOFS_PER_ITERATION, KRYLOV_MAXITER, KRYLOV_MAXITER_LARGE))

    def _krylov(
        self, K: sp.csr_matrix, cmask: np.ndarray, rhs: np.ndarray, rtol: float, maxiter: int
    ) -> np.ndarray | None:
        """CG (GMRES when K is unsymmetric) on K x = rhs with the dofs in ``cmask`` eliminated, preconditioned with the
        factorisation in hand (with ``cmask``'s extra constraints by its Schur complement);
        None when it does not reach ``rtol`` in ``maxiter`` iterations."""
        t = time.perf_counter()

        def matvec(x: np.ndarray) -> np.ndarray:
            y = K @ np.where(cmask, 0.0, x)
            y[cmask] = x[cmask]
            return y

        n = self.n_dofs
        A = spla.LinearOperator((n, n), matvec=matvec, dtype=float)
        correction = self._contact_correction(cmask)
        M = spla.LinearOperator(
            (n, n), matvec=lambda r: self._precondition(r, cmask, correction), dtype=float
        )
        its = [0]

        def count(_x: np.ndarray) -> None:
            its[0] += 1

        if self._tangent_symmetric:
            x, info = spla.cg(A, rhs, rtol=rtol, maxiter=maxiter, M=M, callback=count)
        else:
            x, info = spla.gmres(
                A, rhs, rtol=rtol, restart=maxiter, maxiter=1, M=M, callback=count, callback_type="pr_norm"
            )
        dt = time.perf_counter() - t
        self.stats["krylov_iterations"] += its[0]
        self.stats["krylov_s"] += dt
        self.stats["solve_s"] += dt
        if info != 0 or not np.all(np.isfinite(x)):
            return None
        self.stats["krylov_steps"] += 1
        return np.where(cmask, 0.0, x)

    def _newton_step(
        self, K: sp.csr_matrix, cmask: np.ndarray, rhs: np.ndarray, rtol: float = KRYLOV_RTOL
    ) -> np.ndarray:
        """Solve K x = rhs with the dofs in ``cmask`` eliminated: by conjugate gradients (GMRES
        with friction) preconditioned with the factorisation in hand (to ``rtol``; a tangent
        assembly and a few back-substitutions instead of a factorisation) when that factorisation
        covers the constraints (its own plus nodes attached since,
        :meth:`ConstrainedSymmetricSolver.covers`), else, or when it does not get there, by
        factorising K."""
        if self.linear.covers(cmask):
            x = self._krylov(K, cmask, rhs, rtol, self._krylov_maxiter())
            if x is not None:
                return x
        return self._fresh_step(K, cmask, rhs)

    def _fresh_step(self, K: sp.csr_matrix, cmask: np.ndarray, rhs: np.ndarray) -> np.ndarray:
        """Solve K x = rhs with a factorisation of K made here: one back-substitution; with
        friction GMRES on K itself, preconditioned with it, to ``FRESH_RTOL`` (the factorisation is
        of K's symmetric part, its contact blocks put back by :meth:`_contact_correction` for at
        most ``max_extra // 3`` nodes, and in single precision on large meshes), else that
        factorisation's own step."""
        self._factorize(K, cmask)
        if self._tangent_symmetric:
            return self._solve(rhs, cmask)
        x = self._krylov(K, cmask, rhs, FRESH_RTOL, FRESH_MAXITER)
        # where GMRES does not get there (a correction capped far below the contact set), the
        # factorisation's own step, checked by the damped Newton's residual like any other
        return x if x is not None else self._solve(rhs, cmask)

    def _solve(self, rhs: np.ndarray, cmask: np.ndarray) -> np.ndarray:
        """One back-substitution with the factorisation in hand, ``cmask``'s dofs held at zero."""
        t = time.perf_counter()
        x = self._precondition(rhs, cmask, self._contact_correction(cmask))
        self.stats["solves"] += 1
        self.stats["solve_s"] += time.perf_counter() - t
        return x

    def _contact_correction(self, cmask: np.ndarray) -> LowRankUpdate | None:
        """With friction, what turns the factorisation in hand (of the tangent's symmetric part
        when it was made) into the tangent now as far as the top nodes' contact blocks go: the
        blocks that changed by more than ``CONTACT_BLOCK_CHANGE`` of their node's penalty since
        (nodes that came into contact or left it, slipping nodes, whose blocks are unsymmetric),
        by :class:`LowRankUpdate`. None when nothing changed (or without friction). At most as
        many nodes as the factorisation keeps columns for (``max_extra``), the largest changes
        first."""
        if (
            not self._penalised
            or self._contact_blocks is None
            or self._factored_contact_blocks is None
            or self.linear.factor_mask is None
        ):
            return None
        made = self._correction  # the same blocks and factorisation: the same correction
        if made is not None and made[0] is self._contact_blocks and made[1] == self.stats["factorizations"]:
            return made[2]
        update = self._contact_update(cmask)
        self._correction = (self._contact_blocks, self.stats["factorizations"], update)
        return update

    def _contact_update(self, cmask: np.ndarray) -> LowRankUpdate | None:
        """:meth:`_contact_correction` made anew."""
        change = self._contact_blocks - self._factored_contact_blocks
        size = np.abs(change).max(axis=(1, 2, 3, 4)) / self._cell_eps
        cells = np.flatnonzero(size > CONTACT_BLOCK_CHANGE)
        if cells.size == 0:
            return None
        k = change.shape[1]
        cap = max(1, self.linear.max_extra // (3 * k))
        if cells.size > cap:
            cells = cells[np.argsort(-size[cells], kind="stable")[:cap]]
        cell_dofs = self._points.cell_dofs(self.top)[cells]  # (m, k, 3)
        dofs, local = np.unique(cell_dofs, return_inverse=True)
        local = local.reshape(cell_dofs.shape)
        rows = np.broadcast_to(local[:, :, :, None, None], change[cells].shape)
        cols = np.broadcast_to(local[:, None, None, :, :], change[cells].shape)
        D = np.zeros((dofs.size, dofs.size))  # the changed cells' blocks, summed where they share nodes
        np.add.at(D, (rows.ravel(), cols.ravel()), change[cells].ravel())
        held = cmask[dofs]  # supports and symmetry planes stay eliminated
        D[held, :] = 0.0
        D[:, held] = 0.0
        return LowRankUpdate(self.linear, dofs, D)

    def _precondition(self, r: np.ndarray, cmask: np.ndarray, correction: LowRankUpdate | None) -> np.ndarray:
        """The factorisation in hand applied to ``r`` (``cmask``'s dofs held at zero), with the
        contact blocks' ``correction`` (:meth:`_contact_correction`)."""
        y = self.linear.solve_constrained(r, cmask)
        if correction is None:
            return y
        y = correction.apply(y)
        y[cmask] = 0.0
        return y

    def _constraints(self, contact: StickContactState, depth: float) -> tuple[np.ndarray, np.ndarray]:
        """Mask of constrained dofs (3n,) and their prescribed displacement values."""
        mask = self.bc_fixed.copy()
        values = np.zeros((self.mesh.n_nodes, 3))
        att = self.top[contact.attached]
        mask[att] = True
        values[att] = contact.prescribed_displacement(depth)[contact.attached]
        values[self.bc_fixed] = 0.0
        mask = mask.ravel()
        return mask, values.ravel()[mask]

    def equilibrate(self, u0: np.ndarray, cmask: np.ndarray, target: np.ndarray) -> _Equilibrium:
        """Newton-Raphson to equilibrium with the dofs in ``cmask`` prescribed to ``target``.

        The first iteration carries the prescribed increments into the body through the exact
        tangent (consistent predictor). The corrections reuse that factorisation while the
        residual contracts by at least ``REFACTOR_RATIO`` per iteration (``MAX_STALE_STEPS`` in
        a row at most) and take a Newton step with the tangent at the current state otherwise
        (:meth:`_newton_step`), so most corrections cost a residual and a back-substitution. A correction with an old factorisation that makes
        the residual worse is undone and redone as a full Newton step; a step that inverts an
        element is halved. The residual is checked on the free dofs against the reactions."""
        opts = self.spec.solver
        u = u0.reshape(-1).copy()
        jump = np.zeros(self.n_dofs)
        jump[cmask] = target - u[cmask]
        want_dR = self._sensitivities
        try:
            R, K, _ = self.assemble(u.reshape(-1, 3))
            rhs = -(R + K @ jump)
            rhs[cmask] = 0.0
            # the first step: the constrained dofs jump to their targets, the free ones follow by
            # a Newton step; if that inverts an element, it is halved like any other (below)
            u_prev = u + jump
            du = -self._newton_step(K, cmask, rhs)
            u = u_prev - du
            last = np.inf  # residual norm before the last step
            fresh_step = False  # the last step was taken with a factorisation made at its start
            halvings = 0
            stale_steps = 0  # corrections in a row with the same factorisation
            for it in range(1, opts.max_newton + 1):
                try:
                    R, _, _ = self.assemble(u.reshape(-1, 3), tangent=False)
                except InvertedElementError:
                    if halvings >= MAX_HALVINGS:
                        raise
                    halvings += 1  # the step inverted an element: halve it
                    log.debug("newton %d: an element inverted, step halved (%d)", it, halvings)
                    du *= 0.5
                    u = u_prev - du
                    continue
                norm = np.linalg.norm(np.where(cmask, 0.0, R))
                ref = max(np.linalg.norm(R[cmask]), self._force_scale)
                log.debug("newton %d: residual %.3e of %.3e", it, norm, ref)
                at_round_off = fresh_step and norm > 0.5 * last and norm <= 1e-6 * ref
                if norm <= opts.residual_tol * ref or at_round_off:
                    K = dR = None
                    if want_dR:
                        _, K, dR = self.assemble(u.reshape(-1, 3), parameter_derivatives=True)
                    return _Equilibrium(u.reshape(-1, 3), R, K, it, dR)
                if norm > last and not fresh_step:  # a step with an old factorisation made it worse: undo it
                    u, norm = u_prev, last
                    R, _, _ = self.assemble(u.reshape(-1, 3), tangent=False)
                worn = norm > REFACTOR_RATIO * last or stale_steps >= MAX_STALE_STEPS
                r_free = np.where(cmask, 0.0, R)
                fresh_step = worn or norm == last
                if fresh_step:  # a Newton step with the tangent here
                    du = self._newton_step(self.assemble(u.reshape(-1, 3))[1], cmask, r_free)
                    stale_steps = 0
                else:  # a correction with the factorisation made elsewhere
                    du = self._solve(r_free, cmask)
                last, u_prev = norm, u.copy()
                u = u - du
                stale_steps += 1
        except (InvertedElementError, LinearSolveError) as exc:
            raise _IncrementFailed(str(exc)) from exc
        raise _IncrementFailed(f"Newton did not converge in {opts.max_newton} iterations")

    def _equilibrate_friction(self, u0: np.ndarray, cmask: np.ndarray) -> _Equilibrium:
        """Newton-Raphson to equilibrium with the frictional contact's forces in the residual
        (the supports in ``cmask`` held at zero), damped. As in :meth:`equilibrate`, corrections
        reuse the factorisation in hand while the residual contracts by at least
        ``REFACTOR_RATIO`` (``MAX_STALE_STEPS`` in a row at most), and take a Newton step with
        the tangent at the current state otherwise (:meth:`_newton_step`). Every step is
        shortened so that no slipping node passes its anchor
        (:meth:`FrictionContactState.step_fraction`); a Newton step is then halved until the
        residual falls (a full step can overshoot where a node slides along the indenter, with
        little but the body's shear stiffness to hold it, against the penalty's stiffness
        across), and a correction that does not lower it is replaced by a Newton step."""
        opts = self.spec.solver
        u = u0.reshape(-1).copy()
        try:
            R, K, _ = self.assemble(u.reshape(-1, 3))
        except InvertedElementError as exc:
            raise _IncrementFailed(str(exc)) from exc
        last, stale_steps, fresh_step, exact = np.inf, MAX_STALE_STEPS, True, False
        for it in range(1, FRICTION_NEWTON + 1):
            norm = np.linalg.norm(np.where(cmask, 0.0, R))
            ref = max(np.linalg.norm(R[cmask]), self._force_scale)
            log.debug("newton %d: residual %.3e of %.3e", it, norm, ref)
            at_round_off = fresh_step and norm > 0.5 * last and norm <= 1e-6 * ref  # no more to gain
            if norm <= opts.residual_tol * ref or at_round_off:
                K_out = dR = None
                if self._sensitivities:
                    _, K_out, dR = self.assemble(u.reshape(-1, 3), parameter_derivatives=True)
                return _Equilibrium(u.reshape(-1, 3), R, K_out, it, dR)
            r_free = np.where(cmask, 0.0, R)
            step = None
            worn = norm > REFACTOR_RATIO * last or stale_steps >= MAX_STALE_STEPS
            if not worn and self.linear.covers(cmask):  # a correction with the factorisation in hand
                try:
                    step = self._damped_step(u, self._solve(r_free, cmask), norm, cmask, halve=False)
                except LinearSolveError:
                    step = None
                stale_steps += 1
            fresh_step = step is None
            if fresh_step:  # a Newton step with the tangent here
                if K is None:
                    _, K, _ = self.assemble(u.reshape(-1, 3))
                try:
                    if exact:  # the last step did not lower the residual: a factorisation here
                        du = self._fresh_step(K, cmask, r_free)
                    else:  # an inexact Newton step, as exact as the residual is far above the reactions
                        du = self._newton_step(K, cmask, r_free, KRYLOV_RTOL * min(1.0, ref / norm))
                except LinearSolveError as exc:
                    raise _IncrementFailed(str(exc)) from exc
                step = self._damped_step(u, du, norm, cmask, halve=True)
                stale_steps = 0
            u, R = step
            exact = np.linalg.norm(np.where(cmask, 0.0, R)) >= norm
            K, last = None, norm
            if it <= STATUS_NEWTON_UPDATES and self._statuses_follow(u):
                # the residual with the statuses this state calls for; the next step is a Newton step
                R, _, _ = self.assemble(u.reshape(-1, 3), tangent=False)
                last, exact, stale_steps = np.inf, False, MAX_STALE_STEPS
        raise _IncrementFailed(f"Newton did not converge in {FRICTION_NEWTON} iterations")

    def _statuses_follow(self, u: np.ndarray) -> bool:
        """Within a Newton solve, hold the contact statuses the state ``u`` calls for (a
        semi-smooth Newton step on the active set); whether they changed."""
        c = self._friction_state
        top = u.reshape(-1, 3)[self.top]
        wanted = c.settled_status(
            self._points.to_points(top), self._friction_depth, self._status_tolerance(c, u.reshape(-1, 3))
        )
        if self._holding:
            wanted = np.maximum(wanted, c.status)
        if np.array_equal(wanted, c.status):
            return False
        c.status = wanted
        return True

    def _damped_step(
        self, u: np.ndarray, du: np.ndarray, norm: float, cmask: np.ndarray, halve: bool
    ) -> tuple[np.ndarray, np.ndarray] | None:
        """The state ``u - alpha du`` and its residual, ``du`` first shortened so that no
        slipping node passes its anchor (:meth:`FrictionContactState.step_fraction`): with
        ``halve``, alpha halved until the residual falls below ``norm`` (else the best trial);
        without, the whole step if it lowers the residual, else None."""
        c, top, pts = self._friction_state, self.top, self._points
        du = du * c.step_fraction(
            pts.to_points(u.reshape(-1, 3)[top]), pts.to_points(-du.reshape(-1, 3)[top]), self._friction_depth
        )
        alpha, best = 1.0, None
        for _ in range(MAX_HALVINGS + 2 if halve else 1):
            trial = u - alpha * du
            try:
                R_try, _, _ = self.assemble(trial.reshape(-1, 3), tangent=False)
            except InvertedElementError:
                alpha *= 0.5
                continue
            n_try = np.linalg.norm(np.where(cmask, 0.0, R_try))
            if best is None or n_try < best[0]:
                best = (n_try, trial, R_try)
            if n_try < norm:
                return trial, R_try
            alpha *= 0.5
        if not halve:
            return None
        if best is None:
            raise _IncrementFailed("every Newton step inverted an element")
        return best[1], best[2]

    def _reaction_top(self, R: np.ndarray) -> np.ndarray:
        """External force on the top nodes, with the components that symmetry planes carry zeroed."""
        r = R.reshape(-1, 3)[self.top].copy()
        on_x = np.isin(self.top, self.mesh.xsym)
        on_y = np.isin(self.top, self.mesh.ysym)
        r[on_x, 0] = 0.0
        r[on_y, 1] = 0.0
        return r

    def _increment(
        self,
        u: np.ndarray,
        u_pred: np.ndarray,
        d0: float,
        d1: float,
        contact: StickContactState,
        du_start: np.ndarray | None,
        du_pred: np.ndarray | None = None,
    ) -> tuple[_Equilibrium, StickContactState, int, int, np.ndarray | None]:
        """Solve the increment d0 -> d1. Returns the equilibrium, the contact set, Newton
        iterations, contact passes and (with sensitivities) d u / d theta (n, 3, p)."""
        c = contact.copy()
        u_top0 = u[self.top]
        released = np.zeros_like(c.attached)
        trial = u_pred
        iters = 0
        tol_pen = 1e-9 * self.sphere.radius
        sens = None
        # nodes the predicted state pushes into the sphere are attached where the predicted path
        # crosses its surface, which usually spares a second contact pass
        s0_top = du_start[self.top] if du_start is not None else None
        sp_top = du_pred[self.top] if du_pred is not None else None
        ahead = np.flatnonzero(c.penetrating(u_pred[self.top], d1, tol_pen))
        c.attach(ahead, u_top0, d0, u_pred[self.top], d1, s0_top, sp_top)
        for passes in range(1, self.spec.solver.max_contact_passes + 1):
            cmask, target = self._constraints(c, d1)
            eq = self.equilibrate(trial, cmask, target)
            iters += eq.iterations
            trial = eq.u
            if self._sensitivities:
                sens = self._state_sensitivity(eq, cmask, c)
            normal = c.normal_reaction(self._reaction_top(eq.R))
            tol_t = 1e-9 * max(float(np.abs(normal).max(initial=0.0)), self._force_scale)
            pulling = c.attached & (normal < -tol_t)
            pen = c.penetrating(trial[self.top], d1, tol_pen)
            if not pulling.any() and not pen.any():
                return eq, c, iters, passes, sens
            c.attached[pulling] = False
            released |= pulling
            s_top = sens[self.top] if sens is not None else None
            again = np.flatnonzero(pen & released)  # slipped back in: re-attach where it is now
            c.attach(again, trial[self.top], d1, trial[self.top], d1, s_top, s_top)
            new = np.flatnonzero(pen & ~released)
            c.attach(new, u_top0, d0, trial[self.top], d1, s0_top, s_top)
        raise _IncrementFailed("the contact set did not settle")

    def _increment_friction(
        self,
        u: np.ndarray,
        u_pred: np.ndarray,
        d0: float,
        d1: float,
        contact: FrictionContactState,
        du_start: np.ndarray | None,
        du_pred: np.ndarray | None = None,
    ) -> tuple[_Equilibrium, FrictionContactState, int, int, np.ndarray | None]:
        """Solve the increment d0 -> d1 with a penalty contact: Newton solves with the sphere's
        penalty forces in the residual and each contact point's status held, until the statuses
        the solution calls for are those it was solved with; then the anchors of slipping points
        move (:meth:`FrictionContactState.settle`)."""
        c = contact.copy()
        top = self.top
        at_points = self._points.to_points
        s0_top = at_points(du_start[top]) if du_start is not None else None
        sp_top = at_points(du_pred[top]) if du_pred is not None else None
        c.anchor_newcomers(at_points(u[top]), d0, at_points(u_pred[top]), d1, s0_top, sp_top)
        tol = 1e-9 * self.sphere.radius
        c.status = c.settled_status(at_points(u_pred[top]), d1, tol)
        cmask = self.bc_fixed.ravel()
        trial, iters, seen = u_pred, 0, set()
        self._friction_state, self._friction_depth, self._holding = c, d1, False
        try:
            for passes in range(1, self.spec.solver.max_contact_passes + 1):
                eq = self._equilibrate_friction(trial, cmask)
                iters += eq.iterations
                trial = eq.u
                wanted = c.settled_status(at_points(eq.u[top]), d1, self._status_tolerance(c, eq.u))
                log.debug(
                    "friction pass %d: %d come into contact, %d leave it",
                    passes,
                    int(((wanted != FREE) & (c.status == FREE)).sum()),
                    int(((wanted == FREE) & (c.status != FREE)).sum()),
                )
                if np.array_equal(wanted, c.status):
                    break
                seen.add(c.status.tobytes())
                self._holding = passes >= HOLDING_PASS  # the set wanders: from now on nothing leaves
                if (
                    wanted.tobytes() in seen or self._holding
                ):  # the statuses cycle: keep every node in contact
                    wanted = np.maximum(wanted, c.status)
                    if np.array_equal(wanted, c.status):
                        log.debug("friction pass %d: contact set cycles; kept the nodes it holds", passes)
                        break
                c.status = wanted
            else:
                raise _IncrementFailed("the contact set did not settle")
            try:
                sens = self._friction_sensitivity(eq, cmask, c) if self._sensitivities else None
            except LinearSolveError as exc:  # an increment that fails, cut back like any other
                raise _IncrementFailed(str(exc)) from exc
        finally:
            self._friction_state = None
        c.settle(at_points(eq.u[top]), d1, at_points(sens[top]) if sens is not None else None)
        return eq, c, iters, passes, sens

    def _status_tolerance(self, contact: FrictionContactState, u: np.ndarray) -> np.ndarray:
        """How far (mm) each contact point may be inside the sphere while free, or outside its
        anchor's plane while held, before its status changes: the gap at which its penalty force
        is ``STATUS_FORCE_FRACTION`` of the indenter's force (at least 1e-9 R). A point at the
        contact's edge whose force is that small otherwise toggles from pass to pass."""
        resp = contact.response(self._points.to_points(u[self.top]), self._friction_depth)
        total = max(float(np.abs(resp.pressure).sum()), self._force_scale)
        return np.maximum(1e-9 * self.sphere.radius, STATUS_FORCE_FRACTION * total / self._contact_eps)

    def _friction_sensitivity(
        self, eq: _Equilibrium, cmask: np.ndarray, contact: FrictionContactState
    ) -> np.ndarray:
        """d u / d theta (n, 3, p) for theta = (c1, c5, mu) (p = 3) of a converged frictional
        state, or (c1, c5) (p = 2) of the penalty stick: (K - df/du) du = -dR/dtheta + (d f /
        d theta at fixed positions: the anchors' history and mu), solved by Krylov on the exact
        tangent preconditioned with the factorisation in hand, or by factorising it."""
        pts, n_p = self._points, contact.n_params
        resp = contact.response(pts.to_points(eq.u[self.top]), self._friction_depth)
        b = np.zeros((self.n_dofs, n_p))
        b[:, :2] = -eq.dR
        explicit = contact.explicit_force_derivative(resp, n_p)  # (points, 3, p)
        b.reshape(-1, 3, n_p)[self.top] += pts.to_nodes(explicit)
        b[cmask] = 0.0
        x = np.zeros_like(b)
        for k in range(n_p):
            col = self._krylov(eq.K, cmask, b[:, k], SENSITIVITY_RTOL, self._krylov_maxiter())
            if col is None:  # factorise: with the contact correction GMRES converges at once
                self._factorize(eq.K, cmask)
                col = self._krylov(eq.K, cmask, b[:, k], SENSITIVITY_RTOL, 100)
                if col is None:
                    raise LinearSolveError("the sensitivity solve did not converge")
            x[:, k] = col
        return x.reshape(-1, 3, n_p)

    def _state_sensitivity(
        self, eq: _Equilibrium, cmask: np.ndarray, contact: StickContactState
    ) -> np.ndarray:
        """d u / d theta (n, 3, p) of a converged state: K_ff du_f = -(dR_f + K_fc du_c), where
        du_c is the anchors' derivative at attached nodes (0 at supports). Solved by CG on the
        exact converged tangent, preconditioned with the factorisation in hand."""
        n_p = eq.dR.shape[1]
        jump = np.zeros((self.mesh.n_nodes, 3, n_p))
        att = self.top[contact.attached]
        jump[att] = contact.danchor[contact.attached]
        jump[self.bc_fixed] = 0.0
        jump = jump.reshape(-1, n_p)
        b = -(eq.dR + eq.K @ jump)
        b[cmask] = 0.0
        x = np.zeros_like(b)
        maxiter = self._krylov_maxiter()
        for k in range(n_p):  # CG on the exact tangent, preconditioned with the factorisation in hand
            col = (
                self._krylov(eq.K, cmask, b[:, k], SENSITIVITY_RTOL, maxiter)
                if self.linear.covers(cmask)
                else None
            )
            if col is None:  # that factorisation is too far from this tangent: factorise it
                self._factorize(eq.K, cmask)
                col = self._krylov(eq.K, cmask, b[:, k], SENSITIVITY_RTOL, 100)
                if col is None:
                    raise LinearSolveError("the sensitivity solve did not converge")
            x[:, k] = col
        return (x + jump).reshape(-1, 3, n_p)

    # ------------------------------------------------------------------ driver
    def run(
        self,
        sensitivities: bool = False,
        progress: Callable[[int, int, float], None] | None = None,
        full_field: bool = False,
        *,
        threads: int | None = None,
    ) -> SimulationResult:
        """Run the protocol; ``progress(step, steps, force)`` is called after each step;
        ``full_field`` keeps every node's displacement per step (for VTU export). ``threads``:
        numba's and MKL's thread count for this run; None takes the idle cores
        (:func:`forward.threads.solver_threads`), a campaign worker passes 1. The linear
        solver's memory (PARDISO keeps its factors outside Python) is freed at the end."""
        if sensitivities and not self._mat.homogeneous:
            raise ValueError(
                "sensitivities are those of the homogeneous model's (c1, c5); a composite has none"
            )
        try:
            with thread_limits(solver_threads() if threads is None else threads):
                result = self._run(sensitivities, progress, full_field)
        finally:
            self.linear.release()
        return result

    def _run(
        self,
        sensitivities: bool,
        progress: Callable[[int, int, float], None] | None,
        full_field: bool = False,
    ) -> SimulationResult:
        t_start = time.perf_counter()
        self._sensitivities = sensitivities
        proto, opts = self.spec.protocol, self.spec.solver
        n, nt = self.mesh.n_nodes, self.top.size
        u = np.zeros((n, 3))
        last_inc = np.zeros((n, 3))
        last_dd = 0.0
        friction = self._penalised  # a penalty contact at contact points (friction or stick)
        n_p = 2 if self.friction is None else 3  # theta = (c1, c5), and mu with friction
        contact = (
            FrictionContactState(
                self.sphere,
                self._points.xyz0,
                self._contact_eps,
                np.inf if self.friction is None else self.friction,
                n_params=n_p,
            )
            if friction
            else StickContactState(self.sphere, self.mesh.nodes[self.top])
        )
        increment = self._increment_friction if friction else self._increment
        depths = [0.0]
        forces = [0.0]
        disp = [np.zeros((nt, 3))]
        self._status = [np.zeros(nt, np.int8)]
        self._full = [np.zeros((n, 3))] if full_field else None
        conv = {
            k: [0]
            for k in (
                "newton_iterations",
                "increments",
                "cutbacks",
                "contact_passes",
                "attached_nodes",
            )
        }
        conv["wall_s"] = [0.0]
        f_sens = [np.zeros(n_p)]
        u_sens = [np.zeros((nt, 3, n_p))]
        du_dtheta = np.zeros((n, 3, n_p)) if sensitivities else None
        last_dinc = np.zeros((n, 3, n_p)) if sensitivities else None
        d = 0.0
        nominal = proto.step_size / opts.substeps
        for k, d_target in enumerate(proto.depths, start=1):
            t_step = time.perf_counter()
            rec = dict.fromkeys(("newton_iterations", "increments", "cutbacks", "contact_passes"), 0)
            inc = nominal
            eq = None
            while d < d_target - 1e-12:
                dd = min(inc, d_target - d)
                if d_target - (d + dd) < 1e-9 * proto.step_size:
                    dd = d_target - d
                ratio = dd / last_dd if last_dd > 0 else 0.0
                u_pred = u + ratio * last_inc
                du_pred = du_dtheta + ratio * last_dinc if sensitivities else None
                try:
                    eq, contact_new, its, passes, sens = increment(
                        u, u_pred, d, d + dd, contact, du_dtheta, du_pred
                    )
                except _IncrementFailed as exc:
                    log.debug("increment %.4g -> %.4g mm failed: %s", d, d + dd, exc)
                    rec["cutbacks"] += 1
                    smallest = dd <= nominal * 2.0**-opts.max_cutbacks * (1.0 + 1e-9)
                    if smallest or rec["cutbacks"] > CUTBACK_BUDGET * max(opts.max_cutbacks, 1):
                        partial = self._result(
                            depths, forces, disp, conv, f_sens, u_sens, sensitivities, t_start
                        )
                        raise SimulationError(
                            f"simulation failed at depth {d + dd:.4g} mm (last converged {d:.4g} mm of "
                            f"{proto.max_depth:g}): {exc}",
                            depth_reached=d,
                            partial=partial,
                        ) from exc
                    inc = dd / 2.0
                    continue
                last_inc = eq.u - u
                last_dd = dd
                u = eq.u
                contact = contact_new
                if sensitivities:
                    last_dinc = sens - du_dtheta
                du_dtheta = sens
                d += dd
                rec["newton_iterations"] += its
                rec["increments"] += 1
                rec["contact_passes"] += passes
                inc = min(nominal, 2.0 * inc)
            assert eq is not None
            if friction:
                F_quarter = -float(np.sum(contact.force[:, 2]))
            else:
                F_quarter = -float(np.sum(eq.R.reshape(-1, 3)[self.top[contact.attached], 2]))
            depths.append(d_target)
            forces.append(SYMMETRY_FACTOR * F_quarter)
            disp.append(u[self.top].copy())
            if self._full is not None:
                self._full.append(u.copy())
            if sensitivities and friction:
                f_sens.append(-SYMMETRY_FACTOR * contact.dforce[:, 2].sum(axis=0))
                u_sens.append(du_dtheta[self.top].copy())
            elif sensitivities:
                dRc = eq.dR + eq.K @ du_dtheta.reshape(-1, 2)
                att = self.top[contact.attached]
                f_sens.append(-SYMMETRY_FACTOR * dRc.reshape(-1, 3, 2)[att, 2].sum(axis=0))
                u_sens.append(du_dtheta[self.top].copy())
            for key, val in rec.items():
                conv[key].append(val)
            attached = self._points.any_per_node(contact.attached) if friction else contact.attached
            slipping = self._points.any_per_node(contact.slipping) if friction else False
            conv["attached_nodes"].append(int(attached.sum()))
            self._status.append(attached.astype(np.int8) + slipping)
            if self.friction is not None:
                conv.setdefault("slipping_nodes", [0]).append(int(np.sum(slipping)))
            conv["wall_s"].append(time.perf_counter() - t_step)
            if progress is not None:
                progress(k, proto.steps, forces[-1])
        return self._result(depths, forces, disp, conv, f_sens, u_sens, sensitivities, t_start)

    def _contact_description(self) -> str:
        """One line on the contact this run used (the result file's ``solver.contact``)."""
        c = self.spec.contact
        if not c.penalised:
            return "rigid sphere, node-to-surface stick (attach at path crossing, release on tension)"
        if c.integration == "node":
            where = f"node-to-surface penalty ({c.penalty:g} kPa/mm by tributary area)"
        else:
            where = f"surface-to-surface penalty ({c.penalty:g} kPa/mm at {c.order}x{c.order} Gauss points per top face)"
        law = "stick (mu = inf)" if c.friction is None else f"Coulomb friction mu = {c.friction:g}"
        return f"rigid sphere, {where}, {law} (return map from anchors)"

    def _result(self, depths, forces, disp, conv, f_sens, u_sens, sensitivities, t_start) -> SimulationResult:
        mesh = self.mesh
        return SimulationResult(
            depth=np.asarray(depths),
            force=np.asarray(forces),
            top_node_ids=mesh.node_ids[self.top],
            top_xyz=mesh.nodes[self.top],
            displacement=np.asarray(disp),
            full_displacement=np.asarray(self._full) if self._full is not None else None,
            spec=self.spec.to_dict(),
            solver={
                "name": self.name,
                "version": __version__,
                "element": "hex8 three-field (mean dilatation), 2x2x2 Gauss",
                "contact": self._contact_description(),
                "sensitivity_parameters": ["c1", "c5"] + ([] if self.friction is None else ["mu"]),
                "linear_solver": self.linear_solver,
                "factorisation": "single precision" if self.linear.single_precision else "double precision",
                "mesh": {"source": mesh.source, "nodes": mesh.n_nodes, "elements": mesh.n_elements},
                "stats": dict(self.stats),
            },
            convergence={k: np.asarray(v) for k, v in conv.items()},
            wall_s=time.perf_counter() - t_start,
            force_sensitivity=np.asarray(f_sens) if sensitivities else None,
            displacement_sensitivity=np.asarray(u_sens) if sensitivities else None,
            parameters=("c1", "c5") if self.friction is None else ("c1", "c5", "mu"),
            contact_status=np.asarray(self._status, np.int8),
        )


def simulate(
    spec: ModelSpec, mesh: BlockMesh | None = None, sensitivities: bool = False, **kwargs
) -> SimulationResult:
    """Run one simulation of ``spec`` on the embedded solver."""
    return EmbeddedSolver(spec, mesh, **kwargs).run(sensitivities=sensitivities)
