"""Mesh convergence errors of the paper (eq. 1a, 1b) against a reference mesh's result."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np
from scipy.interpolate import LinearNDInterpolator, RegularGridInterpolator

from ..mesh import build_mesh
from ..result import SimulationResult
from ..solver import EmbeddedSolver
from ..spec import MeshChoice, ModelSpec
from ..stick_contact import RigidSphere


def top_field_interpolator(top_xyz: np.ndarray, field: np.ndarray):
    """Interpolator of a top-surface field ``field`` (n, ...) given at the top nodes ``top_xyz``,
    called with points (m, 2) clipped to the block. A structured top (a tensor grid) is
    interpolated bilinearly, as its own shape functions do; any other top (a FEBio mesh that is
    not a tensor grid) linearly on the Delaunay triangles of its nodes."""
    xy = np.asarray(top_xyz, float)[:, :2]
    field = np.asarray(field, float)
    x = np.unique(np.round(xy[:, 0], 9))
    y = np.unique(np.round(xy[:, 1], 9))
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    if x.size * y.size == xy.shape[0]:
        ix = np.searchsorted(x, np.round(xy[:, 0], 9))
        iy = np.searchsorted(y, np.round(xy[:, 1], 9))
        grid = np.empty((x.size, y.size, *field.shape[1:]))
        grid[ix, iy] = field
        interp = RegularGridInterpolator((x, y), grid, method="linear")
        lo, hi = np.array([x[0], y[0]]), np.array([x[-1], y[-1]])  # the grid's own (rounded) ends
    else:
        interp = LinearNDInterpolator(xy, field.reshape(field.shape[0], -1))

    def at(points: np.ndarray) -> np.ndarray:
        p = np.clip(np.asarray(points, float)[:, :2], lo, hi)
        return np.asarray(interp(p)).reshape((p.shape[0], *field.shape[1:]))

    return at


def interpolate_top_displacement(reference: SimulationResult, xy: np.ndarray, step: int = -1) -> np.ndarray:
    """The reference's top-surface displacement at step ``step`` interpolated at points ``xy``
    (n, 2), by :func:`top_field_interpolator`."""
    return top_field_interpolator(reference.top_xyz, reference.displacement[step])(xy)


@dataclass(frozen=True)
class MeshErrors:
    """E_f and E_u in percent.

    ``E_f_pct`` is eq. 1a as printed (with its 1/N_s factor), ``E_f_rel_pct`` the plain relative
    norm ||F - F_ref|| / ||F_ref|| (stricter by N_s). Eq. 1b averages over "the surface nodes of
    the contact surface between the indenter and the cube", which reads two ways, both given:
    ``E_u_contact_pct`` over the top nodes in contact with the indenter at the final depth
    (``contact_nodes`` of them), ``E_u_pct`` over every top node (the surface DIC sees).

    Attributes
    ----------
    E_f_pct : float
        Eq. 1a as printed, percent.
    E_f_rel_pct : float
        ||F - F_ref|| / ||F_ref||, percent.
    E_u_pct : float
        Eq. 1b over every top node, percent.
    E_u_contact_pct : float
        Eq. 1b over the top nodes in contact at the final depth, percent.
    contact_nodes : int
        How many those are.
    """

    E_f_pct: float
    E_f_rel_pct: float
    E_u_pct: float
    E_u_contact_pct: float = float("nan")
    contact_nodes: int = 0


def nodes_on_sphere(result: SimulationResult, step: int = -1, rtol: float = 1e-6) -> np.ndarray:
    """Mask of the top nodes lying on the indenter's surface at ``step`` (in contact): the
    sphere of the spec's radius whose lowest point is at the top minus the depth."""
    sphere = RigidSphere(float(result.spec["indenter"]["radius"]), float(np.max(result.top_xyz[:, 2])))
    centre = sphere.centre(float(result.depth[step]))
    gap = np.linalg.norm(result.top_xyz + result.displacement[step] - centre, axis=1) - sphere.radius
    return gap <= rtol * sphere.radius


def mesh_errors(result: SimulationResult, reference: SimulationResult) -> MeshErrors:
    """The mesh errors of eq. 1a (forces over all steps) and eq. 1b (final top displacements), percent.

    Parameters
    ----------
    result : SimulationResult
        The simulation on the mesh studied.
    reference : SimulationResult
        The same test on the reference mesh, interpolated at the result's top nodes.

    Returns
    -------
    MeshErrors
        E_f and E_u, both readings.

    Raises
    ------
    ValueError
        If the two do not share the protocol (depths).
    """
    if result.depth.shape != reference.depth.shape or not np.allclose(result.depth, reference.depth):
        raise ValueError("result and reference must share the protocol (depths)")
    F, Fr = result.force[1:], reference.force[1:]
    rel = float(np.linalg.norm(F - Fr) / np.linalg.norm(Fr))
    n_steps = F.size
    u = result.displacement[-1]
    ur = interpolate_top_displacement(reference, result.top_xyz[:, :2])
    norm_r = np.linalg.norm(ur, axis=1)
    keep = norm_r > 1e-12
    node_err = np.linalg.norm(u - ur, axis=1)[keep] / norm_r[keep]
    contact = nodes_on_sphere(result)[keep]
    E_u_contact = float(np.mean(node_err[contact])) if contact.any() else float("nan")
    return MeshErrors(
        100.0 * rel / n_steps,
        100.0 * rel,
        100.0 * float(np.mean(node_err)),
        100.0 * E_u_contact,
        int(contact.sum()),
    )


def solve_or_reuse(
    spec: ModelSpec,
    saved: Path | None,
    progress: Callable[[int, int, float], None] | None = None,
    say: Callable[[str], None] | None = None,
) -> SimulationResult:
    """``spec`` solved on the embedded solver, or read back from ``saved`` when that file holds the
    same spec on the same number of nodes (a reference mesh takes many minutes); a new result is
    kept in ``saved``."""
    if saved is not None and saved.exists():
        previous = SimulationResult.load(saved)
        nodes = build_mesh(spec).n_nodes if spec.mesh.feb_file is None else None
        if previous.spec == spec.to_dict() and previous.solver.get("mesh", {}).get("nodes") == nodes:
            if say is not None:
                say(f"mesh {spec.mesh.preset}: read {saved} (same spec)")
            return previous
    result = EmbeddedSolver(spec).run(progress=progress)
    if saved is not None:
        result.save(saved)
    return result


def convergence_study(
    spec: ModelSpec,
    presets: list[str],
    reference: str = "reference",
    out_dir: str | Path | None = None,
    progress: Callable[[str, int, int, float], None] | None = None,
    say: Callable[[str], None] | None = None,
) -> list[dict]:
    """Eq. 1a and 1b of each mesh preset in ``presets`` against ``reference``, all solved for ``spec``.

    The spec's own mesh choice is replaced by each preset.

    Parameters
    ----------
    spec : ModelSpec
        The test.
    presets : list of str
        The meshes to study.
    reference : str, default "reference"
        The reference mesh preset.
    out_dir : str or pathlib.Path, optional
        Each mesh's result is kept there as ``<preset>.npz`` and reused by later studies of the
        same spec.
    progress : callable, optional
        ``progress(preset, step, steps, force)`` during each solve.
    say : callable, optional
        Where to report reused results.

    Returns
    -------
    list of dict
        One row per preset: ``preset``, ``nodes``, ``elements``, the :class:`MeshErrors` fields
        and ``wall_s``.
    """
    folder = Path(out_dir) if out_dir is not None else None
    results = {}
    for name in [*presets, reference]:
        at = replace(spec, mesh=MeshChoice(name))
        report = None if progress is None else (lambda k, n, f, m=name: progress(m, k, n, f))
        results[name] = solve_or_reuse(at, None if folder is None else folder / f"{name}.npz", report, say)
    rows = []
    for name in presets:
        r = results[name]
        rows.append(
            {
                "preset": name,
                "nodes": r.solver["mesh"]["nodes"],
                "elements": r.solver["mesh"]["elements"],
                **asdict(mesh_errors(r, results[reference])),
                "wall_s": r.wall_s,
            }
        )
    return rows
