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
from fallbench.yamlfile import InputError

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


def with_meshes_beside(folder: Path):
    """An `edit_urdf` for `renamed_talos`: the URDF names its meshes relative to its own folder
    (`meshes/...`, a link to TALOS's), as a user's description package often does."""
    (folder / "meshes").symlink_to(TALOS.mesh_root / "talos_data" / "meshes")
    return lambda urdf: urdf.replace(f"{TALOS.mesh_root}/talos_data/", "")


@pytest.mark.slow
def test_a_card_in_a_folder_runs_a_sweep_and_a_report_under_its_name(tmp_path: Path, sweep) -> None:
    card = renamed_talos(tmp_path, edit_urdf=with_meshes_beside(tmp_path))
    assert 'filename="meshes/' in (tmp_path / "bot.urdf").read_text()
    (tmp_path / "drop.yaml").write_text("name: drop\nrobot: bot.yaml\ninitial: {height: 0.2}\n")
    results, out = tmp_path / "results", tmp_path / "report"
    ran = sweep(tmp_path / "drop.yaml", results)  # stiff and zero: two runs, a ranking
    assert ran.exit_code == 0 and len(ran.simulated) == 2, ran.output
    assert set(load_metrics(results).robot) == {str(card)}  # the store keeps the card's path
    result = invoke("report", "--results", str(results), "--out", str(out), "--jobs", "1")
    assert result.exit_code == 0, result.output
    page = out / "family_bot_drop.html"  # the card's `name`, not its path
    assert page.is_file() and "<title>bot drop</title>" in page.read_text()
    for written in out.iterdir():
        assert "yaml" not in written.name and "tmp" not in written.name, written.name
        if written.suffix in (".html", ".md"):
            assert str(card) not in written.read_text(), written.name
    assert "drop[robot=bot]#s0" in page.read_text()  # the point labels too


def test_a_card_resolves_package_uris_and_says_which_mesh_is_missing(tmp_path: Path) -> None:
    from fallbench.scenario import Scenario
    from fallbench.sim.world import build_world

    def packaged(urdf: str) -> str:  # as ROS names them: package://<package>/<path inside it>
        return urdf.replace(f"{TALOS.mesh_root}/talos_data/", "package://bot_description/")

    cards = {}
    for case in ("ok", "other_uri", "no_meshes"):  # a card path is read once a process
        (tmp_path / case / "bot_description").mkdir(parents=True)
        if case != "no_meshes":
            (tmp_path / case / "bot_description" / "meshes").symlink_to(
                TALOS.mesh_root / "talos_data" / "meshes"
            )
        uri = "other/" if case == "other_uri" else ""
        cards[case] = renamed_talos(
            tmp_path / case,
            lambda text, uri=uri: text.replace("model: {", f"model: {{package_uri: '{uri}', "),
            packaged,
        )
    world = build_world(Scenario(name="s", duration=1.0, robot=str(cards["ok"])))  # MuJoCo read every mesh
    assert world.model.nmesh > 0
    result = invoke("robots", "show", str(cards["other_uri"]))
    assert result.exit_code == 2 and len(result.output.strip().splitlines()) == 1, result.output
    assert ": model.package_uri: bot.urdf names mesh package://bot_description/meshes/" in result.output
    result = invoke("robots", "show", str(cards["no_meshes"]))
    assert result.exit_code == 2 and len(result.output.strip().splitlines()) == 1, result.output
    assert ": model.urdf: bot.urdf names mesh package://bot_description/meshes/" in result.output
    assert f"no file {tmp_path / 'no_meshes' / 'bot_description' / 'meshes'}" in result.output


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


@pytest.mark.parametrize(
    "edit_card, edit_urdf, exit_code, says",
    [
        (
            lambda card: card.replace("imu_body: base_link", "imu_body: imu_frame"),
            None,
            2,
            ": imu_body: no body 'imu_frame' in bot.urdf",
        ),
        (
            lambda card: card.replace("head: [head_1_link,", "head: [helmet_.*, head_1_link,"),
            None,
            2,
            ": body_groups.head.0: 'helmet_.*' matches no body of bot.urdf",
        ),
        (
            None,
            lambda urdf: re.sub(r'type="(revolute|continuous)"', 'type="fixed"', urdf),
            2,
            ": model.urdf: bot.urdf has no revolute or continuous joint: nothing for a servo to drive",
        ),
        (
            None,
            lambda urdf: re.sub(
                r'(<joint name="arm_left_2_joint" type="revolute">.*?effort=")[^"]*"',
                r'\g<1>0"',
                urdf,
                count=1,
                flags=re.S,
            ),
            1,
            "problem: joint arm_left_2_joint has no torque limit",
        ),
        (
            lambda card: card.replace(
                "feet: [lower_left_6_link, lower_right_6_link,", "feet: [lower_left_6_link,"
            ),
            None,
            1,
            "problem: lower_right_6_link touches the floor standing in default but is not in body_groups.feet: "
            "adaptive_qp_hold hands only a landing on the feet to its QP",
        ),
    ],
    ids=[
        "imu body missing",
        "group matching nothing",
        "no actuated joint",
        "no torque limit",
        "a sole not a foot",
    ],
)
def test_robots_check_fails_with_the_reason(tmp_path: Path, edit_card, edit_urdf, exit_code, says) -> None:
    card = renamed_talos(tmp_path, edit_card or (lambda text: text), edit_urdf or (lambda text: text))
    result = invoke("robots", "check", str(card))
    assert result.exit_code == exit_code and says in result.output, result.output
    if exit_code == 2:  # a bad card: one line, before anything is compiled
        assert len(result.output.strip().splitlines()) == 1 and result.output.startswith(f"error: {card}:")


def test_disabled_collisions_auto_disables_the_pairs_touching_in_the_stance(tmp_path: Path) -> None:
    from fallbench.results.robot_check import stance_scenario, touching_pairs
    from fallbench.sim.scene import stance_contacts
    from fallbench.sim.world import build_world

    def without_srdf_pairs(folder: Path, entry: str) -> str:
        folder.mkdir()
        card = renamed_talos(folder, lambda text: text + (f"disabled_collisions: {entry}\n" if entry else ""))
        srdf = folder / "bot.srdf"
        srdf.write_text(re.sub(r"<disable_collisions[^>]*/>", "", srdf.read_text()))
        return str(card)

    bare = without_srdf_pairs(tmp_path / "bare", "")
    touching = touching_pairs(build_world(stance_scenario(bare)), stance_scenario(bare))
    assert ("base_link", "torso_2_link") in touching and (
        "lower_left_1_link",
        "lower_left_3_link",
    ) in touching
    auto = without_srdf_pairs(tmp_path / "auto", "[auto, [lower_left_1_link, lower_left_3_link]]")
    assert get_robot(auto).disabled_collisions == (("lower_left_1_link", "lower_left_3_link"),)
    assert set(stance_contacts(get_robot(auto))) == set(touching) - {
        ("lower_left_1_link", "lower_left_3_link")
    }
    assert touching_pairs(build_world(stance_scenario(auto)), stance_scenario(auto)) == []
    shown = invoke("robots", "show", auto)
    assert "and those touching in the default stance (auto)" in shown.output


def test_an_imu_site_is_a_frame_on_a_body(tmp_path: Path) -> None:
    import math

    import numpy as np

    from fallbench.scenario import Scenario
    from fallbench.sim.world import build_world, initial_state

    site = "imu_site: {body: torso_2_link, pos: [0.04, 0.0, 0.1], rpy: [3.141592653589793, 0, 0]}"  # z down
    (tmp_path / "site").mkdir()
    card = renamed_talos(tmp_path / "site", lambda text: text.replace("imu_body: base_link", site))
    scenario = Scenario(name="s", duration=1.0, robot=str(card), initial={"height": 0.5})
    world = build_world(scenario)
    imu = world.model.site("imu")
    assert world.model.body(imu.bodyid[0]).name == "torso_2_link"
    np.testing.assert_allclose(imu.pos, [0.04, 0.0, 0.1])
    np.testing.assert_allclose(imu.quat, [math.cos(math.pi / 2), 1.0, 0.0, 0.0], atol=1e-12)
    data = initial_state(world, scenario)
    z_axis = data.site_xmat[imu.id].reshape(3, 3)[:, 2]  # the torso upright: the IMU's z points down
    np.testing.assert_allclose(z_axis, [0.0, 0.0, -1.0], atol=0.05)
    shown = invoke("robots", "show", str(card))
    assert "IMU torso_2_link at [0.04, 0.0, 0.1] m" in shown.output
    (tmp_path / "both").mkdir()
    both = renamed_talos(
        tmp_path / "both", lambda text: text.replace("imu_body: base_link", f"imu_body: base_link\n{site}")
    )
    result = invoke("robots", "show", str(both))
    assert (
        result.exit_code == 2
        and ": imu_body: give the IMU as either `imu_body` or `imu_site`" in result.output
    )


def test_postures_from_the_keyframes_of_an_mjcf(tmp_path: Path) -> None:
    """An MJCF of the robot (here compiled from its own URDF, as a model collection would ship it)
    names postures by its <key>s; `default_posture` may take one."""
    import mujoco

    renamed_talos(tmp_path)  # the URDF, to make the MJCF from
    spec = mujoco.MjSpec.from_string((tmp_path / "bot.urdf").read_text())
    spec.worldbody.first_body().add_freejoint()
    model = spec.compile()
    qpos = model.qpos0.copy()
    qpos[2] = 0.95  # root height
    knee = model.jnt_qposadr[model.joint("lower_left_4_joint").id]
    qpos[knee] = 1.0
    key = spec.add_key()
    key.name, key.qpos = "crouch", qpos.tolist()
    spec.compile()
    (tmp_path / "bot.xml").write_text(spec.to_xml())

    def with_keys(text: str) -> str:
        text = text.replace(
            "model: {urdf: bot.urdf, srdf: bot.srdf}",
            "model: {urdf: bot.urdf, srdf: bot.srdf, keyframes: bot.xml}",
        )
        return text.replace("default_posture: half_sitting", "default_posture: crouch")

    (tmp_path / "keys").mkdir()
    for name in ("bot.urdf", "bot.srdf", "bot.xml"):
        (tmp_path / "keys" / name).write_text((tmp_path / name).read_text())
    card = tmp_path / "keys" / "bot.yaml"
    card.write_text(with_keys((tmp_path / "bot.yaml").read_text()))
    bot = load_card(card)
    assert (
        bot.postures["crouch"]["lower_left_4_joint"] == 1.0
        and bot.postures["crouch"]["lower_right_4_joint"] == 0.0
    )
    assert (
        bot.postures["default"] == bot.postures["crouch"] and "half_sitting" in bot.postures
    )  # the SRDF's too
    assert bot.posture_base_height["crouch"] == pytest.approx(0.95)
    (tmp_path / "keys" / "bot.xml").write_text(spec.to_xml().replace('name="crouch"', 'name=""'))
    with pytest.raises(InputError, match=r"model.keyframes: bot.xml has no named keyframe"):
        load_card(card)
