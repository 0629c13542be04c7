"""The recipe of a shipped surrogate (issue 46): every campaign and training step that makes the
surrogate a fit at one test uses without being told, then the file and its manifest entry.

For an indenter of radius R pushed in N steps of h mm into the paper's block, on the fit's model
(docs/explanation/model-error.md: the contact-L family with the surface contact, the objective
without the DIC rings under 1.5 R):

1. the perfect stick on the low level (contact-L1), 9 x 9 points even in log c1 (a GP);
2. 32 held-out stick points (Latin hypercube), its test campaign;
3. 512 Sobol points over (c1, c5, mu), mu log-uniform over the prior 0.1 to 3, on the low level:
   the slip's change over the stick (an MLP; 5-fold cross-validation keeps its held-out errors);
4. the stick on the high level (contact-L3) over the paper's whole box, the 25 points of
   ``docs/validation/data/campaigns/box-grid.csv`` (5 x 5 in log c1 1 to 21 kPa x log c5 82.5 to
   578 kPa; ``--high-grid``): the multi-fidelity discrepancy from the low level to it (a GP, its
   5-fold held-out errors kept in the file; issue 57: the nine budget points alone, c1 in
   {3, 11, 19} x c5 in {120, 330, 540}, left the soft corner to extrapolation);
4b. with ``--high-mu-grid`` (e.g. ``sobol:16:2,mu=0.1:3:log``), the high level with friction as an
   axis too, merged with step 4's stick campaign (its points at the low level's mu range end), so
   that the discrepancy is learned with friction rather than learned at the stick and applied at
   every mu (docs/validation/model-error.md: the stick's discrepancy missed level 3 with mu 0.2 to
   0.6 by 1.2 to 4.0 % in c5);
5. the file copied to ``--out`` as ``paper-test-R<R>.safetensors`` (or ``test-R<R>-<N>x<h>``) with
   its manifest entry: sha256, size, test, campaigns (grid, points, failures, solver time),
   held-out errors, package version and commit, and this command.

Every step is one ``indent-studio`` command, printed before it runs; campaigns resume where they
stopped, and a campaign already complete under its name is used as it is. One command:

    .venv/bin/python tools/ship_surrogates.py --radius 8 --runs-dir runs/ship \\
        --out indentation_studio/surrogates

A few hours of CPU per radius on 2 cores (the campaigns: docs/validation/surrogates.md, "The shipped
surrogates").
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
from datetime import UTC, datetime
from pathlib import Path

import pandas as pd

from indentation_studio import __version__
from indentation_studio.campaign.loader import campaign_record
from indentation_studio.surrogate.persistence import load_surrogate
from indentation_studio.surrogate.shipped import add_to_manifest, file_sha256

ROOT = Path(__file__).resolve().parents[1]
CLI = str(Path(sys.executable).with_name("indent-studio"))
STICK_GRID = "c1=1:21:9:log,c5=82.5:578:9"
TEST_GRID = "lhs:32:5"
MU_GRID = "sobol:512:1,mu=0.1:3:log"
HIGH_GRID = str(ROOT / "docs" / "validation" / "data" / "campaigns" / "box-grid.csv")


def run(command: list[str]) -> None:
    """Print a command and run it; stop on its failure."""
    print("$ " + " ".join(command), flush=True)
    subprocess.run(command, check=True)


def complete(runs_dir: Path, name: str) -> bool:
    """Whether a campaign of that name exists with every point done."""
    index = runs_dir / name / "index.parquet"
    return index.is_file() and bool((pd.read_parquet(index)["status"] == "done").all())


def campaign(runs_dir: Path, name: str, grid: str, args: argparse.Namespace, mesh: str) -> None:
    """Run (or resume) one campaign of the test, unless it is complete already."""
    if complete(runs_dir, name):
        print(f"campaign {name}: complete, used as it is", flush=True)
        return
    run(
        [
            CLI,
            "campaign",
            "run",
            "--name",
            name,
            "--grid",
            grid,
            "--radius",
            f"{args.radius:g}",
            "--steps",
            str(args.steps),
            "--step-size",
            f"{args.step:g}",
            "--mesh",
            mesh,
            "--jobs",
            str(args.jobs),
            "--runs-dir",
            str(runs_dir),
        ]
    )


def train(campaign_name: str, kind: str, *options: str) -> None:
    """``indent-studio surrogate train`` of one campaign."""
    run([CLI, "surrogate", "train", "--campaign", campaign_name, "--kind", kind, *options])


def up_to_date(model: Path, *inputs: Path) -> bool:
    """Whether a trained file exists and is newer than everything it was trained from."""
    return model.is_file() and all(model.stat().st_mtime > path.stat().st_mtime for path in inputs)


#: The bands of mu the held-out errors are given in (and the stick, mu's prior's upper end).
MU_BANDS = (0.1, 0.5, 1.0, 3.0 + 1e-9)


def slip_errors_by_mu(model) -> list[dict] | None:
    """The slip surrogate's held-out errors (its k-fold) within bands of mu."""
    error = model.emulation_error
    return None if error is None else error.describe_bands(model.parameters.index("mu"), MU_BANDS)


def commit() -> str:
    """The repository's commit (and whether its work tree had changes)."""
    head = subprocess.run(["git", "rev-parse", "HEAD"], cwd=ROOT, capture_output=True, text=True)
    dirty = subprocess.run(["git", "status", "--porcelain"], cwd=ROOT, capture_output=True, text=True)
    text = head.stdout.strip() or "unknown"
    return text + ("+changes" if dirty.stdout.strip() else "")


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--radius", type=float, required=True, help="indenter radius, mm")
    parser.add_argument("--steps", type=int, default=28)
    parser.add_argument("--step", type=float, default=0.5, help="depth per step, mm")
    parser.add_argument("--runs-dir", type=Path, default=Path("runs/ship"))
    parser.add_argument("--out", type=Path, default=Path("indentation_studio/surrogates"))
    parser.add_argument("--jobs", type=int, default=0, help="parallel processes (0: all cores)")
    parser.add_argument("--low-mesh", default="contact-L1")
    parser.add_argument("--high-mesh", default="contact-L3")
    parser.add_argument("--stick-campaign", help="name of the low level's stick campaign")
    parser.add_argument("--test-campaign", help="name of its held-out stick campaign")
    parser.add_argument("--mu-campaign", help="name of the low level's campaign over (c1, c5, mu)")
    parser.add_argument("--high-campaign", help="name of the high level's stick campaign")
    parser.add_argument(
        "--high-grid", default=HIGH_GRID, help="the high level's points (a grid option or a CSV of c1, c5)"
    )
    parser.add_argument(
        "--high-mu-grid",
        help="also the high level with a mu axis (e.g. sobol:16:2,mu=0.1:3:log), merged with the stick's",
    )
    parser.add_argument("--high-mu-campaign", help="name of the high level's campaign with mu")
    args = parser.parse_args()

    tag = f"R{args.radius:g}" + (
        "" if (args.steps, args.step) == (28, 0.5) else f"-{args.steps}x{args.step:g}"
    )
    names = {
        "stick": args.stick_campaign or f"stick-{tag}",
        "test": args.test_campaign or f"stick-test-{tag}",
        "mu": args.mu_campaign or f"mu-{tag}",
        "high": args.high_campaign or f"high-box-{tag}",
    }
    if args.high_mu_grid:
        names["high-mu"] = args.high_mu_campaign or f"high-mu-{tag}"
    runs_dir = args.runs_dir
    campaign(runs_dir, names["stick"], STICK_GRID, args, args.low_mesh)
    campaign(runs_dir, names["test"], TEST_GRID, args, args.low_mesh)
    campaign(runs_dir, names["mu"], MU_GRID, args, args.low_mesh)
    campaign(runs_dir, names["high"], args.high_grid, args, args.high_mesh)
    if args.high_mu_grid:
        campaign(runs_dir, names["high-mu"], args.high_mu_grid, args, args.high_mesh)

    stick = runs_dir / names["stick"] / "surrogate-gp.safetensors"
    slip = runs_dir / names["mu"] / "surrogate-slip.safetensors"
    shipped = runs_dir / names["high"] / "surrogate-mf-slip.safetensors"
    common = ["--runs-dir", str(runs_dir), "--seed", "0"]
    index = {key: runs_dir / name / "index.parquet" for key, name in names.items()}
    if up_to_date(stick, index["stick"], index["test"]):  # a stopped recipe resumes, as campaigns do
        print(f"{stick}: trained after its campaigns, used as it is", flush=True)
    else:
        train(names["stick"], "gp", "--test-campaign", names["test"], *common)
    if up_to_date(slip, index["mu"], stick):
        print(f"{slip}: trained after its campaign and stick surrogate, used as it is", flush=True)
    else:
        train(names["mu"], "slip", "--stick", str(stick), "--kfold", "5", *common)
    run(
        [
            CLI,
            "surrogate",
            "train-mf",
            "--low",
            str(slip),
            "--campaign",
            names["high"],
            *(["--campaign", names["high-mu"]] if args.high_mu_grid else []),
            "--out",
            str(shipped),
            *common,
        ]
    )

    name = "paper-test-" + tag if tag.startswith("R") and "-" not in tag else "test-" + tag
    args.out.mkdir(parents=True, exist_ok=True)
    target = args.out / f"{name}.safetensors"
    shutil.copyfile(shipped, target)
    model = load_surrogate(target)
    meta = model.meta
    entry = {
        "name": name,
        "file": target.name,
        "sha256": file_sha256(target),
        "bytes": target.stat().st_size,
        "test": {
            "radius_mm": args.radius,
            "steps": args.steps,
            "step_mm": args.step,
            "depths_mm": [round(args.step * k, 9) for k in range(1, args.steps + 1)],
            "block_mm": meta["campaign"]["model"]["geometry"],
        },
        "kind": model.kind,
        "parameters": list(model.parameters),
        "models": {"low": args.low_mesh, "high": args.high_mesh},
        "campaigns": [
            campaign_record(runs_dir, names[key])
            for key in ("stick", "test", "mu", "high", "high-mu")
            if key in names
        ],
        "held_out": {
            "stick": load_surrogate(stick).meta.get("emulation_error"),
            "slip": load_surrogate(slip).meta.get("emulation_error"),
            "slip_by_mu": slip_errors_by_mu(load_surrogate(slip)),
            "discrepancy_kfold": meta.get("discrepancy_kfold"),
        },
        "error_budget": meta.get("error_budget"),
        "made": {
            "indentation_studio": __version__,
            "commit": commit(),
            "date": datetime.now(UTC).isoformat(timespec="seconds"),
            "versions": meta.get("versions"),
        },
        "recipe": (
            f"python tools/ship_surrogates.py --radius {args.radius:g} --steps {args.steps} "
            f"--step {args.step:g}" + (f' --high-mu-grid "{args.high_mu_grid}"' if args.high_mu_grid else "")
        ),
    }
    path = add_to_manifest(args.out, entry)
    print(
        f"shipped {target} ({entry['bytes'] / 1e6:.2f} MB, sha256 {entry['sha256'][:12]}...); manifest {path}"
    )


if __name__ == "__main__":
    main()
