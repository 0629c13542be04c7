"""The speed history: every record of benchmarks/history/speed.jsonl (one run of
benchmarks/speed_history.py each), per case the warm median wall time with the thread policy's
choice, the one-thread ratio to the numpy yardstick (the figure the regression check compares;
its yardstick changed once, so the ratios are comparable only within one yardstick), and the
machine's load average when the run started.

    .venv/bin/python docs/figures/solver_and_speed_history.py

Writes docs/validation/figures/speed-history.png.
"""

from __future__ import annotations

import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

ROOT = Path(__file__).resolve().parents[2]
HISTORY = ROOT / "benchmarks" / "history" / "speed.jsonl"
OUT = ROOT / "docs" / "validation" / "figures" / "speed-history.png"
CASES = ("paper", "sensitivities", "mu0.3", "R8")


def main() -> None:
    records = [json.loads(line) for line in HISTORY.read_text().splitlines() if line.strip()]
    x = list(range(len(records)))
    labels = [f"{r['commit']}\n{r['date'][5:10]} {r['date'][11:16]}" for r in records]
    yardstick = [r.get("yardstick", 1) for r in records]
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.0), constrained_layout=True)
    for i, case in enumerate(CASES):
        at = [k for k in x if case in records[k]["cases"]]
        axes[0].plot(at, [records[k]["cases"][case]["median_s"] for k in at], "o-", color=f"C{i}", label=case)
        for version, marker in ((1, "o"), (2, "s")):
            on = [k for k in at if yardstick[k] == version]
            axes[1].plot(
                on,
                [records[k]["cases"][case]["ratio"] for k in on],
                marker + "-",
                color=f"C{i}",
                label=f"{case} (yardstick {version})",
            )
    axes[2].bar(x, [r["load_average_before"][0] for r in records], color="0.6")
    axes[0].set(ylabel="warm median wall time (s)", title="one simulation, the thread policy's threads")
    axes[1].set(ylabel="one-thread time / yardstick time", title="the ratio the regression check compares")
    axes[1].set_yscale("log")
    axes[2].set(ylabel="1-min load average before the run", title="how busy the machine was")
    first_v2 = next((k for k in x if yardstick[k] == 2), None)
    for ax in axes:
        ax.set_xticks(x, labels, fontsize=7)
        if first_v2 is not None:
            ax.axvline(first_v2 - 0.5, color="k", lw=0.8, ls=":")
    axes[0].legend(fontsize=8)
    axes[1].legend(fontsize=7, ncol=2)
    fig.suptitle(f"benchmarks/history/speed.jsonl: {len(records)} records (the dotted line: yardstick 2)")
    OUT.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(OUT, dpi=110)
    print(OUT)


if __name__ == "__main__":
    main()
