"""Draw a training curve: the mean episode return (stable-baselines3's `rollout/ep_rew_mean`, the
mean over the last 100 episodes) against the environment steps, from train.py's progress.csv.

    python examples/learned/plot_curve.py runs/g1_ppo/progress.csv --out runs/g1_ppo/curve.png

Needs only pandas and matplotlib (fallbench's own dependencies).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pandas as pd  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("progress", type=Path, help="progress.csv written by train.py")
    parser.add_argument("--out", type=Path, default=None, help="PNG to write (default: beside the CSV)")
    args = parser.parse_args()
    progress = pd.read_csv(args.progress)
    steps = progress["time/total_timesteps"] / 1e6
    figure, (returns, noise) = plt.subplots(2, 1, figsize=(7, 4.5), sharex=True, height_ratios=[3, 1])
    returns.plot(steps, progress["rollout/ep_rew_mean"], color="tab:blue")
    returns.set_ylabel("episode return\n(mean of last 100)")
    returns.grid(alpha=0.3)
    noise.plot(steps, progress["train/std"], color="tab:gray")
    noise.set_ylabel("action std")
    noise.set_xlabel("environment steps (millions)")
    noise.grid(alpha=0.3)
    figure.tight_layout()
    out = args.out or args.progress.with_name("curve.png")
    figure.savefig(out, dpi=120)
    print(out)


if __name__ == "__main__":
    main()
