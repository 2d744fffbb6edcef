"""fallbench's user cache folder, shared by the compiled worlds, the reach samples and the meshes."""

from __future__ import annotations

import os
from pathlib import Path


def cache_root() -> Path:
    """$XDG_CACHE_HOME/fallbench, or ~/.cache/fallbench."""
    return Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "fallbench"
