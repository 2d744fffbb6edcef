"""Robot cards: a robot from a YAML file and its URDF, with no Python.

Most tests use `renamed_talos`: TALOS's card, URDF and SRDF copied into a temporary folder as a new
robot `bot` whose leg bodies and joints are renamed (`leg_*` -> `lower_*`), as a user's robot would
be: nothing in fallbench knows its names.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from typer.testing import CliRunner

from fallbench.checks import check_scenario
from fallbench.cli import app
from fallbench.results.store import consolidate, load_metrics
from fallbench.robots import ROBOTS, get_robot
from fallbench.robots.card import load_card
from fallbench.scenario import ScenarioError, load_scenario_file

TALOS = get_robot("talos")
RENAMED = re.compile(r'((?:name|link|link1|link2|joint)=")leg_')  # XML references to a leg body or joint


def renamed_talos(folder: Path, edit_card=lambda text: text, edit_urdf=lambda text: text) -> Path:
    """TALOS as robot `bot` in `folder` (card bot.yaml, bot.urdf, bot.srdf), `leg_` renamed
    `lower_`; `edit_card` and `edit_urdf` change the texts further. Returns the card's path."""
    urdf = TALOS.urdf_path.read_text().replace(f"package://{TALOS.package_prefix}", f"{TALOS.mesh_root}/")
    (folder / "bot.urdf").write_text(edit_urdf(RENAMED.sub(r"\1lower_", urdf)))
    assert TALOS.srdf_path is not None
    (folder / "bot.srdf").write_text(RENAMED.sub(r"\1lower_", TALOS.srdf_path.read_text()))
    card = (
        ROBOTS["talos"]
        .read_text()
        .replace("leg_", "lower_")
        .replace("lower_pitch_joints", "leg_pitch_joints")
    )
    card = card.replace("name: talos", "name: bot")
    card = re.sub(r"^model:\n(?:  .*\n)+", "model: {urdf: bot.urdf, srdf: bot.srdf}\n", card, flags=re.M)
    path = folder / "bot.yaml"
    path.write_text(edit_card(card))
    return path


def invoke(*args: str):
    return CliRunner().invoke(app, list(args))


def test_shipped_cards_are_named_as_their_files_and_load() -> None:
    assert set(ROBOTS) >= {"talos", "g1"}
    for name, card in ROBOTS.items():
        robot = get_robot(name)
        assert robot.name == name and robot.card_path == card and len(robot.fingerprint) == 16


def test_a_renamed_copy_is_the_same_robot_under_other_names(tmp_path: Path) -> None:
    bot = load_card(renamed_talos(tmp_path))
    assert bot.name == "bot" and bot.version == "local files" and bot.mass == pytest.approx(TALOS.mass)
    assert bot.legs["left"][0] == "lower_left_1_joint" and bot.knee_joints == (
        "lower_left_4_joint",
        "lower_right_4_joint",
    )
    assert bot.postures["default"]["lower_left_4_joint"] == TALOS.postures["default"]["leg_left_4_joint"]
    assert bot.armature["lower_left_4_joint"] == TALOS.armature["leg_left_4_joint"]  # the SRDF's rotors
    assert bot.disabled_collisions == tuple(
        tuple(b.replace("leg_", "lower_") for b in pair) for pair in TALOS.disabled_collisions
    )
    assert bot.default_gains("lower_right_4_joint") == TALOS.default_gains("leg_right_4_joint")


def test_a_card_in_a_folder_runs_a_drop_that_is_stored(tmp_path: Path) -> None:
    card = renamed_talos(tmp_path)
    (tmp_path / "drop.yaml").write_text(
        "name: drop\nrobot: bot.yaml\nduration: 1.0\ninitial: {height: 0.2}\n"
    )
    results = tmp_path / "results"
    result = invoke("run", "one", str(tmp_path / "drop.yaml"), "--results", str(results))
    assert result.exit_code == 0, result.output
    assert consolidate(results) == 1  # `run one` stores a run folder; the table takes it in
    (row,) = load_metrics(results).to_dict("records")
    assert row["status"] == "ok" and row["robot"] == str(card) and row["scenario"] == "drop"
    assert set(row["first_contact_bodies"].split(",")) == {"lower_left_6_link", "lower_right_6_link"}
    assert row["version:robot_card"] == get_robot(str(card)).fingerprint
    exported = invoke("scenarios", "export", str(tmp_path / "drop.yaml"), "--out", str(tmp_path / "s.xml"))
    assert exported.exit_code == 0 and 'name="lower_left_6_link"' in (tmp_path / "s.xml").read_text()


def test_the_run_identity_holds_the_card(tmp_path: Path) -> None:
    from fallbench.results.runner import RunSpec, _versions

    card = renamed_talos(tmp_path)
    (tmp_path / "drop.yaml").write_text("name: drop\nrobot: bot.yaml\nduration: 1.0\n")
    (point,) = load_scenario_file(tmp_path / "drop.yaml")
    before = RunSpec(point, "stiff").run_id
    card.write_text(card.read_text().replace("{kp: 2000, kd: 20}", "{kp: 2100, kd: 20}"))
    get_robot.cache_clear()  # a command reads a card once; the next command reads the edited card
    _versions.cache_clear()
    assert RunSpec(point, "stiff").run_id != before  # an edited card is a new run


def test_sizes_scale_to_a_card_robot_by_mass_and_standing_height(tmp_path: Path) -> None:
    def half_masses(urdf: str) -> str:
        return re.sub(r'<mass value="([^"]+)"', lambda m: f'<mass value="{float(m.group(1)) / 2!r}"', urdf)

    renamed_talos(
        tmp_path, lambda card: card.replace("standing_height: 1.01927", "standing_height: 0.8"), half_masses
    )
    (tmp_path / "push.yaml").write_text(
        "name: p\nrobot: bot.yaml\nsizes_for: talos\nduration: 1.0\npush: {force: 200}\n"
        "obstacles: [{type: box, pos: [1.0, 0.0, 0.25], size: [0.4, 0.4, 0.5]}]\n"
    )
    (point,) = load_scenario_file(tmp_path / "push.yaml", check=check_scenario)
    assert point.scenario.push.force == pytest.approx(100.0)  # N: the mass ratio 1/2
    assert point.scenario.obstacles[0].pos[0] == pytest.approx(0.8 / 1.01927)  # m: standing heights


@pytest.mark.parametrize(
    "edit, key, reason",
    [
        (lambda c: c + "colour: blue\n", "colour", "unknown key"),
        (lambda c: c.replace("schema_version: 1", "schema_version: 2"), "schema_version", "schema version 1"),
        (
            lambda c: c.replace("imu_body: base_link", "imu_body: imu_nowhere"),
            "imu_body",
            "no body 'imu_nowhere'",
        ),
        (
            lambda c: c.replace("head: [head_1_link,", "head: [antenna_.*, head_1_link,"),
            "body_groups.head.0",
            "matches no body",
        ),
        (
            lambda c: c.replace("  gripper_.*: {kp: 50, kd: 0.5}\n", ""),
            "gains",
            "'gripper_left_joint' matches none",
        ),
        (
            lambda c: c.replace("default_posture: half_sitting", "default_posture: crouch"),
            "default_posture",
            "no posture 'crouch'",
        ),
        (
            lambda c: c.replace("trajectory_joints:\n", "trajectory_joints:\n  head_1_joint: head\n"),
            "timeseries_joints",
            "misses head_1_joint",
        ),
    ],
)
def test_a_bad_card_is_one_line_at_its_key(tmp_path: Path, edit, key: str, reason: str) -> None:
    card = renamed_talos(tmp_path, edit)
    result = invoke("robots", "show", str(card))
    assert result.exit_code == 2 and len(result.output.strip().splitlines()) == 1, result.output
    line = next(
        i + 1 for i, text in enumerate(card.read_text().splitlines()) if text.startswith(key.split(".")[0])
    )
    assert (
        result.output.startswith(f"error: {card}:")
        and f": {key}: " in result.output
        and reason in result.output
    )
    assert int(result.output.split(":")[2]) >= line  # at the key, or at the entry under it


def test_a_scenario_names_a_missing_card_at_its_robot_line(tmp_path: Path) -> None:
    (tmp_path / "s.yaml").write_text("name: s\nduration: 1.0\nrobot: robots/nowhere.yaml\n")
    result = invoke("scenarios", "validate", str(tmp_path / "s.yaml"))
    assert result.exit_code == 2
    assert f"s.yaml:3: robot: no robot card at {tmp_path / 'robots/nowhere.yaml'}" in result.output


def test_a_strategy_needing_arms_refuses_a_robot_without_before_any_run(tmp_path: Path, sweep) -> None:
    renamed_talos(tmp_path, lambda card: re.sub(r"^arms:\n(?:  .*\n)+", "", card, flags=re.M))
    (tmp_path / "push.yaml").write_text("name: p\nrobot: bot.yaml\nduration: 1.0\npush: {force: 300}\n")
    result = sweep(tmp_path / "push.yaml", tmp_path / "r", pre_impact="none,reshape")
    assert result.exit_code == 2 and not result.simulated
    assert "robot: strategy 'reshape' needs the robot's `arms`, which" in result.output
    with pytest.raises(ScenarioError, match="strategy 'reshape' needs the robot's `arms`"):
        load_scenario_file(
            tmp_path / "push.yaml",
            check=lambda s: check_scenario(s.model_copy(update={"pre_impact": ("reshape",)})),
        )


def test_robots_check_passes_the_renamed_robot_and_says_why_others_fail(tmp_path: Path) -> None:
    folders = {
        name: tmp_path / name for name in ("ok", "weak", "loose")
    }  # a card path is read once a process
    for folder in folders.values():
        folder.mkdir()
    ok = invoke("robots", "check", str(renamed_talos(folders["ok"])))
    assert ok.exit_code == 0 and "ok: " in ok.output and "touching in the default stance: none" in ok.output
    weak = renamed_talos(folders["weak"], lambda card: card.replace("kp: 2000", "kp: 20"))
    result = invoke("robots", "check", str(weak))
    assert result.exit_code == 1 and "problem: does not stand under stiff" in result.output
    unlimited = renamed_talos(
        folders["loose"],
        edit_urdf=lambda urdf: urdf.replace(
            '<joint name="arm_left_2_joint" type="revolute"',
            '<joint name="arm_left_2_joint" type="continuous"',
        ),
    )
    result = invoke("robots", "check", str(unlimited))
    assert result.exit_code == 1 and "problem: joint arm_left_2_joint has no range" in result.output
