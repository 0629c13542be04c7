"""From raw experiment data to what the objective compares with the model (paper 2.7, 2.8.1).

* :func:`relaxation_fit`: eq. 9, f(t) = A exp(-b t) + f_inf, per step (scipy curve_fit), giving
  the static force f_inf with its standard error.
* :func:`fit_sphere`: the indenter's sphere from its tracked points (linear least squares); its
  lowest point is the indentation point and the origin of the model frame.
* :func:`fiber_angle_from_strain`: the fiber direction from the principal directions of the
  measured in-plane strain around the indenter (the stiff fibers stretch least).
* :func:`to_model_frame`: level the DIC data (the plane of its reference positions is the top
  face, :mod:`.specimen_frame`; DIC in camera coordinates comes out in the specimen's frame),
  translate to the indentation point and rotate about z so that +y runs along the fibers.
* :func:`dic_to_nodes`: the DIC displacements at the FE top-surface nodes by a proximity-weighted
  least-squares plane through neighbouring DIC points in the reference configuration (scipy
  cKDTree); the full field is folded onto the quarter model by the symmetry planes (x -> |x| with
  ux -> sign(x) ux, the same for y) and mirrored back across them; nodes whose neighbours do not
  surround them, or lie too far, are obscured (weight 0).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import sparse
from scipy.spatial import cKDTree

from ...design.objective import Objective
from .data import ExperimentData, ExperimentDataError
from .relaxation import RelaxationFit, relaxation_fit  # noqa: F401 (eq. 9's names, kept here too)
from .specimen_frame import SpecimenFrame, specimen_frame


def static_forces(exp: ExperimentData) -> tuple[np.ndarray, np.ndarray]:
    """The static force f_inf and its standard error per step 1..N, fitted by eq. 9 to each hold.

    Parameters
    ----------
    exp : ExperimentData
        The experiment.

    Returns
    -------
    f_inf : numpy.ndarray
        (N,) the static force per step, mN; NaN for the excluded steps.
    f_std : numpy.ndarray
        (N,) its standard error, mN.
    """
    f_inf, f_std = np.full(exp.steps, np.nan), np.full(exp.steps, np.nan)
    for k in exp.used_steps:
        g = exp.force[exp.force["step"] == k]
        fit = relaxation_fit(g["time_s"].to_numpy(), g["force_mN"].to_numpy())
        f_inf[k - 1], f_std[k - 1] = fit.f_inf, fit.f_inf_std
    return f_inf, f_std


def fit_sphere(points: np.ndarray) -> tuple[np.ndarray, float]:
    """Centre (3,) and radius of the sphere through ``points`` (n, 3) in the least-squares sense of
    |x|^2 = 2 c.x + (R^2 - |c|^2)."""
    x = np.asarray(points, float)
    A = np.column_stack([2.0 * x, np.ones(len(x))])
    sol, *_ = np.linalg.lstsq(A, np.sum(x**2, axis=1), rcond=None)
    centre = sol[:3]
    r2 = sol[3] + centre @ centre
    if not r2 > 0:
        raise ExperimentDataError("the indenter points do not lie on a sphere")
    return centre, float(np.sqrt(r2))


def _noise_neighbours(
    xy: np.ndarray, u: np.ndarray, neighbours: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The DIC points of one step that a noise estimate compares: the correlated ones' displacements
    ``u`` (n, 3), and of each its ``neighbours`` nearest others the indices (n, k) and the offsets
    (n, k, 2) from it (:func:`.data_check.dic_noise`, :func:`.adequacy.dic_noise_mm`).

    Raises ExperimentDataError if fewer than ``neighbours`` + 1 points are correlated."""
    ok = np.isfinite(u).all(axis=1)
    xy, u = xy[ok], u[ok]
    if len(xy) < neighbours + 1:
        raise ExperimentDataError(f"too few correlated DIC points ({len(xy)}) to estimate the noise")
    _, idx = cKDTree(xy).query(xy, k=neighbours + 1)
    idx = idx[:, 1:]
    return u, idx, xy[idx] - xy[:, None, :]


def in_plane_strain(xy: np.ndarray, u: np.ndarray, neighbours: int = 12) -> np.ndarray:
    """Green-Lagrange in-plane strain (n, 2, 2) at each point from a local least-squares fit of the
    displacement gradient over its nearest ``neighbours``."""
    ok = np.all(np.isfinite(u), axis=1)
    xy_ok, u_ok = xy[ok], u[ok][:, :2]
    _, idx = cKDTree(xy_ok).query(xy, k=min(neighbours, len(xy_ok)))
    dX = xy_ok[idx] - xy[:, None, :]  # (n, k, 2)
    dU = u_ok[idx] - u_ok[idx].mean(axis=1, keepdims=True)
    dX = dX - dX.mean(axis=1, keepdims=True)
    G = np.linalg.solve(
        np.einsum("nki,nkj->nij", dX, dX) + 1e-12 * np.eye(2), np.einsum("nki,nkj->nij", dX, dU)
    )
    H = np.transpose(G, (0, 2, 1))  # du_i / dX_j
    F = np.eye(2) + H
    return 0.5 * (np.einsum("nki,nkj->nij", F, F) - np.eye(2))


def fiber_angle_from_strain(xy: np.ndarray, u: np.ndarray, inner: float, outer: float) -> float:
    """Fiber direction (degrees from x, in [0, 180)) from the strain at the deepest step: the mean
    in-plane strain tensor over the ring ``inner`` < r < ``outer`` around the indentation point is
    isotropic for an isotropic material; fibers resist stretch, so its least principal direction
    is the fiber direction."""
    r = np.hypot(xy[:, 0], xy[:, 1])
    E = in_plane_strain(xy, u)
    ring = (r > inner) & (r < outer) & np.all(np.isfinite(u), axis=1)
    if ring.sum() < 10:
        raise ExperimentDataError("too few DIC points around the indenter to estimate the fiber direction")
    _, V = np.linalg.eigh(E[ring].mean(axis=0))
    v = V[:, 0]
    return float(np.degrees(np.arctan2(v[1], v[0])) % 180.0)


def rotation_to_fibers(angle_deg: float) -> np.ndarray:
    """The rotation about z (3, 3) that takes the fiber direction (angle from x) onto +y."""
    a = np.radians(90.0 - angle_deg)
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


@dataclass
class RegisteredDIC:
    xyz: np.ndarray  # (points, 3) in the model frame: origin at the indentation point, y along the fibers
    u: np.ndarray  # (steps, points, 3) in the model frame
    origin: np.ndarray  # the indentation point in the DIC frame
    fiber_angle_deg: float  # in the leveled frame (the DIC frame when its z is the face's normal)
    fiber_angle_estimated: bool
    sphere_radius: float
    sphere_rms: float = float("nan")  # RMS distance of the indenter points from the fitted sphere, mm
    rotation: np.ndarray | None = None  # DIC frame -> model frame (leveling, then about z to the fibers)
    frame: SpecimenFrame | None = None  # the specimen's top face found in the DIC data

    def to_dict(self) -> dict:
        """The registration a fit used (what ``fit --json`` reports): the origin (indentation
        point) and rotation DIC frame -> model frame, the sphere fit, the top face (normal, tilt,
        the points' spread about it, the indentation point's distance from it), the fibers."""
        out = {
            "origin_mm": self.origin.tolist(),
            "sphere_radius_mm": self.sphere_radius,
            "sphere_fit_rms_mm": self.sphere_rms,
            "rotation": None if self.rotation is None else self.rotation.tolist(),
            "fiber_angle_deg": self.fiber_angle_deg,
            "fiber_angle_estimated": self.fiber_angle_estimated,
        }
        if self.frame is not None:
            out.update(self.frame.to_dict())
        return out


def leveled_fiber_angle(angle_deg: float, frame: SpecimenFrame) -> float:
    """A fiber direction given in the DIC frame (degrees from x, as the camera sees it: the
    direction in the top face whose projection along the DIC z makes that angle with x) as its
    angle in the leveled frame."""
    a = np.radians(angle_deg)
    n = frame.normal
    f = np.array([np.cos(a), np.sin(a), -(n[0] * np.cos(a) + n[1] * np.sin(a)) / n[2]])
    f = frame.leveling @ f
    return float(np.degrees(np.arctan2(f[1], f[0])) % 180.0)


def to_model_frame(exp: ExperimentData) -> RegisteredDIC:
    """The DIC data registered to the model frame: origin at the indentation point, y along the fibers.

    The top face and its normal come from the plane of the DIC reference positions
    (:mod:`.specimen_frame`: DIC in camera coordinates is leveled; a point of indentation off the
    face is an error), the origin is the fitted sphere's point nearest the face, and y is along
    the fibers (given, or estimated from the strain field when the experiment does not say).

    Parameters
    ----------
    exp : ExperimentData
        The experiment.

    Returns
    -------
    RegisteredDIC
        Positions and displacements in the model frame, the origin, the fiber angle, the sphere
        fit and the rotation.
    """
    centre, radius = fit_sphere(exp.indenter_xyz)
    frame = specimen_frame(exp.dic_xyz, centre, radius)
    origin = frame.indentation_point_mm
    L = frame.leveling
    xyz_l = (exp.dic_xyz - origin) @ L.T
    u_l = exp.dic_u @ L.T
    estimated = exp.fiber_angle_deg is None
    angle = (
        fiber_angle_from_strain(xyz_l[:, :2], u_l[exp.used_steps[-1] - 1], 1.5 * exp.radius, 4.0 * exp.radius)
        if estimated
        else leveled_fiber_angle(exp.fiber_angle_deg, frame)
        if frame.tilt_deg > 0.0
        else exp.fiber_angle_deg
    )
    Q = rotation_to_fibers(angle)
    rms = float(np.sqrt(np.mean((np.linalg.norm(exp.indenter_xyz - centre, axis=1) - radius) ** 2)))
    return RegisteredDIC(
        xyz_l @ Q.T,
        u_l @ Q.T,
        origin=origin,
        fiber_angle_deg=float(angle),
        fiber_angle_estimated=estimated,
        sphere_radius=radius,
        sphere_rms=rms,
        rotation=Q @ L,
        frame=frame,
    )


def _step_mask(steps: int, used: np.ndarray) -> np.ndarray:
    """(steps, 1, 1): 1 for the steps used, 0 for the others."""
    mask = np.zeros((steps, 1, 1))
    mask[used] = 1.0
    return mask


#: A node counts as measured only when its DIC neighbours surround it: the widest angle between
#: the directions to them must stay below this (a node at the edge of the data, e.g. in the
#: indenter's shadow, sees them all on one side, and a plane through them would extrapolate).
MAX_NEIGHBOUR_GAP_DEG = 120.0


def unfold_by_symmetry(xy: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """DIC points (points, 2) and displacements (steps, points, 3) of the whole surface folded
    into the quarter x, y >= 0 and mirrored back across both symmetry planes (ux odd in x, uy
    odd in y), so that every quarter-model node, also on a symmetry line, has data on all sides."""
    sx, sy = np.where(xy[:, 0] < 0, -1.0, 1.0), np.where(xy[:, 1] < 0, -1.0, 1.0)
    folded = np.abs(xy)
    uf = u.copy()
    uf[..., 0] *= sx
    uf[..., 1] *= sy
    points, values = [], []
    for mx, my in ((1.0, 1.0), (-1.0, 1.0), (1.0, -1.0), (-1.0, -1.0)):
        points.append(folded * [mx, my])
        values.append(uf * [mx, my, 1.0])
    return np.concatenate(points), np.concatenate(values, axis=1)


@dataclass
class NodeInterpolation:
    """How :func:`dic_to_nodes` makes each FE top node's value from the DIC points: the weighted
    least-squares plane through its ``k`` nearest points (of those folded into the quarter model
    and mirrored back). A node's value is ``planes[:, 0]`` . u of its neighbours, its in-plane
    gradient ``planes[:, 1:]`` . u: linear in the DIC data, so the noise of the node values
    follows from it (:mod:`inference.adequacy`)."""

    points: np.ndarray  # (n_ok,) indices into the DIC points of those correlated at every step used
    neighbours: np.ndarray  # (nodes, k) indices into the unfolded points (copy * n_ok + point)
    planes: np.ndarray  # (nodes, 3, k): rows value, d/dx, d/dy of the plane at the node
    measured: np.ndarray  # (nodes,) bool: the node has data
    signs: np.ndarray  # (nodes, k, 3): the sign each neighbour's ux, uy, uz carries (folding, mirroring)

    def matrix(self, direction: int) -> sparse.csr_matrix:
        """(nodes, n_ok), sparse: node value of ``direction`` (0 ux, 1 uy, 2 uz) = this @ that
        direction of the points (0 for nodes without data); a point that is a neighbour twice (a
        node on a symmetry plane sees it and its mirror image) counts twice with its signs."""
        n_ok = len(self.points)
        rows = np.repeat(np.arange(len(self.neighbours)), self.neighbours.shape[1])
        w = (self.planes[:, 0, :] * self.signs[..., direction] * self.measured[:, None]).ravel()
        shape = (len(self.neighbours), n_ok)
        return sparse.csr_matrix((w, (rows, (self.neighbours % n_ok).ravel())), shape=shape)


#: The mirror images of :func:`unfold_by_symmetry`, in its order: (x, y) signs.
_MIRRORS = ((1.0, 1.0), (-1.0, 1.0), (1.0, -1.0), (-1.0, -1.0))


def node_interpolation(
    dic: RegisteredDIC,
    node_xy: np.ndarray,
    neighbours: int = 12,
    max_distance: float | None = None,
    used_steps: np.ndarray | None = None,
) -> NodeInterpolation:
    """The planes :func:`dic_to_nodes` interpolates with (its docstring says how they are chosen)."""
    xy = dic.xyz[:, :2]
    used = np.arange(dic.u.shape[0]) if used_steps is None else np.asarray(used_steps, int) - 1
    ok = np.all(np.isfinite(dic.u[used]), axis=(0, 2))  # points correlated at every step used
    if not ok.any():
        raise ExperimentDataError("no DIC point is correlated at every step")
    k = int(min(neighbours, 4 * int(ok.sum())))
    if k < 3:
        raise ExperimentDataError(f"a plane through the DIC points needs 3 of them, got {int(ok.sum())}")
    n_ok = int(ok.sum())
    pts = np.concatenate([np.abs(xy[ok]) * m for m in _MIRRORS])
    tree = cKDTree(pts)
    if max_distance is None:  # twice the typical reach of k neighbours among the DIC points
        # The unfolded set is its own mirror image, so each mirrored copy of a point has the same
        # distances to its neighbours (bit for bit: the coordinate differences only change sign):
        # the median over the first copy is the median over all four, at a quarter of the queries.
        d, _ = tree.query(pts[:n_ok], k=k + 1)
        max_distance = 2.0 * float(np.median(d[:, -1]))
    node_xy = np.asarray(node_xy, float)
    dist, idx = tree.query(node_xy, k=k)  # (nodes, k)
    dx = pts[idx] - node_xy[:, None, :]  # (nodes, k, 2)
    angle = np.sort(np.arctan2(dx[..., 1], dx[..., 0]), axis=1)
    gaps = np.diff(np.concatenate([angle, angle[:, :1] + 2.0 * np.pi], axis=1), axis=1)
    surrounded = gaps.max(axis=1) < np.deg2rad(MAX_NEIGHBOUR_GAP_DEG)
    w = (1.0 - dist / (1.0001 * dist[:, -1:] + 1e-12)) ** 2
    A = np.concatenate([np.ones((*dist.shape, 1)), dx], axis=2)  # (nodes, k, 3)
    AtW = np.transpose(A * w[..., None], (0, 2, 1))  # (nodes, 3, k)
    M = AtW @ A  # (nodes, 3, 3)
    # a node whose neighbours do not surround it well (all on a line) has a singular plane fit
    well_posed = np.linalg.cond(M) < 1e8
    measured = (dist[:, -1] <= max_distance) & well_posed & surrounded
    planes = np.linalg.solve(np.where(well_posed[:, None, None], M, np.eye(3)), AtW)  # (nodes, 3, k)
    fold = np.where(xy[ok] < 0, -1.0, 1.0)  # (n_ok, 2): the point's quadrant
    mirror = np.array(_MIRRORS)[idx // n_ok]  # (nodes, k, 2)
    signs = np.ones((*idx.shape, 3))
    signs[..., :2] = fold[idx % n_ok] * mirror
    return NodeInterpolation(np.flatnonzero(ok), idx, planes, measured, signs)


def dic_to_nodes(
    dic: RegisteredDIC,
    node_xy: np.ndarray,
    neighbours: int = 12,
    max_distance: float | None = None,
    used_steps: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Displacements (steps, nodes, 3) at the FE top nodes ``node_xy`` (nodes, 2) and the mask of
    nodes with data, from the ``neighbours`` nearest DIC points of each node in the reference
    configuration (folded into the quarter model and mirrored across its symmetry planes),
    weighted by proximity (1 - d / d_max)^2 with d_max just beyond the farthest of them: a
    weighted least-squares plane through them (u = a + b . (x - x_node)), whose value at the node
    is a proximity-weighted average of the points that is exact for a field varying linearly (a
    plain average is biased where the field is steep, next to the indenter, where Appendix B
    weighs most). A node is obscured (no data, weight 0) where its neighbours do not surround it
    (``MAX_NEIGHBOUR_GAP_DEG``: the edge of the field of view, the indenter's shadow) or lie
    farther than ``max_distance`` (default twice the median distance of a DIC point to its k-th
    neighbour). ``used_steps`` (1..N; default all) are the steps that count: a point needs to be
    correlated in those only, and the other steps' displacements are returned as 0."""
    plan = node_interpolation(dic, node_xy, neighbours, max_distance, used_steps)
    used = np.arange(dic.u.shape[0]) if used_steps is None else np.asarray(used_steps, int) - 1
    u = np.nan_to_num(dic.u[:, plan.points]) * _step_mask(dic.u.shape[0], used)  # (steps, n_ok, 3)
    n_ok = len(plan.points)
    U = u[:, plan.neighbours % n_ok] * plan.signs[None]  # (steps, nodes, k, 3)
    out = np.einsum("nk,snkd->snd", plan.planes[:, 0, :], U)
    out[:, ~plan.measured] = 0.0
    return out, plan.measured


def experiment_objective(exp: ExperimentData, top_xyz: np.ndarray, reading: str = "fit", excluded_steps=()):
    """The objective (eq. 4, 5) of a measured experiment against a model with top nodes ``top_xyz``.

    Static forces from eq. 9, DIC registered and interpolated at the nodes, nodes without data
    obscured.

    Parameters
    ----------
    exp : ExperimentData
        The experiment.
    top_xyz : numpy.ndarray
        (nodes, 3) the model's top nodes, mm.
    reading : str, default "fit"
        How eq. 4 is read (:class:`Objective`): by default the studio's fit objective, the
        paper's without the DIC rings from R to 1.5 R (design.nodal_weights).
    excluded_steps : sequence of int, default ()
        Steps (1..N) left out beside ``exp.excluded_steps``.

    Returns
    -------
    objective : Objective
        The objective against the data.
    dic : RegisteredDIC
        The registration (:func:`to_model_frame`).

    Raises
    ------
    ExperimentDataError
        If an excluded step is not in 1..N.
    """
    from dataclasses import replace

    bad = [k for k in excluded_steps if not 1 <= int(k) <= exp.steps]
    if bad:
        raise ExperimentDataError(f"excluded step(s) {bad} are not in 1..{exp.steps}")
    excluded = tuple(sorted(set(exp.excluded_steps) | {int(k) for k in excluded_steps}))
    if excluded != exp.excluded_steps:
        exp = replace(exp, excluded_steps=excluded)
    f_inf, _ = static_forces(exp)
    dic = to_model_frame(exp)
    u_nodes, measured = dic_to_nodes(dic, np.asarray(top_xyz)[:, :2], used_steps=exp.used_steps)
    objective = Objective(
        f_inf, u_nodes, top_xyz, radius=exp.radius, reading=reading, mask=measured, excluded_steps=excluded
    )
    return objective, dic
