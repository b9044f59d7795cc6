"""reachavoid: the application above the game (design.md).

The ``reachavoid`` command (``cli``, started by ``__main__``), the one episode loop
(``rollout``), many episodes and their statistics (``evaluation``), benchmark suites
(``suite``), the paper's table (``paper``) and the ``solve`` driver. The names below are
imported on first use, so that starting the command loads nothing before it can handle
Ctrl-C.
"""

from __future__ import annotations

import importlib
from typing import Any

_HOMES = {"compare_defenders": "evaluation", "run_episodes": "evaluation",
          "summarize": "evaluation", "EpisodeResult": "rollout", "run_episode": "rollout"}

__all__ = ["EpisodeResult", "compare_defenders", "run_episode", "run_episodes", "summarize"]


def __getattr__(name: str) -> Any:
    if name not in _HOMES:
        raise AttributeError(f"module 'reachavoid' has no attribute {name!r}")
    return getattr(importlib.import_module(f"reachavoid.{_HOMES[name]}"), name)
