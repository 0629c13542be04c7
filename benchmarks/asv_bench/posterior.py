"""The posterior of the shipped example (``examples/synthetic-12-250``) on the shipped surrogate."""

from __future__ import annotations

from pathlib import Path

from indentation_studio.inference.experiment.data import load_experiment
from indentation_studio.inference.posterior.workflow import sample_posterior_for
from indentation_studio.surrogate.persistence import load_surrogate
from indentation_studio.surrogate.shipped import shipped_surrogates

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "synthetic-12-250"


class ShippedPosterior:
    """``posterior_speed.py`` on the shipped R = 4.77 mm surrogate: 32 walkers, 300 steps."""

    number = 1
    repeat = (1, 3, 300.0)
    warmup_time = 0
    timeout = 1800

    def setup(self):
        entry = next(e for e in shipped_surrogates() if e.radius == 4.77)
        self.surrogate = load_surrogate(entry.verified_path())
        self.experiment = load_experiment(EXAMPLE)

    def time_posterior_shipped_surrogate(self):
        sample_posterior_for(self.experiment, self.surrogate, walkers=32, steps=300, seed=0)
