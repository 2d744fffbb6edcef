"""`onnx`: a learned whole-fall policy given as an ONNX file, run with onnxruntime.

`policy_params.onnx.model: PATH` (relative to the working folder) names a model with one float
input of shape [1, 6 + 3 n] (the `fallbench-obs-v1` observation; a symbolic first dimension is
accepted) and one float output of shape [1, n], n = the robot's actuated joints. A model that does
not fit the scenario's robot is a scenario error, found when the scenario loads, before any run.
"""

from __future__ import annotations

import hashlib
from functools import cache
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from fallbench.preimpact.learned.observation import observation_size
from fallbench.preimpact.learned.strategy import LEARNED_DEFAULTS, LearnedStrategy

if TYPE_CHECKING:
    import onnxruntime

    from fallbench.scenario import Scenario
    from fallbench.sim.world import World

FLOAT = "tensor(float)"


@cache
def _session(path: str, modified_ns: int, size: int) -> onnxruntime.InferenceSession:
    """One inference session per model file version (a file rewritten in place is read again);
    one thread, so that a sweep's workers do not contend and the outputs are repeatable."""
    import onnxruntime

    options = onnxruntime.SessionOptions()
    options.intra_op_num_threads = options.inter_op_num_threads = 1
    options.log_severity_level = 3  # errors only
    return onnxruntime.InferenceSession(path, options, providers=["CPUExecutionProvider"])


@cache
def _digest(path: str, modified_ns: int, size: int) -> str:
    """SHA-256 of a file's content, read once per file version (a run id asks for it often)."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def session_for(path: Path) -> onnxruntime.InferenceSession:
    status = path.stat()
    return _session(str(path.resolve()), status.st_mtime_ns, status.st_size)


def _dimension_problem(shape: list[Any], size: int, what: str) -> str | None:
    """Why a tensor shape is not [1, size] (a symbolic or unknown first dimension accepted)."""
    fits = (
        len(shape) == 2
        and (shape[0] == 1 or not isinstance(shape[0], int))
        and isinstance(shape[1], int)
        and shape[1] == size
    )
    return None if fits else f"{what} has shape {list(shape)}, expected [1, {size}]"


def model_problem(path: Path, joints: int) -> str | None:
    """Why the ONNX file at `path` cannot run as a policy of a robot with `joints` actuated joints."""
    if not path.is_file():
        return f"no such file {str(path)!r}"
    try:
        session = session_for(path)
    except Exception as exc:  # onnxruntime raises its own exception types for every bad file
        return f"not a loadable ONNX model ({' '.join(str(exc).split())[:200]})"
    inputs, outputs = session.get_inputs(), session.get_outputs()
    if len(inputs) != 1 or len(outputs) != 1:
        return f"expected one input and one output, the model has {len(inputs)} and {len(outputs)}"
    for tensor, what in ((inputs[0], "input"), (outputs[0], "output")):
        if tensor.type != FLOAT:
            return f"{what} {tensor.name!r} is {tensor.type}, expected {FLOAT} (float32)"
    return _dimension_problem(
        inputs[0].shape, observation_size(joints), f"input {inputs[0].name!r} (fallbench-obs-v1)"
    ) or _dimension_problem(outputs[0].shape, joints, f"output {outputs[0].name!r} (one per actuated joint)")


class OnnxStrategy(LearnedStrategy):
    """A learned whole-fall policy read from an ONNX file (see the module docstring)."""

    name = "onnx"
    defaults = LEARNED_DEFAULTS | {"model": ""}  # path of the .onnx file

    def __init__(self, world: World, scenario: Scenario) -> None:
        super().__init__(world, scenario)
        self.session = session_for(Path(self.params["model"]))
        self.input_name = self.session.get_inputs()[0].name

    @classmethod
    def check(cls, scenario: Scenario) -> tuple[str, str] | None:
        problem = super().check(scenario)
        if problem:
            return problem
        from fallbench.sim.world import build_world

        model = scenario.policy_params.get(cls.name, {}).get("model", "")
        key = f"policy_params.{cls.name}.model"
        if not model:
            return key, "the ONNX policy file is required for strategy 'onnx'"
        problem_text = model_problem(Path(model), build_world(scenario).model.nu)
        return (key, problem_text) if problem_text else None

    @classmethod
    def inputs(cls, scenario: Scenario) -> dict[str, str]:
        model = scenario.policy_params.get(cls.name, {}).get("model", "")
        if not model or not Path(model).is_file():
            return {}
        status = Path(model).stat()
        return {model: _digest(str(Path(model).resolve()), status.st_mtime_ns, status.st_size)}

    def decide(self, observation: np.ndarray) -> np.ndarray:
        output = self.session.run(None, {self.input_name: observation[None]})[0]
        return output[0]
