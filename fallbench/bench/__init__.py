"""`fallbench bench`: fallbench's cost against the physics limit, 2-core sweep scaling, memory.

Everything is measured in one process on the same compiled model, medians of repeats:
- pure physics: mj_step on the scenario's model with the default servo and no controller;
- per policy: episode wall time / pure-physics wall time for the same number of steps, and
  / the time the episode itself spent in mj_step (a collapsing robot has more contacts, so its
  physics costs more than the standing robot's; the second ratio is the controller's overhead);
- controller cost per control step where a controller ran, and the QP's model/build/solve parts;
  `adaptive_qp` once with each QP solver (ProxSuite, the default, and DAQP);
- the reshaping QP's step (model, tasks, build, solve) on a 370 N forward push with `reshape`, with
  each QP solver;
- sweep throughput with 1 and 2 jobs on the same run list (warm workers), peak RSS per worker,
  and bytes stored per run;
- whole commands, start-up included, each in a fresh interpreter: a sweep of shipped drops and
  pushes (four policies, no reshaping) with 1 and 2 jobs, `fallbench run one` on the point, and
  the import time of what `run one` loads;
- the results store at N runs (synthetic rows with a real run's schema): adding one run, a
  grouped SQL query, a read filtered by scenario and policy;
- the Gymnasium environment (`fallbench/Fall-v0`, with the `learned` extra): its steps per second
  over whole episodes of random actions, against the time the same steps spent in mj_step.
"""

from fallbench.bench.markdown import markdown
from fallbench.bench.run import run_bench

__all__ = ["markdown", "run_bench"]
