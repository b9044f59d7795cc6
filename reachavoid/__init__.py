"""reachavoid: the application above the game (design.md).

The ``reachavoid`` command (``cli``), the one episode loop (``rollout``), many episodes and
their statistics (``evaluation``), benchmark suites (``suite``), the paper's table
(``paper``) and the ``solve`` driver.
"""

from reachavoid.evaluation import compare_defenders, run_episodes, summarize
from reachavoid.rollout import EpisodeResult, run_episode

__all__ = ["EpisodeResult", "compare_defenders", "run_episode", "run_episodes", "summarize"]
