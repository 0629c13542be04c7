"""Load time and size of surrogate files: the old pickle (joblib, format 1) against the safe
safetensors file (format 2), for surrogates trained on a campaign.

    python benchmarks/surrogate_file_timing.py --campaign p775c --kinds gp,mlp --repeats 5

Trains each kind on the campaign (or reuses runs/<campaign>/surrogate-<kind>.safetensors when it
exists), writes both formats side by side, and times loading each in fresh Python processes
(imports included: what a CLI command or a notebook pays) and again in one warm process (imports
done); checks that both loaded models predict the same forces. Writes
runs/<campaign>/surrogate-file-timing.json.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import time
from pathlib import Path

import joblib
import numpy as np

from indentation_studio.atomic_write import atomic_write_json
from indentation_studio.campaign.loader import load_campaign
from indentation_studio.surrogate.base import TrainingData
from indentation_studio.surrogate.persistence import load_surrogate, save_surrogate, versions
from indentation_studio.surrogate.training import make_surrogate

COLD_LOAD = {
    "joblib": "import joblib; joblib.load({path!r})",
    "safetensors": "from indentation_studio.surrogate.persistence import load_surrogate; load_surrogate({path!r})",
}


def cold_load_s(kind: str, path: Path, repeats: int) -> list[float]:
    """Wall time of a fresh interpreter that loads ``path`` (less that of an empty interpreter)."""
    times = []
    for _ in range(repeats):
        code = "import time; t = time.perf_counter(); " + COLD_LOAD[kind].format(path=str(path))
        code += "; print(time.perf_counter() - t)"
        out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
        times.append(float(out.stdout.strip().splitlines()[-1]))
    return times


def warm_load_s(load, path: Path, repeats: int) -> list[float]:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        load(path)
        times.append(time.perf_counter() - t0)
    return times


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--campaign", default="p775c")
    parser.add_argument("--runs-dir", default="runs")
    parser.add_argument("--kinds", default="gp,mlp")
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    folder = Path(args.runs_dir) / args.campaign
    data = None
    rows = []
    for kind in args.kinds.split(","):
        new = folder / f"surrogate-{kind}.safetensors"
        old = folder / f"surrogate-{kind}.joblib"
        if new.is_file():
            model = load_surrogate(new)
            train_s = model.meta.get("fit_s")
        else:
            data = data or TrainingData.from_campaign(load_campaign(args.campaign, args.runs_dir))
            print(f"training {kind} on {data.n} points ...", file=sys.stderr, flush=True)
            model = make_surrogate(kind).fit(data, seed=0)
            train_s = model.meta["fit_s"]
            save_surrogate(model, new)
        model.meta["versions"] = versions()
        joblib.dump({"format": "indentation-studio-surrogate/1", "model": model}, old)  # as format 1 did
        theta = (model.scaler.lo + model.scaler.hi)[None] / 2
        same = np.array_equal(
            joblib.load(old)["model"].predict(theta).force, load_surrogate(new).predict(theta).force
        )
        row = {"kind": kind, "training_points": model.meta["training_points"], "fit_s": train_s, "same": same}
        formats = (("joblib", old, joblib.load), ("safetensors", new, load_surrogate))
        cold = {fmt: [] for fmt, _, _ in formats}
        for _ in range(args.repeats):  # interleaved, so that a change in the machine's load hits both
            for fmt, path, _ in formats:
                cold[fmt] += cold_load_s(fmt, path, 1)
        for fmt, path, load in formats:
            warm = warm_load_s(load, path, args.repeats)
            row[fmt] = {
                "file": str(path),
                "bytes": path.stat().st_size,
                "cold_load_s_median": statistics.median(cold[fmt]),
                "cold_load_s": cold[fmt],
                "warm_load_s_median": statistics.median(warm),
                "warm_load_s": warm,
            }
        rows.append(row)
        print(row, file=sys.stderr, flush=True)
    atomic_write_json(folder / "surrogate-file-timing.json", {"campaign": args.campaign, "rows": rows})
    for r in rows:
        for fmt in ("joblib", "safetensors"):
            f = r[fmt]
            print(
                f"{r['kind']:4s} {r['training_points']:4d} points  {fmt:12s} {f['bytes'] / 1e6:8.2f} MB  "
                f"cold {f['cold_load_s_median']:.3f} s  warm {f['warm_load_s_median'] * 1e3:.1f} ms"
            )


if __name__ == "__main__":
    main()
