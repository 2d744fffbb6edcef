"""`fallbench bench`'s whole-command sweep reads the shipped scenarios (a moved module once lost them)."""

from __future__ import annotations

from pathlib import Path

from fallbench.bench.commands import _sweep_file
from fallbench.checks import load


def test_sweep_file_mixes_shipped_drops_and_pushes(tmp_path: Path) -> None:
    points = load([_sweep_file(16, tmp_path)])
    assert len(points) == 4  # runs / 4 points: the bench sweeps four policies over them
    names = [p.scenario.name for p in points]
    assert names[0].startswith("drop_") and names[1].startswith("push_200N_")
