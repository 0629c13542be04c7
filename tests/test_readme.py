"""The README's Python example runs as it stands, and .ci/run calls exactly the README's test command."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()


def test_ci_runs_the_readme_test_command():
    commands = re.findall(r"^python3 -m venv .*$", README, flags=re.M)
    assert len(commands) == 2 and commands[1].endswith(".venv/bin/python -m pytest")
    assert "ruff check ." in commands[1] and "ruff format --check ." in commands[1]
    assert commands[1] in (ROOT / ".ci" / "run").read_text().splitlines()


@pytest.mark.slow
def test_readme_python_example_runs(tmp_path, monkeypatch):
    block = re.search(r"## Python\n.*?```python\n(.*?)```", README, flags=re.S).group(1)
    monkeypatch.chdir(tmp_path)
    namespace: dict = {}
    exec(compile(block, "README.md", "exec"), namespace)
    result, truth = namespace["result"], namespace["truth"]
    # data and model on the same mesh: the truth lies inside the 95 % bounds, mu marginalised
    assert result.friction.mode == "marginalise" and result.fit.theta.size == 3
    assert np.all(np.abs(result.theta / truth - 1) * 100 < result.bounds_pct)
    lo, hi = np.array(namespace["posterior"].to_dict()["ci95"]).T
    assert np.all((lo < result.theta) & (result.theta < hi))
    assert len(namespace["fig"].axes) == 4  # a 2 x 2 corner plot


def test_readme_lab_commands_are_the_lab_examples():
    """The README's three lab commands import the shipped lab example with the angle it was made with."""
    import json

    block = re.search(r"### A lab's files.*?```bash\n(.*?)```", README, flags=re.S).group(1)
    commands = [c for c in block.replace("\\\n", " ").splitlines() if c.strip()]
    assert [c.split()[1] for c in commands] == ["import", "check", "fit"]
    about = json.loads((ROOT / "examples" / "lab-matchid" / "lab.json").read_text())
    angle = float(commands[0].split("--fiber-angle")[1].split()[0])
    assert angle == pytest.approx(about["fiber_angle_deg_as_the_camera_sees_it"], abs=0.01)
    for name in ("matchid", "load_frame.csv", "frame_times.csv", "indenter.csv"):
        assert f"examples/lab-matchid/{name}" in commands[0]
        assert (ROOT / "examples" / "lab-matchid" / name).exists()
