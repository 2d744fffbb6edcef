"""A card without `standing_height`: the height is derived by settling the robot 2 s under `stiff`
in `default` (fallbench/sim/settle.py), as `fallbench robots check` measures it, and cached beside
the compiled worlds. The card here is G1's without the key (its files from example-robot-data)."""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

from fallbench.cli import app
from fallbench.robots import ROBOTS, get_robot
from fallbench.robots.card import load_card
from fallbench.robots.description import StandingHeightUnknown
from fallbench.scenario import load_scenario_file
from fallbench.scenario.sizes import StandingHeightNeeded
from fallbench.sim import settle

PUSH = """name: p
robot: g1_free.yaml
sizes_for: talos
duration: 1.0
push: {force: 200}
obstacles: [{type: box, pos: [1.0, 0.0, 0.25], size: [0.4, 0.4, 0.5]}]
"""


@pytest.fixture
def free_card(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> str:
    """G1's card as `g1_free` without `standing_height`, and a cache of the test's own."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    lines = ROBOTS["g1"].read_text().splitlines(keepends=True)
    text = "".join(line for line in lines if not line.startswith("standing_height:"))
    card = tmp_path / "g1_free.yaml"
    card.write_text(text.replace("name: g1\n", "name: g1_free\n"))
    return str(card)


def test_a_card_without_standing_height_gets_the_settled_height(free_card: str) -> None:
    from fallbench.results.robot_check import stand

    robot = load_card(Path(free_card))
    assert not robot.standing_height_given and not robot.standing_height_known
    with pytest.raises(StandingHeightUnknown, match="its card gives no standing_height"):
        _ = robot.standing_height
    assert all(get_robot(name).standing_height_given for name in ROBOTS)  # the shipped cards give it
    result = CliRunner().invoke(app, ["robots", "check", free_card])
    assert result.exit_code == 0, result.output
    height = get_robot(free_card).standing_height
    assert f"standing height: {height:.3f} m, derived (the card gives none)" in result.output
    assert f"derived standing_height {height:.3f} m" in result.output
    # the check's own measure of the stance, to the last bit, and G1's (the same robot)
    assert height == stand(free_card).end_height == stand("g1").end_height
    assert abs(height - get_robot("g1").standing_height) < 0.001  # G1's card value, measured so
    assert settle.cached_standing_height(free_card) == height


def test_the_derived_height_is_read_from_the_cache(free_card: str, monkeypatch: pytest.MonkeyPatch) -> None:
    derived = settle.ensure_standing_height(free_card)
    assert settle.standing_height_file(free_card).is_file()
    get_robot.cache_clear()  # another process: the card read afresh

    def no_settling(robot: str) -> float:
        raise AssertionError("settled again")

    monkeypatch.setattr(settle, "settled_height", no_settling)
    assert settle.ensure_standing_height(free_card) == derived == get_robot(free_card).standing_height


def test_sizes_for_a_card_without_standing_height(free_card: str, tmp_path: Path) -> None:
    """Reading the file alone cannot settle the robot: it names the key; loading it as fallbench's
    commands do derives the height, then scales the obstacle by it."""
    from fallbench.checks import load

    (tmp_path / "push.yaml").write_text(PUSH)
    with pytest.raises(StandingHeightNeeded, match=r"push\.yaml:3: sizes_for: robot 'g1_free'"):
        load_scenario_file(tmp_path / "push.yaml")
    (point,) = load([tmp_path / "push.yaml"])
    height = get_robot(free_card).standing_height
    assert point.scenario.obstacles[0].pos[0] == pytest.approx(height / get_robot("talos").standing_height)
