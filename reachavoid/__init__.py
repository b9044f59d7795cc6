"""reachavoid: the application above the game (design.md).

The ``reachavoid`` command (``cli``, started by ``__main__``), the one episode loop
(``rollout``), many episodes and their statistics (``evaluation``), benchmark suites
(``suite``), the paper's table (``paper``), the ``solve`` driver, and training attacker
teams (``training``: the team recipe, and ``exploit``, the best response to each defender).
The names below are imported on first use (PEP 562), so that starting the command loads
nothing before it can handle Ctrl-C.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from reachavoid_env import lazy

if TYPE_CHECKING:
    from reachavoid.evaluation import compare_defenders, run_episodes, summarize
    from reachavoid.rollout import EpisodeResult, run_episode
    from reachavoid.training.exploit import exploit

__all__ = ["EpisodeResult", "compare_defenders", "exploit", "run_episode", "run_episodes",
           "summarize"]

__getattr__, __dir__ = lazy.attributes(__name__, {
    "EpisodeResult": "reachavoid.rollout", "run_episode": "reachavoid.rollout",
    "exploit": "reachavoid.training.exploit",
    **dict.fromkeys(["compare_defenders", "run_episodes", "summarize"], "reachavoid.evaluation"),
})
