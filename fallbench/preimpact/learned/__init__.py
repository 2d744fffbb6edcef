"""Learned whole-fall controllers: the observation and action layout they are trained with
(`fallbench-obs-v1`), the controller that acts on it, and the `onnx` strategy that runs a policy
file. The Gymnasium environment (`fallbench.environment`) drives the same controller."""
