"""A Gymnasium environment on fallbench's falls (needs the `learned` extra: `pip install
'fallbench[learned]'`). Importing this package registers `fallbench/Fall-v0`:

    import gymnasium as gym
    import fallbench.environment  # noqa: F401  (registers the id)

    env = gym.make("fallbench/Fall-v0", scenario="examples/learned/falls.yaml", robot="g1")

(or `gym.make("fallbench.environment:fallbench/Fall-v0", ...)`, which imports it). See
docs/methods/learned.md.
"""

from __future__ import annotations

import gymnasium

ENV_ID = "fallbench/Fall-v0"

if ENV_ID not in gymnasium.registry:
    gymnasium.register(id=ENV_ID, entry_point="fallbench.environment.fall:FallEnv")
