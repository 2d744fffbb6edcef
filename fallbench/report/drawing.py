"""Drawing the report's figures: in parallel worker processes, and only those whose inputs changed.

Each figure is a `Figure`: a module-level function, its arguments (tables of metric rows, names)
and the ids of the runs whose stored files it reads. Its cache key is a BLAKE2 digest of

- the report's code version (the bytes of every `fallbench/report/*.py`, fallbench's and
  matplotlib's versions) and whether vector files are written (`--svg`);
- the function's name and its arguments (DataFrames by content: the column names, the bytes of
  each numeric column and `pandas.util.hash_pandas_object` of every other cell);
- the content of every run it reads: the bytes of each file in the run's folder.

The cache (`.figure-cache.json` in the report folder) maps each figure's name to its key and
files. A figure whose key is unchanged and whose files are all present is not drawn again. File
digests are remembered by (path, size, modification time), so a warm report reads no run file
again; a run written anew (another size or time) is read and hashed again.
"""

from __future__ import annotations

import hashlib
import json
import os
import time
from collections.abc import Callable, Iterable
from concurrent.futures import Future
from dataclasses import dataclass, field
from functools import cache
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from fallbench.report.figure_files import FigureSkipped, files_only, set_vector
from fallbench.results import store

CACHE_FILE = ".figure-cache.json"
PAYLOADS = ".figure-cache"  # folder of the cached payloads (pickles), one per key
CACHE_FORMAT = 1


@dataclass(frozen=True)
class Figure:
    """One figure (or a few files drawn together): `draw(*args)` writes them and returns their
    paths, or (paths, payload) with a picklable payload (e.g. the tables computed with them), which
    is cached with the files."""

    name: str  # unique within a report, e.g. "002:drop#height=1"
    draw: Callable[..., list[Path]]
    args: tuple = ()
    run_ids: tuple[str, ...] = ()  # runs whose stored files `draw` reads
    group: str = ""  # figures added together with the same group are drawn by one worker, in turn


@dataclass
class Drawn:
    """What drawing a list of figures gave: files per figure name, notes (e.g. why a filmstrip is
    missing), and how many were drawn and how many were taken from the cache."""

    paths: dict[str, list[Path]] = field(default_factory=dict)
    notes: dict[str, str] = field(default_factory=dict)
    payloads: dict[str, Any] = field(default_factory=dict)  # what a job returned besides its files
    cpu_s: dict[str, float] = field(default_factory=dict)  # CPU time of each figure drawn (s)
    drawn: int = 0
    cached: int = 0


@cache
def code_version() -> str:
    """The report's code and style: a digest of fallbench/report/*.py and the library versions."""
    import matplotlib

    import fallbench

    digest = hashlib.blake2b(digest_size=16)
    for path in sorted(Path(__file__).parent.glob("*.py")):
        digest.update(path.name.encode() + path.read_bytes())
    digest.update(f"{getattr(fallbench, '__version__', '')}|{matplotlib.__version__}".encode())
    return digest.hexdigest()


def _value_digest(value: Any, digest: Any) -> None:
    """Feed one argument into `digest`: tables by content, paths by nothing (the runs they hold
    are keyed by `run_ids`; the output folder is the cache's own), everything else by repr."""
    if isinstance(value, pd.DataFrame):
        digest.update(repr(list(value.columns)).encode())
        for _, column in value.items():  # numbers by their bytes, the rest by pandas' hash of each cell
            if isinstance(column.dtype, np.dtype) and column.dtype.kind in "biuf":
                digest.update(column.dtype.str.encode() + column.to_numpy().tobytes())
            else:
                digest.update(
                    pd.util.hash_pandas_object(column.astype(object), index=False).to_numpy().tobytes()
                )
    elif isinstance(value, pd.Series):
        _value_digest(value.to_frame(), digest)
    elif isinstance(value, Path):
        digest.update(b"<path>")
    elif isinstance(value, (list, tuple)):
        for item in value:
            _value_digest(item, digest)
    else:
        digest.update(repr(value).encode())


class _RunDigests:
    """Content digests of run folders, remembered by (path, size, mtime) across reports."""

    def __init__(self, results: Path, known: dict[str, list]) -> None:
        self.results = results
        self.known = known  # "runs/<id>/<file>" -> [size, mtime_ns, digest]
        self.used: dict[str, list] = {}

    def of(self, run_id: str) -> str:
        digest = hashlib.blake2b(digest_size=16)
        folder = store.run_dir(self.results, run_id)
        for path in sorted(folder.iterdir()) if folder.is_dir() else []:
            digest.update(path.name.encode() + self._file(path).encode())
        return digest.hexdigest()

    def _file(self, path: Path) -> str:
        stat = path.stat()
        name = str(path.relative_to(self.results))
        entry = self.known.get(name)
        if entry is None or entry[:2] != [stat.st_size, stat.st_mtime_ns]:
            entry = [stat.st_size, stat.st_mtime_ns, _file_digest(path)]
        self.used[name] = entry
        return entry[2]


def _file_digest(path: Path) -> str:
    digest = hashlib.blake2b(digest_size=16)
    with open(path, "rb") as handle:
        while chunk := handle.read(1 << 20):
            digest.update(chunk)
    return digest.hexdigest()


def figure_key(figure: Figure, runs: _RunDigests, vector: bool) -> str:
    digest = hashlib.blake2b(digest_size=16)
    digest.update(f"{code_version()}|{vector}|{figure.name}|".encode())
    digest.update(f"{figure.draw.__module__}.{figure.draw.__qualname__}".encode())
    _value_digest(figure.args, digest)
    for run_id in figure.run_ids:
        digest.update(run_id.encode() + runs.of(run_id).encode())
    return digest.hexdigest()


def _load_cache(out: Path) -> dict[str, Any]:
    try:
        cached = json.loads((out / CACHE_FILE).read_text())
    except (OSError, ValueError):
        return {"format": CACHE_FORMAT, "figures": {}, "files": {}}
    return (
        cached
        if cached.get("format") == CACHE_FORMAT
        else {"format": CACHE_FORMAT, "figures": {}, "files": {}}
    )


Outcome = tuple[list[Path], str, Any, float]  # files, note ("" or why skipped), payload, CPU s


def _draw_one(figure: Figure, vector: bool) -> Outcome:
    """In a worker: draw one figure; also returns the CPU time it took (s, this process's threads)."""
    files_only()
    before = set_vector(vector)
    started = time.process_time()
    try:
        drawn = figure.draw(*figure.args)
    except FigureSkipped as exc:
        return [], str(exc), None, time.process_time() - started
    except FileNotFoundError as exc:  # a run stored without its time series (or since deleted)
        return [], f"{figure.name}: skipped, {exc.filename or exc} is missing", None, 0.0
    finally:
        set_vector(before)  # drawing in this process leaves its setting as it was
    cpu = time.process_time() - started
    if isinstance(drawn, tuple):
        return list(drawn[0]), "", drawn[1], cpu
    return list(drawn), "", None, cpu


def _draw_group(figures: list[Figure], vector: bool) -> list[Outcome]:
    """In a worker: draw the figures in turn."""
    return [_draw_one(figure, vector) for figure in figures]


class Drawing:
    """Figures drawn as they are added: each one not in the cache goes to a worker process at once
    (with `jobs` > 1, loky's reusable executor; in this process, in turn, at `finish` with one job),
    so that the report computes its tables while the figures added first are drawn."""

    def __init__(self, results: Path, out: Path, jobs: int = 1, vector: bool = False) -> None:
        self.out, self.jobs, self.vector = out, jobs, vector
        self.cached = _load_cache(out)
        self.digests = _RunDigests(results, self.cached["files"])
        self.keys: dict[str, str] = {}
        self.result = Drawn()
        self.todo: dict[str, Figure] = {}  # drawn in this process at `finish` (one job)
        self.pending: list[tuple[list[str], Future]] = []  # drawn by the workers, a group per task
        self.pool: Any = None

    def add(self, figures: Iterable[Figure]) -> None:
        """Take each figure from the cache, or start drawing it: in the order given, the figures of
        a group together, at the place of its first (e.g. the filmstrips of one scene, so that one
        worker makes its renderer)."""
        tasks: dict[str, list[Figure]] = {}
        for figure in figures:
            if figure.name in self.keys:
                raise ValueError("figure names must be unique within a report")
            self.keys[figure.name] = figure_key(figure, self.digests, self.vector)
            entry = self.cached["figures"].get(figure.name)
            if entry and entry["key"] == self.keys[figure.name] and _complete(self.out, entry):
                self._take_cached(figure.name, entry)
            elif self.jobs > 1:
                tasks.setdefault(f"group:{figure.group}" if figure.group else figure.name, []).append(figure)
            else:
                self.todo[figure.name] = figure
        for task in tasks.values():
            self.pool = self.pool or _executor(self.jobs)
            self.pending.append(([f.name for f in task], self.pool.submit(_draw_group, task, self.vector)))

    def _take_cached(self, name: str, entry: dict[str, Any]) -> None:
        self.result.paths[name] = [self.out / p for p in entry["files"]]
        if entry.get("note"):
            self.result.notes[name] = entry["note"]
        if entry.get("payload"):
            self.result.payloads[name] = pd.read_pickle(self.out / entry["payload"])
        self.result.cached += 1

    def finish(self, order: Iterable[Figure] = ()) -> Drawn:
        """Wait for every figure added, save the cache; returns their files and notes, in the
        order of `order` (the same figures) if given, else as added."""
        outcomes = {name: _draw_one(figure, self.vector) for name, figure in self.todo.items()}
        for names, future in self.pending:
            outcomes |= dict(zip(names, future.result()))
        for name, (paths, note, payload, cpu) in outcomes.items():
            self._take_drawn(name, paths, note, payload, cpu)
        self.result.drawn = len(outcomes)
        names = [f.name for f in order] or list(self.keys)
        if sorted(names) != sorted(self.keys):
            raise ValueError("finish: `order` must hold the figures added")
        self.save_figure(names)
        self.result.paths = {name: self.result.paths[name] for name in names}
        return self.result

    def _take_drawn(self, name: str, paths: list[Path], note: str, payload: Any, cpu: float) -> None:
        self.result.paths[name] = paths
        self.result.cpu_s[name] = cpu
        if note:
            self.result.notes[name] = note
        if payload is not None:
            self.result.payloads[name] = payload
            pd.to_pickle(payload, _payload_path(self.out, self.keys[name]))

    def save_figure(self, names: list[str]) -> None:
        """Write the cache of these figures and delete the payloads no figure uses any more."""
        out, result, cached = self.out, self.result, self.cached["figures"]
        entries = {
            name: {
                "key": self.keys[name],
                "files": [str(p.relative_to(out)) for p in result.paths[name]],
                "note": result.notes.get(name, ""),
                "cpu_s": round(result.cpu_s.get(name, cached.get(name, {}).get("cpu_s", 0.0)), 3),
                "payload": str(_payload_path(out, self.keys[name]).relative_to(out))
                if name in result.payloads
                else "",
            }
            for name in names
            if not _unavailable(result.notes.get(name, ""))
        }
        _save_cache(out, {"format": CACHE_FORMAT, "figures": entries, "files": self.digests.used})
        kept = {e["payload"] for e in entries.values() if e["payload"]}
        for stale in (out / PAYLOADS).glob("*.pkl") if (out / PAYLOADS).is_dir() else []:
            if str(stale.relative_to(out)) not in kept:
                stale.unlink()


WORKER_GROWTH = int(2e9)  # bytes a drawing worker may grow by over its size after its first figure


def _executor(jobs: int) -> Any:
    """loky's reusable pool of `jobs` worker processes (started by the first figure sent to it)."""
    from joblib.externals.loky import get_reusable_executor

    return get_reusable_executor(max_workers=jobs, initializer=_worker_start)


def start_workers(jobs: int, modules: tuple[str, ...] = ()) -> None:
    """With `jobs` > 1, start the drawing workers now and have them import `modules` (those most
    figures are drawn by: each worker draws every kind), while this process loads the runs."""
    if jobs > 1:
        pool = _executor(jobs)
        for _ in range(jobs):
            pool.submit(_warm_up, modules)


def _warm_up(modules: tuple[str, ...]) -> None:
    import importlib

    files_only()
    for module in modules:
        importlib.import_module(module)


def _worker_start() -> None:
    """In each worker, before its first figure: loky restarts a worker whose memory grew by 300 MB
    over its size after its first figure, and the first filmstrip a worker renders adds ~430 MB
    that it keeps (the OpenGL libraries, the renderer's buffers, the scene's meshes), whatever ran
    first; a restart costs a new process and its imports, so the figures can come in any order."""
    from joblib.externals.loky import process_executor

    if hasattr(process_executor, "_MAX_MEMORY_LEAK_SIZE"):
        process_executor._MAX_MEMORY_LEAK_SIZE = WORKER_GROWTH


def draw(
    figures: Iterable[Figure],
    results: Path,
    out: Path,
    jobs: int = 1,
    vector: bool = False,
    progress: Callable[[int], None] | None = None,
) -> Drawn:
    """Draw the figures whose cache key changed or whose files are missing, take the others from the
    cache in `out`; returns every figure's files (in the order given) and the notes."""
    drawing = Drawing(results, out, jobs, vector)
    drawing.add(figures)
    drawn = drawing.finish()
    if progress:
        progress(drawn.drawn)
    return drawn


def _complete(out: Path, entry: dict[str, Any]) -> bool:
    files = entry["files"] + ([entry["payload"]] if entry.get("payload") else [])
    return all((out / p).exists() for p in files)


def _payload_path(out: Path, key: str) -> Path:
    folder = out / PAYLOADS
    folder.mkdir(exist_ok=True)
    return folder / f"{key}.pkl"


def _unavailable(note: str) -> bool:
    """A note of a missing OpenGL context is not cached: the next report may have one."""
    return note.startswith("no OpenGL")


def _save_cache(out: Path, cached: dict[str, Any]) -> None:
    tmp = out / f".{CACHE_FILE}.{os.getpid()}.tmp"
    tmp.write_text(json.dumps(cached))
    os.replace(tmp, out / CACHE_FILE)
