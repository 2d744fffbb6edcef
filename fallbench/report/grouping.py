"""The report groups every table and figure by robot."""

from __future__ import annotations

import pandas as pd

from fallbench.robots import DEFAULT_ROBOT


def with_robot(runs: pd.DataFrame) -> pd.DataFrame:
    """Runs with a `robot` column (runs stored before it existed ran on the default robot)."""
    robot = runs["robot"].fillna(DEFAULT_ROBOT) if "robot" in runs else DEFAULT_ROBOT
    return runs.assign(robot=robot)
