"""fallbench: compare humanoid fall-control strategies on the same robot, falls and damage measures."""

import os
import sys

__version__ = "0.1.0"

# MuJoCo picks its OpenGL backend when it is first imported; offscreen rendering (filmstrips,
# `fallbench render`) needs EGL on a headless Linux machine. A user's own MUJOCO_GL wins.
if sys.platform.startswith("linux"):
    os.environ.setdefault("MUJOCO_GL", "egl")
