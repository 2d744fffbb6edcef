"""One robot's scenario family as the report shows it: its runs, ranking, representative
falls and paired changes, computed once."""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass

import pandas as pd

import fallbench.report.pages as pages
import fallbench.report.ranking as ranking
from fallbench.report.filmstrips import Pick, family_picks
from fallbench.report.forest import paired_changes


@dataclass
class Family:
    """One robot's scenario family: its runs, ranking (computed once) and representative falls."""

    robot: str
    name: str
    runs: pd.DataFrame
    ranked: ranking.Ranked
    picks: list[Pick]  # the falls shown as filmstrips (`--filmstrips`)
    changes: pd.DataFrame  # paired changes against none + stiff (the forest plot's numbers)
    arm_picks: list[Pick]  # the typical and worst fall of every (strategy, policy)
    unsettled: int = 0  # runs that did not settle by their cap, left out of `runs`
    medians: pd.DataFrame | None = None  # sweeps.median_table, set by `_tables`

    @property
    def table(self) -> pd.DataFrame:
        return ranking.shown_table(self.ranked)

    @property
    def verdict(self) -> str:
        return ranking.verdict(self.runs, self.ranked)

    @property
    def title(self) -> str:
        return f"{self.robot} {self.name}".strip()

    @property
    def stem(self) -> str:
        return pages.family_file(self.robot, self.name).removesuffix(".html")


def find_families(
    per_robot: dict[str, pd.DataFrame], filmstrips: str = "family", unsettled: pd.DataFrame | None = None
) -> list[Family]:
    left_out = Counter(zip(unsettled.robot, unsettled.scenario)) if unsettled is not None else Counter()
    found = []
    for robot, robot_runs in per_robot.items():
        for family in ranking.families(robot_runs):
            group = robot_runs[robot_runs.scenario == family]
            done = ranking.ranked(group)
            arms = ranking.arm_order(group, done)
            every_arm = family_picks(robot, family, group, arms, "all")
            shown = every_arm if filmstrips == "all" else family_picks(robot, family, group, arms, filmstrips)
            changes = paired_changes(group, done)
            found.append(
                Family(robot, family, group, done, shown, changes, every_arm, left_out[(robot, family)])
            )
    return found
