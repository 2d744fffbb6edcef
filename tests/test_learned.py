"""Learned whole-fall controllers: the `onnx` strategy with a tiny model the test builds itself
(onnx's helpers, no PyTorch), the model checks, and the Gymnasium environment's contract."""

from __future__ import annotations

import json
from pathlib import Path

import gymnasium
import numpy as np
import onnx
import pytest
from gymnasium.utils.env_checker import check_env
from onnx import TensorProto, helper, numpy_helper

import fallbench.environment  # noqa: F401  (registers fallbench/Fall-v0)
from fallbench.assembly import simulate_named
from fallbench.checks import load
from fallbench.environment import ENV_ID
from fallbench.environment.fall import FallEnv
from fallbench.preimpact.learned.observation import observation_size
from fallbench.preimpact.learned.onnx import model_problem
from fallbench.results.store import load_metrics
from fallbench.scenario import ScenarioError

JOINTS = {"g1": 29, "talos": 32}  # actuated joints (MuJoCo actuators)


def tiny_model(
    path: Path, inputs: int, outputs: int, dtype: int = TensorProto.FLOAT, batch: object = "batch"
) -> Path:
    """action = tanh(W obs + b), W small and random: a policy that moves every joint."""
    numpy_type = helper.tensor_dtype_to_np_dtype(dtype)
    weights = (0.3 * np.random.default_rng(0).standard_normal((inputs, outputs))).astype(numpy_type)
    graph = helper.make_graph(
        [
            helper.make_node("MatMul", ["obs", "W"], ["h"]),
            helper.make_node("Add", ["h", "b"], ["z"]),
            helper.make_node("Tanh", ["z"], ["action"]),
        ],
        "tiny_policy",
        [helper.make_tensor_value_info("obs", dtype, [batch, inputs])],
        [helper.make_tensor_value_info("action", dtype, [batch, outputs])],
        [
            numpy_helper.from_array(weights, "W"),
            numpy_helper.from_array(np.full(outputs, 0.1, numpy_type), "b"),
        ],
    )
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])
    model.ir_version = 8
    onnx.checker.check_model(model)
    onnx.save(model, path)
    return path


def drop_file(tmp_path: Path, models: dict[str, Path], duration: float = 0.8) -> Path:
    """A short drop per robot, `none` and `onnx` pinned, each robot with its own model."""
    documents = [
        f"name: learned_drop\nrobot: {robot}\nduration: {duration}\n"
        "initial: {posture: default, height: 0.5}\npre_impact: [none, onnx]\n"
        f"policy_params:\n  onnx: {{model: {model}}}\n"
        for robot, model in models.items()
    ]
    path = tmp_path / "learned.yaml"
    path.write_text("---\n".join(documents))
    return path


@pytest.fixture(scope="module")
def g1_model(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tiny_model(tmp_path_factory.mktemp("onnx") / "g1.onnx", observation_size(29), 29)


def test_onnx_policy_runs_in_a_sweep_on_both_robots(tmp_path: Path, sweep, g1_model: Path) -> None:
    talos = tiny_model(tmp_path / "talos.onnx", observation_size(JOINTS["talos"]), JOINTS["talos"])
    suite = drop_file(tmp_path, {"g1": g1_model, "talos": talos})
    result = sweep(suite, tmp_path / "results", policies="stiff,zero")
    assert result.exit_code == 0, result.output
    table = load_metrics(tmp_path / "results")
    assert (table.status == "ok").all(), table[["pre_impact", "policy", "status", "error"]]
    # the whole-fall controller runs once per point with the policy `-`; `none` with each gain policy
    labels = sorted(zip(table.robot, table.pre_impact, table.policy))
    assert labels == sorted(
        (robot, pre, policy)
        for robot in ("g1", "talos")
        for pre, policy in (("none", "stiff"), ("none", "zero"), ("onnx", "-"))
    )


def test_onnx_policy_drives_the_joints_through_the_landing(tmp_path: Path, g1_model: Path) -> None:
    [point] = load([drop_file(tmp_path, {"g1": g1_model})])
    recording = simulate_named(point.scenario, "-", "onnx")
    world, detected = recording.world, recording.time >= recording.fall_time
    assert recording.impact_time is not None and np.isnan(recording.switch_time).all()  # never handed over
    after_impact = recording.time > recording.impact_time + 0.05
    gains = np.array([world.robot.learned_gains(j)[0] for j in world.joint_names])
    # the policy's servo to the end, not a gain policy's
    assert np.allclose(recording.kp[after_impact], gains)
    targets = recording.q_ref[detected]
    changes = np.flatnonzero(np.any(np.diff(targets, axis=0) != 0, axis=1)) + 1
    # a new target every 20 ms (50 Hz, the default control_dt) from fall detection to the end
    decided = recording.time[detected][changes]
    assert np.allclose(np.diff(decided), 0.02) and decided[-1] >= point.scenario.duration - 0.02 - 1e-9
    assert recording.policy_stats["policy_decisions"] == len(changes)


@pytest.mark.parametrize(
    ("inputs", "outputs", "dtype", "reason"),
    [
        (observation_size(29) - 3, 29, TensorProto.FLOAT, "has shape ['batch', 90], expected [1, 93]"),
        (observation_size(29), 12, TensorProto.FLOAT, "has shape ['batch', 12], expected [1, 29]"),
        (observation_size(29), 29, TensorProto.DOUBLE, "is tensor(double), expected tensor(float)"),
    ],
)
def test_a_model_that_does_not_fit_is_one_line_before_any_run(
    tmp_path: Path, sweep, inputs: int, outputs: int, dtype: int, reason: str
) -> None:
    model = tiny_model(tmp_path / "bad.onnx", inputs, outputs, dtype)
    suite = drop_file(tmp_path, {"g1": model})
    result = sweep(suite, tmp_path / "results")
    assert result.exit_code == 2
    [line] = result.output.strip().splitlines()
    assert line.startswith(f"error: {suite}:7: policy_params.onnx.model: ") and reason in line
    assert result.simulated == () and not (tmp_path / "results").exists()


def test_a_strategy_chosen_on_the_command_line_is_checked_too(tmp_path: Path, sweep) -> None:
    suite = tmp_path / "drop.yaml"
    suite.write_text("name: d\nrobot: g1\nduration: 0.5\ninitial: {height: 0.5}\n")
    result = sweep(suite, tmp_path / "results", pre_impact="none,onnx")
    assert result.exit_code == 2
    assert result.output.strip() == (
        f"error: {suite}: policy_params.onnx.model: the ONNX policy file is required for strategy 'onnx'"
    )


def test_policy_param_option_gives_the_model_to_every_point(tmp_path: Path, sweep, g1_model: Path) -> None:
    suite = tmp_path / "drop.yaml"
    suite.write_text("name: d\nrobot: g1\nduration: 0.4\ninitial: {height: 0.3}\n")
    result = sweep(suite, tmp_path / "results", "--policy-param", f"onnx.model={g1_model}", pre_impact="onnx")
    assert result.exit_code == 0, result.output
    table = load_metrics(tmp_path / "results")
    assert list(zip(table.pre_impact, table.policy, table.status)) == [("onnx", "-", "ok")]
    bad = sweep(suite, tmp_path / "other", "--policy-param", "onnx.model", pre_impact="onnx")
    assert bad.exit_code == 2 and bad.output.startswith(
        "error: --policy-param 'onnx.model': expected NAME.KEY=VALUE"
    )


# ---------------------------------------------------------------- the Gymnasium environment


@pytest.fixture(scope="module")
def falls(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Randomised short G1 drops (height and friction drawn at every reset)."""
    path = tmp_path_factory.mktemp("env") / "falls.yaml"
    path.write_text(
        "name: env_drop\nrobot: g1\nduration: 0.5\ninitial: {posture: default, height: 0.4}\n"
        "randomize:\n  initial.height: [0.3, 0.6]\n  friction: [0.5, 1.0]\n"
    )
    return path


def test_environment_reset_and_step_contract(falls: Path) -> None:
    env = gymnasium.make(ENV_ID, scenario=str(falls))
    obs, info = env.reset(seed=3)
    assert obs.shape == (observation_size(29),) and obs.dtype == np.float32
    assert env.action_space.shape == (29,)
    assert np.allclose(obs[:3], [0, 0, -1], atol=0.05)  # upright: gravity along the root's -z
    again, info_again = env.reset(seed=3)
    assert np.array_equal(obs, again) and info["point"] == info_again["point"]  # a seed is one fall
    assert env.reset(seed=4)[1]["point"] != info["point"]  # another seed, another draw
    terminated = truncated = False
    rewards, times = [], [info["t"]]
    while not (terminated or truncated):
        obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
        assert obs.shape == (observation_size(29),)
        rewards.append(reward)
        times.append(info["t"])
    assert truncated and not terminated  # still falling at the 0.5 s cap: a time limit, not an end
    assert info["t"] == pytest.approx(0.5)
    steps = np.diff(times)  # one step = one decision of the policy, 20 ms apart (control_dt)
    assert np.allclose(steps[:-1], 0.02) and 0 < steps[-1] <= 0.02 + 1e-9
    assert all(r <= 0 for r in rewards) and min(rewards) < 0  # damage costs; the landing costs most
    with pytest.raises(RuntimeError):
        env.step(env.action_space.sample())
    check_env(env.unwrapped, skip_render_check=True)


def test_environment_steps_the_runner_episode(falls: Path, g1_model: Path, tmp_path: Path) -> None:
    """The onnx strategy in the runner and the same model acting through the environment on the
    same fall give the same trajectory: one episode code."""
    import onnxruntime

    fixed = tmp_path / "fixed.yaml"
    fixed.write_text(
        "name: env_drop\nrobot: g1\nduration: 0.5\ninitial: {posture: default, height: 0.4}\n"
        f"policy_params:\n  onnx: {{model: {g1_model}}}\n"
    )
    env = gymnasium.make(ENV_ID, scenario=str(fixed)).unwrapped
    session = onnxruntime.InferenceSession(str(g1_model), providers=["CPUExecutionProvider"])
    obs, _ = env.reset(seed=0)
    terminated = truncated = False
    while not (terminated or truncated):
        obs, _, terminated, truncated, _ = env.step(session.run(None, {"obs": obs[None]})[0][0])
    [point] = load([fixed])
    recording = simulate_named(point.scenario, "-", "onnx")
    assert env.episode.step == recording.steps
    assert np.array_equal(env.episode.trace.qpos[: recording.steps], recording.qpos)


def test_environment_ends_the_episode_at_rest(tmp_path: Path) -> None:
    """The environment ends a fall by the runner's rule: terminated once the robot is at rest,
    at the same step as the runner's run (here a short drop the robot lands on its feet from)."""
    path = tmp_path / "rest.yaml"
    path.write_text("name: env_rest\nrobot: g1\nduration: 6\ninitial: {posture: default, height: 0.1}\n")
    env = gymnasium.make(ENV_ID, scenario=str(path)).unwrapped
    env.reset(seed=0)
    terminated = truncated = False
    while not (terminated or truncated):
        _, _, terminated, truncated, info = env.step(np.zeros(29))
    assert terminated and not truncated and info["t"] < 6.0
    assert env.episode.rest.settled


def _episode(env: FallEnv, seed: int) -> tuple[list[float], list[float], bool]:
    """Rewards and fall terms of one episode of the zero action, and whether it was truncated."""
    env.reset(seed=seed)
    rewards, fell, terminated, truncated = [], [], False, False
    while not (terminated or truncated):
        _, reward, terminated, truncated, info = env.step(np.zeros(29))
        rewards.append(reward)
        fell.append(info["damage"]["fell"])
    return rewards, fell, truncated


@pytest.mark.parametrize("fallen", [True, False])
def test_fall_term_is_paid_once_on_a_fallen_last_step(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, fallen: bool
) -> None:
    """`DamageWeights.fell` is paid once, on the episode's last step, if the robot ends it below
    fallbench's fallen height; with weight 0 the reward is the damage alone, step for step. The
    zero action (the default posture under G1's compliant learned gains: the ankles' 2 x 40 Nm/rad
    is under m g l, ~207 Nm/rad) does not keep G1 up even after a 0.3 m drop, so the survived end
    is the same fall judged against a fallen height below the floor."""
    if not fallen:
        monkeypatch.setattr("fallbench.environment.fall.fell_height", lambda *_: 0.0)
    path = tmp_path / "fell.yaml"
    path.write_text("name: env_fell\nrobot: g1\nduration: 0.5\ninitial: {posture: default, height: 0.3}\n")
    plain = FallEnv(path, physics_dt=0.001, cap=6.0)
    weighted = FallEnv(path, reward_weights={"fell": 5.0}, physics_dt=0.001, cap=6.0)
    base, base_fell, truncated = _episode(plain, 0)
    rewards, fell, _ = _episode(weighted, 0)
    assert not truncated and plain.episode.rest.settled  # the 6 s cap replaced the file's 0.5 s
    assert fell[:-1] == [0.0] * (len(fell) - 1) and fell[-1] == float(fallen) and base_fell == fell
    assert rewards[:-1] == base[:-1] and rewards[-1] == pytest.approx(base[-1] - 5.0 * fallen, abs=1e-12)
    last = plain.episode.trace.qpos[plain.episode.step - 1, 2]
    assert last < 0.6 * 0.755  # lying: under metrics.FELL_HEIGHT_FRACTION x G1's standing height


def test_vectorised_environment(falls: Path) -> None:
    envs = gymnasium.make_vec(ENV_ID, num_envs=2, vectorization_mode="sync", scenario=str(falls))
    obs, _ = envs.reset(seed=[1, 2])
    assert obs.shape == (2, observation_size(29))
    obs, rewards, terminated, truncated, _ = envs.step(envs.action_space.sample())
    assert obs.shape == (2, observation_size(29)) and rewards.shape == (2,)
    envs.close()


def test_environment_physics_step_option(falls: Path) -> None:
    """`physics_dt` replaces every fall's step (a coarser one for training) and is checked as the
    scenario key is."""
    env = gymnasium.make(ENV_ID, scenario=str(falls), physics_dt=0.001).unwrapped
    env.reset(seed=3)
    assert env.episode.scenario.physics_dt == 0.001
    before = env.episode.step
    env.step(np.zeros(29))
    assert env.episode.step - before == 20  # one 20 ms decision = 20 physics steps of 1 ms
    with pytest.raises(ScenarioError, match="physics_dt"):
        FallEnv(falls, physics_dt=0.05)  # longer than the control step


def test_shipped_baseline_fits_g1_and_records_its_training() -> None:
    """The main job's learned baseline: a G1 policy, with the command and seed that made it."""
    folder = Path(__file__).parent.parent / "examples" / "learned" / "g1_ppo"
    assert model_problem(folder / "policy.onnx", JOINTS["g1"]) is None
    assert model_problem(folder / "policy.onnx", JOINTS["talos"]) is not None
    record = json.loads((folder / "train.json").read_text())
    assert record["seed"] == 0 and record["timesteps"] >= 1_000_000
    assert record["export_max_abs_difference"] < 1e-5
    assert (folder / "policy.onnx").stat().st_size < 1_000_000
