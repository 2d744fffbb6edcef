"""fallbench: compare humanoid fall-control strategies on the same robot, falls and damage measures."""

__version__ = "0.1.0"
