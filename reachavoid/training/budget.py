"""What one run of ``reachavoid exploit`` spends (``Budget``): each field a flag of the
command with its default, help and range, checked by ``check_budget``. Light to import (the
command's parser reads it for ``--help``)."""

from __future__ import annotations

from dataclasses import dataclass, field, fields
from typing import Any

from reachavoid_env import checks


def _flag(default: Any, help_text: str, low: float, high: float | None = None,
          metavar: str = "N") -> Any:
    """A ``Budget`` field: its default, and its flag's help, range (``check_budget``) and
    metavar."""
    return field(default=default, metadata={"help": help_text, "range": (low, high),
                                            "metavar": metavar})


@dataclass(frozen=True)
class Budget:
    """What one run spends: PPO's wall minutes (and agent steps at most), the clone's size
    (the 2 vs 1 recipe of docs/training.md by default), PPO's game copies and rollouts,
    and the episodes of the pick and the evaluation. Each field is a flag of the command
    (``--minutes``, ``--imitate-steps``, ...)."""

    minutes: float = _flag(14.0, "wall minutes of PPO per run", 0.0, metavar="M")
    timesteps: int = _flag(3_000_000, "PPO agent steps per run at most", 0, 10**13)
    imitate_steps: int = _flag(80_000, "steps of the best scripted team cloned", 1, 10**13)
    imitate_epochs: int = _flag(40, "passes over the cloned steps", 1, 10**6)
    dagger_rounds: int = _flag(5, "DAgger rounds after the cloning", 0, 10**6)
    dagger_steps: int = _flag(20_000, "steps the clone plays per DAgger round", 1, 10**13)
    dagger_epochs: int = _flag(20, "passes over all labelled steps per DAgger round", 1,
                               10**6)
    net_arch: str = _flag("256,256", "hidden layers of the policy and value networks", 0,
                           metavar="A,B")
    copies: int = _flag(16, "game copies PPO steps together", 1)
    n_steps: int = _flag(256, "PPO rollout length per slot", 1, 10**7)
    batch_size: int = _flag(512, "PPO minibatch", 2, 10**9)
    pick_episodes: int = _flag(100, "starts each scripted team plays in the pick", 1, 10**7)
    episodes: int = _flag(1000, "fresh starts of the evaluation", 1, 10**7)


def check_budget(budget: Budget) -> None:
    """``FieldError`` naming the flag of the first field of ``budget`` out of its range
    (``--net-arch``: positive sizes separated by commas, ``net_arch_sizes``)."""
    for item in fields(budget):
        flag, value = f"--{item.name.replace('_', '-')}", getattr(budget, item.name)
        if item.name == "net_arch":
            from reachavoid.training.config import net_arch_sizes

            net_arch_sizes(value, flag)
        elif isinstance(value, float):
            checks.positive(value, flag)
        elif item.name == "copies":
            from reachavoid_env.vector import MAX_COPIES  # the env: only when checked

            checks.integer(value, flag, 1, MAX_COPIES)
        else:
            checks.integer(value, flag, *item.metadata["range"])
