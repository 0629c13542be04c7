"""A DIC-like experiment made from a real FEBio run: its indenter force and top-node field, as a
lab's DIC system and load cell would record them (points over a field of view with the
indenter's shadow, noise, a registration error; :func:`inference.experiment.synthetic.write_synthetic_experiment`).

This is how the studio is checked against a solver it does not share code with: an experiment
made by FEBio 4 (its sliding-elastic contact, its three-field element) is fitted by the studio's
surrogate and FE model, as a measured one would be. Steps FEBio accepted off equilibrium
(:mod:`forward.febio.equilibrium`) have no force and are left out of the experiment."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from ...forward.febio.log import FebioLogError
from ...forward.febio.readback import logged_block_material, read_febio_run
from ...forward.predictor import Prediction, as_theta
from ...forward.spec import Indenter, Material, MeshChoice, ModelSpec, Protocol
from .data import load_experiment
from .folder import refuse_existing_experiment
from .synthetic import LAB_RECORDING, Recording, write_synthetic_experiment

__all__ = ["RecordedRun", "experiment_from_febio_run", "febio_contact", "febio_experiment_summary"]


class RecordedRun:
    """A Predictor that knows one parameter point: a recorded simulation.

    Its force is NaN at steps off equilibrium. Asked anything else (another point, a Jacobian),
    ``predict`` raises ``ValueError``.

    Parameters
    ----------
    prediction : Prediction
        The recorded response.
    theta : numpy.ndarray
        The point it was recorded at, kPa.
    spec : ModelSpec
        The model it was recorded with.
    """

    def __init__(self, prediction: Prediction, theta: np.ndarray, spec: ModelSpec) -> None:
        self.prediction = prediction
        self.theta = np.asarray(theta, float)
        self.parameters = prediction.parameters
        self.spec = spec

    def predict(self, theta, jacobian: bool = False) -> Prediction:
        """The recorded response, at the recorded point only.

        Parameters
        ----------
        theta : array_like
            The recorded point (one row).
        jacobian : bool, default False
            Must be False: a recorded run has no sensitivities.

        Returns
        -------
        Prediction
            The recorded response.

        Raises
        ------
        ValueError
            If a Jacobian or another point is asked for.
        """
        t = as_theta(theta, len(self.parameters))
        if jacobian:
            raise ValueError("a recorded run has no sensitivities")
        if len(t) != 1 or not np.allclose(t[0], self.theta, rtol=1e-9):
            raise ValueError(f"the recorded run is at {self.theta.tolist()}, not {t.tolist()}")
        return self.prediction


def febio_contact(feb_file: str | Path) -> dict:
    """The contact of a FEBio 4 model as its .feb states it.

    FEBio's sliding-elastic with fric_coeff 1e8 is its 'stick', which renews the stick point every
    increment: not the studio's perfect stick.

    Parameters
    ----------
    feb_file : str or pathlib.Path
        The model file.

    Returns
    -------
    dict
        ``{"febio": ...}``: each ``<contact>``'s type and name, its ``fric_coeff``, ``penalty``
        and ``laugon`` where given (one dict, or a list); with a ``note`` when it states none.

    Raises
    ------
    ValueError
        If the file cannot be read.
    """
    import xml.etree.ElementTree as ET

    try:
        root = ET.parse(feb_file).getroot()
    except (OSError, ET.ParseError) as exc:
        raise ValueError(f"{feb_file}: cannot read the model's contact ({exc})") from exc
    found = []
    for c in root.iter("contact"):
        entry = {"type": c.get("type"), "name": c.get("name")}
        for key in ("fric_coeff", "penalty", "laugon"):
            node = c.find(key)
            if node is not None and node.text is not None:
                try:
                    entry[key] = float(node.text)
                except ValueError:
                    entry[key] = node.text.strip()
        found.append(entry)
    if not found:
        return {"febio": None, "note": "the .feb states no contact"}
    return {"febio": found[0] if len(found) == 1 else found}


def experiment_from_febio_run(
    log_path: str | Path,
    out_dir: str | Path,
    *,
    feb_file: str | Path | None = None,
    radius: float = 4.77,
    steps: int = 28,
    step_size: float = 0.5,
    recording: Recording = LAB_RECORDING,
    seed: int = 0,
    overwrite: bool = False,
) -> Path:
    """Write an experiment folder from the FEBio run logged in ``log_path``.

    c1, c5 and kappa are read as the log echoes them. The experiment.json records the run (log,
    .feb, parameters) and excludes the steps FEBio accepted off equilibrium.

    Parameters
    ----------
    log_path : str or pathlib.Path
        The FEBio log.
    out_dir : str or pathlib.Path
        The experiment folder.
    feb_file : str or pathlib.Path, optional
        The run's model (its hex8 block); default the .feb beside the log.
    radius : float, default 4.77
        The run's indenter radius, mm.
    steps : int, default 28
        The run's steps.
    step_size : float, default 0.5
        The run's step size, mm.
    recording : Recording, default LAB_RECORDING
        How the run is recorded (:class:`~indentation_studio.inference.experiment.synthetic.Recording`).
    seed : int, default 0
        The noise seed.
    overwrite : bool, default False
        Replace an experiment folder already there.

    Returns
    -------
    pathlib.Path
        The experiment folder.

    Raises
    ------
    FebioLogError
        If the .feb is missing, or the log is unreadable, does not echo the material parameters
        or is not of the model.
    FebioRunError
        If FEBio did not terminate normally or the log holds fewer steps than asked.
    FileExistsError
        If an experiment folder is already there (unless ``overwrite``).
    """
    refuse_existing_experiment(out_dir, overwrite=overwrite)
    log_path = Path(log_path)
    feb = Path(feb_file) if feb_file is not None else log_path.with_suffix(".feb")
    if not feb.is_file():
        raise FebioLogError(f"{log_path}: no model file {feb} (give the run's .feb)")
    logged = logged_block_material(log_path.read_text(encoding="latin-1"))
    missing = [k for k in ("c1", "c5", "k") if k not in logged]
    if missing:
        raise FebioLogError(f"{log_path}: the log echoes no block material parameter(s) {missing}")
    spec = ModelSpec(
        indenter=Indenter(radius),
        protocol=Protocol(step_size=step_size, steps=steps),
        material=Material(c1=logged["c1"], c5=logged["c5"], kappa=logged["k"]),
        mesh=MeshChoice(feb_file=str(feb)),
    )
    result = read_febio_run(log_path, spec, feb)
    prediction = Prediction.from_results([result], ("c1", "c5"))
    theta = np.array([logged["c1"], logged["c5"]])
    source = {
        "solver": "febio",
        "log": str(log_path),
        "feb": str(feb),
        "c1": logged["c1"],
        "c5": logged["c5"],
        "kappa": logged["k"],
        "off_equilibrium_depths_mm": result.off_equilibrium_depths,
        "contact": febio_contact(feb),
    }
    return write_synthetic_experiment(
        RecordedRun(prediction, theta, spec),
        theta,
        out_dir,
        radius=radius,
        step_size=step_size,
        recording=recording,
        seed=seed,
        source=source,
    )


def febio_experiment_summary(folder: str | Path) -> dict[str, Any]:
    """What ``import febio --json`` prints of an experiment made from a FEBio run.

    Parameters
    ----------
    folder : str or Path
        The experiment folder :func:`experiment_from_febio_run` wrote.

    Returns
    -------
    dict
        The folder, the run's (c1, c5), the steps left out, the depths FEBio accepted off
        equilibrium and a warning naming those steps (if any).
    """
    exp = load_experiment(folder)
    src = exp.synthetic["source"]
    excluded = list(exp.excluded_steps)
    return {
        "experiment": str(folder),
        "theta": [src["c1"], src["c5"]],
        "excluded_steps": excluded,
        "off_equilibrium_depths_mm": src["off_equilibrium_depths_mm"],
        "warnings": [f"steps FEBio accepted off equilibrium left out: {excluded}"] if excluded else [],
    }
