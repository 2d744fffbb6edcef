"""Scenario validation never fails with anything but the one-line ScenarioError, and every numeric
field of the schema has a documented range (a new field without bounds fails here)."""

from __future__ import annotations

import atexit
import copy
import io
import shutil
import tempfile
import types
import typing
from pathlib import Path
from typing import Any

import annotated_types
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pydantic import BaseModel
from pydantic.fields import FieldInfo
from ruamel.yaml import YAML

from fallbench.checks import check_scenario
from fallbench.scenario import ScenarioError, ScenarioFile, load_scenario_file

SHIPPED = sorted((Path(__file__).resolve().parents[1] / "scenarios").glob("*.yaml"))
DOCS = {path.name: [doc for doc in YAML(typ="safe").load_all(path.read_text()) if doc] for path in SHIPPED}
TEXTS = {path.name: path.read_text() for path in SHIPPED}
FOLDER = Path(tempfile.mkdtemp(prefix="fallbench-fuzz-"))  # one file rewritten per example
atexit.register(shutil.rmtree, FOLDER, True)


def _bounds(metadata: list[Any]) -> tuple[bool, bool]:
    flat: list[Any] = []
    for item in metadata:
        flat += item.metadata if isinstance(item, FieldInfo) else [item]
    lower = any(isinstance(m, (annotated_types.Gt, annotated_types.Ge)) for m in flat)
    upper = any(isinstance(m, (annotated_types.Lt, annotated_types.Le)) for m in flat)
    return lower, upper


def _numeric_fields(
    annotation: Any, where: str, metadata: list[Any]
) -> typing.Iterator[tuple[str, list[Any]]]:
    origin = typing.get_origin(annotation)
    if origin is typing.Annotated:
        base, *extra = typing.get_args(annotation)
        yield from _numeric_fields(base, where, metadata + extra)
    elif annotation in (int, float):
        yield where, metadata
    elif isinstance(annotation, type) and issubclass(annotation, BaseModel):
        for name, field in annotation.model_fields.items():
            yield from _numeric_fields(field.annotation, f"{where}.{name}".lstrip("."), list(field.metadata))
    elif origin in (typing.Union, types.UnionType, tuple, list, dict):
        for index, arg in enumerate(typing.get_args(annotation)):
            yield from _numeric_fields(arg, f"{where}[{index}]", [])


def test_every_numeric_field_has_a_range() -> None:
    fields = list(_numeric_fields(ScenarioFile, "", []))
    assert len(fields) > 25
    unbounded = [where for where, metadata in fields if _bounds(metadata) != (True, True)]
    assert unbounded == []


# ---------------------------------------------------------------- mutations of the shipped files

VALUES = st.one_of(
    st.floats(),
    st.integers(min_value=-(10**30), max_value=10**30),
    st.text(max_size=12),
    st.booleans(),
    st.none(),
    st.lists(st.floats(allow_nan=True), max_size=4),
    st.dictionaries(st.text(max_size=6), st.integers(), max_size=2),
)


def _paths(node: Any, prefix: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    found = [prefix] if prefix else []
    if isinstance(node, dict):
        for key, value in node.items():
            found += _paths(value, prefix + (key,))
    elif isinstance(node, list):
        for index, value in enumerate(node):
            found += _paths(value, prefix + (index,))
    return found


@st.composite
def mutated_document(draw: st.DrawFn) -> bytes:
    """A shipped file with one value replaced, one key removed or added, or its text cut and spliced."""
    name = draw(st.sampled_from(sorted(DOCS)))
    kind = draw(st.sampled_from(["value", "value", "drop", "add", "text", "bytes"]))
    if kind in ("text", "bytes"):
        data = TEXTS[name].encode()
        start = draw(st.integers(0, len(data)))
        end = draw(st.integers(start, min(len(data), start + 40)))
        insert = draw(st.binary(max_size=12)) if kind == "bytes" else draw(st.text(max_size=12)).encode()
        return data[:start] + insert + data[end:]
    docs = [dict(doc) for doc in DOCS[name]]
    docs = copy.deepcopy(docs)
    doc = draw(st.sampled_from(docs))
    path = draw(st.sampled_from(_paths(doc)))
    parent = doc
    for part in path[:-1]:
        parent = parent[part]
    if kind == "value":
        parent[path[-1]] = draw(VALUES)
    elif kind == "drop" and isinstance(parent, dict):
        del parent[path[-1]]
    elif isinstance(parent, dict):
        parent[
            draw(
                st.sampled_from(
                    ["duration", "seed", "robot", "sweep", "push", "physics_dt", "initial", "extra"]
                )
            )
        ] = draw(VALUES)
    text = io.StringIO()
    YAML(typ="safe", pure=True).dump_all(docs, text)
    return text.getvalue().encode()


@pytest.mark.slow
@settings(max_examples=1000, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(mutated_document())
def test_validation_only_ever_fails_with_one_line(data: bytes) -> None:
    path = FOLDER / "mutated.yaml"
    path.write_bytes(data)
    try:
        load_scenario_file(path, check=check_scenario)
    except ScenarioError as exc:
        message = str(exc)
        assert "\n" not in message and message.startswith(f"{path}:"), message
