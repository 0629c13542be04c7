"""The models an error budget fits, as the command line names them: a mesh preset, a contact
level, two presets extrapolated (Richardson), a FEBio .feb mesh, a surrogate file; ``@stick`` or
``@mu=VALUE`` for another contact."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

from ...forward.convergence.richardson import RichardsonPredictor
from ...forward.fe_predictor import FESolverPredictor
from ...forward.mesh_presets import CONTACT_MESH_LEVELS, MESH_PRESETS
from ...forward.predictor import CachedPredictor
from ...forward.spec import MeshChoice, ModelSpec
from ...surrogate.persistence import load_surrogate

__all__ = ["json_key", "resolve_model"]


def json_key(payload: dict) -> str:
    return json.dumps(payload, sort_keys=True)


def resolve_model(name: str, reference_spec, fe_cache: dict | None = None) -> tuple[object, object | None]:
    """The model a name on the command line gives, for an error budget.

    Parameters
    ----------
    name : str
        A mesh preset (the reference's model on that mesh), a FEBio .feb file's hex8 mesh,
        ``richardson:FINE,COARSE[,ORDER]`` (two presets extrapolated, :mod:`forward.convergence.richardson`)
        or a surrogate file; ``@stick`` or ``@mu=VALUE`` after a mesh or a .feb gives the model
        another contact (the bias a contact model causes: a stick model fitted to frictional
        data).
    reference_spec : ModelSpec
        The reference's model.
    fe_cache : dict, optional
        Mesh -> Predictor: FE models shared so that a mesh is solved once per test point whatever
        uses it.

    Returns
    -------
    predictor : Predictor
        The model.
    fe : Predictor or None
        The FE Predictor a surrogate emulates; None for an FE model.

    Raises
    ------
    ValueError
        If the contact suffix or the Richardson form is not understood, or the model is not of
        the reference's test.

    Examples
    --------
    >>> import indentation_studio as ins
    >>> stick, fe = ins.inference.resolve_model("coarse@stick", ins.ModelSpec().with_friction(0.3))
    >>> stick.spec.contact.friction is None, fe is None
    (True, True)
    """

    cache = {} if fe_cache is None else fe_cache
    name, _, contact = name.partition("@")
    if contact:  # the same model with another contact: PRESET@stick or PRESET@mu=0.3
        if contact == "stick":
            reference_spec = reference_spec.with_friction(None)
        elif contact.startswith("mu="):
            try:
                reference_spec = reference_spec.with_friction(float(contact[3:]))
            except ValueError as exc:
                raise ValueError(f"model {name}@{contact}: {exc}") from exc
        else:
            raise ValueError(f"model {name}@{contact}: the contact is @stick or @mu=VALUE")

    def fe(spec) -> CachedPredictor:
        key = json_key(spec.to_dict())
        if key not in cache:
            cache[key] = CachedPredictor(FESolverPredictor(spec))
        return cache[key]

    presets = {**MESH_PRESETS, **CONTACT_MESH_LEVELS}
    if name in presets:
        return fe(replace(reference_spec, mesh=MeshChoice(name))), None
    if name.startswith("richardson:"):
        parts = name.split(":", 1)[1].split(",")
        if len(parts) not in (2, 3) or not all(m in presets for m in parts[:2]):
            raise ValueError(f"model {name!r}: use richardson:FINE,COARSE[,ORDER] with mesh presets")
        fine, coarse = (fe(replace(reference_spec, mesh=MeshChoice(m))) for m in parts[:2])
        return RichardsonPredictor(fine, coarse, float(parts[2]) if len(parts) == 3 else 1.0), None
    path = Path(name)
    if path.suffix == ".feb":
        return fe(replace(reference_spec, mesh=MeshChoice(feb_file=str(path)))), None
    if not path.is_file():
        raise ValueError(
            f"model {name!r}: not a mesh preset ({', '.join(presets)}), richardson:FINE,COARSE, "
            ".feb file or surrogate file"
        )
    surrogate = load_surrogate(path)
    model = (surrogate.meta.get("campaign") or {}).get("model")
    return surrogate, (fe(ModelSpec.from_dict(model)) if model else None)
