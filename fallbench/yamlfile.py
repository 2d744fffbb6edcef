"""YAML input files (scenario files, robot cards): reading with line numbers, and every problem as
one line `FILE:LINE: KEY: reason`.

A file is read whole (at most `MAX_FILE_BYTES`), must be UTF-8 text, and holds plain data only: no
YAML tags, no aliases of mappings or lists, no nesting deeper than `MAX_NESTING`. Its schema is a
pydantic model (`Strict`: unknown keys rejected, every number finite); `validation_error` turns
pydantic's first error into an `InputError` at the line of the key it is about.
"""

from __future__ import annotations

import datetime
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ConfigDict, ValidationError
from ruamel.yaml import YAML
from ruamel.yaml.comments import CommentedMap, CommentedSeq, TaggedScalar
from ruamel.yaml.error import MarkedYAMLError, YAMLError

MAX_FILE_BYTES = 128 << 10  # 128 KiB: an input file is a page or two of YAML (parsing 128 KiB takes ~1 s)
MAX_NESTING = 16  # levels of YAML mappings and lists
PLAIN_SCALARS = (str, int, float, bool, type(None), datetime.date)  # dates: implicit YAML timestamps


class InputError(ValueError):
    """Bad input in a file: carries file, line and key so the CLI prints one clear line."""

    def __init__(self, path: Path | str, line: int | None, key: str, reason: str) -> None:
        key, reason = " ".join(key.split()), " ".join(reason.split())  # always one line
        self.path, self.line, self.key, self.reason = str(path), line, key, reason
        where = f"{self.path}:{line}" if line else self.path
        super().__init__(f"{where}: {key}: {reason}" if key else f"{where}: {reason}")


class FieldProblem(ValueError):
    """A problem found by a model validator that belongs to one field (for the error's key and line)."""

    def __init__(self, key: str, reason: str) -> None:
        super().__init__(reason)
        self.key = key


class Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


def line_of(doc: Any, loc: tuple[Any, ...]) -> int | None:
    """1-based line of the deepest node of `loc` that exists in the parsed YAML (a key set after
    parsing, e.g. the environment's `physics_dt`, has none: the line of its parent)."""
    node, line = doc, None
    for part in loc:
        if isinstance(node, CommentedMap) and part in node and part in (node.lc.data or {}):
            line = node.lc.key(part)[0] + 1
            node = node[part]
        elif isinstance(node, CommentedSeq) and isinstance(part, int) and part < len(node):
            line = node.lc.item(part)[0] + 1
            node = node[part]
        else:
            break
    return line


def _read_text(path: Path, kind: str) -> str:
    """The file as UTF-8 text: not too large, not binary. `kind` names the file in messages."""
    try:
        size = path.stat().st_size
        if size > MAX_FILE_BYTES:
            raise InputError(
                path,
                None,
                "",
                f"file too large ({size:,} bytes; a {kind} holds at most {MAX_FILE_BYTES:,})",
            )
        data = path.read_bytes()
    except OSError as exc:
        raise InputError(path, None, "", f"cannot read file ({exc.strerror})") from None
    if b"\0" in data:
        line = data[: data.index(b"\0")].count(b"\n") + 1
        raise InputError(path, line, "", f"binary file (NUL byte): a {kind} is UTF-8 YAML text")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = data[: exc.start].count(b"\n") + 1
        raise InputError(
            path,
            line,
            "",
            f"not UTF-8 text (byte 0x{data[exc.start]:02x}): a {kind} is UTF-8 YAML text",
        ) from None


def _check_tree(
    path: Path, kind: str, node: Any, where: tuple[Any, ...] = (), line: int = 1, seen: set[int] | None = None
) -> None:
    """Reject what plain data never needs: tags (`!!python/...`, `!foo`, `!!binary`, `!!set`),
    aliases of mappings or lists (they multiply nodes), nesting deeper than MAX_NESTING, keys that
    are not plain scalars."""
    seen = set() if seen is None else seen
    key = ".".join(map(str, where))
    if type(node) in (CommentedMap, CommentedSeq):
        if node.tag.value is not None:
            raise InputError(path, line, key, f"YAML tags ({node.tag.value}) are not allowed in {kind}s")
        if id(node) in seen:
            raise InputError(
                path,
                line,
                key,
                f"YAML aliases (*name) of mappings or lists are not allowed in {kind}s: write the value out",
            )
        seen.add(id(node))
        if len(where) >= MAX_NESTING:
            raise InputError(path, line, key, f"nested deeper than {MAX_NESTING} levels")
        if isinstance(node, CommentedMap):
            for name, value in node.items():
                here = node.lc.key(name)[0] + 1
                if not isinstance(name, PLAIN_SCALARS):
                    raise InputError(path, here, key, "a key must be a plain name")
                _check_tree(path, kind, value, where + (name,), here, seen)
        else:
            for index, value in enumerate(node):
                _check_tree(path, kind, value, where + (index,), node.lc.item(index)[0] + 1, seen)
    elif not isinstance(node, PLAIN_SCALARS) or isinstance(node, TaggedScalar):
        tag = getattr(node, "tag", None)
        what = (
            f"YAML tags ({getattr(tag, 'value', tag)})"
            if tag is not None
            else f"YAML tags and special types (here a {type(node).__name__})"
        )
        raise InputError(path, line, key, f"{what} are not allowed in {kind}s")


def read_yaml(path: Path, kind: str) -> list[CommentedMap]:
    """The YAML documents of a file (several can share a file, separated by `---`), each a mapping
    of plain data; `kind` ("scenario file", "robot card") names the file in messages."""
    text = _read_text(path, kind)
    try:
        docs = list(YAML(typ="rt").load_all(text))
    except RecursionError:
        raise InputError(path, None, "", f"nested far deeper than {MAX_NESTING} levels") from None
    except MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        line = mark.line + 1 if mark else None
        reason = f"malformed YAML: {exc.problem or exc.context}"
        if exc.context and exc.context_mark and exc.problem:
            reason += f" ({exc.context} started at line {exc.context_mark.line + 1})"
        raise InputError(path, line, "", reason) from None
    except YAMLError as exc:  # the reader's errors (e.g. a control character) carry no mark
        raise InputError(path, None, "", f"malformed YAML: {exc}") from None
    docs = [doc for doc in docs if doc is not None]
    if not docs:
        raise InputError(path, 1, "", "empty file: expected a YAML mapping")
    for doc in docs:
        if not isinstance(doc, CommentedMap):
            line = doc.lc.line + 1 if hasattr(doc, "lc") else 1
            raise InputError(path, line, "", f"each document of a {kind} must be a YAML mapping")
        _check_tree(path, kind, doc)
    return docs


def plain(node: Any) -> Any:
    """ruamel's round-trip containers as plain dicts and lists."""
    if isinstance(node, dict):
        return {str(k): plain(v) for k, v in node.items()}
    if isinstance(node, list):
        return [plain(v) for v in node]
    return node


def error_location(err: Any, tags: tuple[str, ...] = ()) -> tuple[Any, ...]:
    """Where a pydantic error is: its location without the union `tags` pydantic inserts (the
    discriminator values of a tagged union), plus a FieldProblem's field."""
    loc = tuple(p for p in err["loc"] if not (isinstance(p, str) and p in tags))
    problem = (err.get("ctx") or {}).get("error")
    return loc + tuple(problem.key.split(".")) if isinstance(problem, FieldProblem) else loc


def validation_error(
    path: Path, doc: Any, exc: ValidationError, line_loc: tuple[Any, ...] = (), tags: tuple[str, ...] = ()
) -> InputError:
    """pydantic's first error as one line, at the line of `line_loc` (default: the error's key)."""
    err = exc.errors()[0]
    loc = error_location(err, tags)
    key = ".".join(str(p) for p in loc) or "(top level)"
    line = line_of(doc, line_loc or loc) or 1
    reason = err["msg"].removeprefix("Value error, ")
    if err["type"] == "extra_forbidden":
        reason = "unknown key"
    elif "input" in err and err["type"] not in ("missing",) and not isinstance(err["input"], dict):
        got = repr(err["input"])
        reason += f" (got {got if len(got) <= 60 else got[:57] + '...'})"
    return InputError(path, line, key, reason)
