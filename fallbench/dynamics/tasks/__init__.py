"""Set-point tasks of the whole-body QPs, one per file, each a `Task` (task.py): error, Jacobian and
drift J_dot q_dot at a `RobotState`."""
