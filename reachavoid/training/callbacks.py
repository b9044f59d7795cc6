"""The team recipe's PPO callbacks and wrappers: the curriculum of easy starts, the
training curve (rows, the printed line, its plot), snapshots for self-play with past
policies, and full-speed actions."""

from __future__ import annotations

import copy
import time
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure
from stable_baselines3 import PPO
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.vec_env import VecEnvWrapper

from policies.learned import Predict
from reachavoid.training.curriculum import StartCurriculum
from reachavoid.training.self_play import PastSelves
from reachavoid_env import AttackerStatus
from reachavoid_env.files import atomic_write
from reachavoid_env.rules import unit_vectors


class EasyStarts(BaseCallback):
    """Sets the training envs' ``start_reach`` from ``curriculum`` before every rollout;
    the progress is the larger of the agent steps done over ``total_steps`` and the wall
    time over ``max_seconds``. ``reach``: the current one (map units; ``None``: anywhere)."""

    def __init__(self, curriculum: StartCurriculum, diagonal: float, total_steps: int,
                 max_seconds: float | None) -> None:
        super().__init__()
        self.curriculum, self.diagonal = curriculum, diagonal
        self.total_steps, self.max_seconds = total_steps, max_seconds
        self.reach: float | None = None

    def _on_training_start(self) -> None:
        self.start = time.perf_counter()
        self._on_rollout_start()

    def _on_rollout_start(self) -> None:
        progress = self.num_timesteps / self.total_steps
        if self.max_seconds is not None:
            progress = max(progress, (time.perf_counter() - self.start) / self.max_seconds)
        self.reach = self.curriculum.reach(progress, self.diagonal)
        self.training_env.set_attr("start_reach", self.reach)

    def _on_step(self) -> bool:
        return True


# ---- the training curve -------------------------------------------------------------------

class TrainingCurve(BaseCallback):
    """One row per PPO rollout: agent steps so far, wall seconds, and over the attacker
    episodes (slots) that ended in the rollout, how they ended and their mean return.
    Prints the latest row every ``print_seconds``; stops training after ``max_seconds`` of
    wall time. With ``easy_starts`` (the curriculum's callback) each row also has the
    rollout's ``start_reach`` (map units; empty: anywhere)."""

    def __init__(self, max_seconds: float | None = None, print_seconds: float = 30.0,
                 easy_starts: EasyStarts | None = None) -> None:
        super().__init__()
        self.max_seconds = max_seconds
        self.easy_starts = easy_starts
        self.print_seconds = print_seconds
        self._printed = 0.0
        self.rows: list[dict[str, float | None]] = []
        self.start: float | None = None
        self.cpu_seconds = 0.0      # this process's CPU seconds in training, set at its end
        self._cpu_start = 0.0

    def _on_training_start(self) -> None:
        self.start = time.perf_counter()
        self._cpu_start = time.process_time()
        self.status = np.zeros(self.training_env.num_envs, dtype=np.int64)
        self._ended: list[int] = []
        self._returns: list[float] = []

    def _on_training_end(self) -> None:
        self.cpu_seconds = time.process_time() - self._cpu_start

    def _on_step(self) -> bool:
        steps = zip(self.locals["infos"], self.locals["dones"], self.locals["rewards"],
                    strict=True)
        for slot, (info, done, reward) in enumerate(steps):
            if done:
                self._ended.append(self._final_status(slot, info, reward))
                self._returns.append(float(info["episode"]["r"]))
                self.status[slot] = AttackerStatus.ACTIVE.code
            elif "status" in info:          # an attacker's last step carries its status
                self.status[slot] = info["status"]
        return self.max_seconds is None or self.seconds < self.max_seconds

    def _final_status(self, slot: int, info: dict[str, Any], reward: float) -> int:
        """How the attacker of ``slot`` ended, on the step that ends its game. SuperSuit's
        vector env overwrites that step's infos with the next episode's reset infos, but
        keeps ``TimeLimit.truncated`` for the attackers still in play: for them a time-out
        is read from it, an arrival or a capture from the sign of the step's reward (+1 or
        -1; the progress term of one step is far smaller)."""
        if self.status[slot] != AttackerStatus.ACTIVE.code or "TimeLimit.truncated" not in info:
            return int(self.status[slot])
        if info["TimeLimit.truncated"]:
            return AttackerStatus.ACTIVE.code
        return (AttackerStatus.ARRIVED if reward > 0 else AttackerStatus.CAPTURED).code

    @property
    def seconds(self) -> float:
        """Wall seconds since training started (0 before)."""
        return 0.0 if self.start is None else time.perf_counter() - self.start

    def _on_rollout_end(self) -> None:
        ended = np.asarray(self._ended)
        rates = {f"{status.value if status is not AttackerStatus.ACTIVE else 'timeout'}_rate":
                 float(np.mean(ended == status.code)) if len(ended) else float("nan")
                 for status in (AttackerStatus.ARRIVED, AttackerStatus.CAPTURED,
                                AttackerStatus.ACTIVE)}
        self.rows.append({"timesteps": self.num_timesteps, "seconds": round(self.seconds, 2),
                          "attacker_episodes": len(ended), **rates,
                          "mean_return": float(np.mean(self._returns)) if self._returns
                          else float("nan")})
        if self.easy_starts is not None:
            self.rows[-1]["start_reach"] = self.easy_starts.reach
        self._ended, self._returns = [], []
        if self.seconds - self._printed >= self.print_seconds:
            self._printed = self.seconds
            print(row_text(self.rows[-1]), flush=True)


def row_text(row: dict[str, float | None]) -> str:
    """A curve row as the line the recipe prints (a ``None`` reach reads "anywhere")."""
    return "PPO: " + ", ".join(f"{key} {'anywhere' if value is None else f'{value:.4g}'}"
                               for key, value in row.items())



class FullSpeed(VecEnvWrapper):
    """``--full-speed``: every action is scaled to length 1 before the games see it."""

    def step_async(self, actions: np.ndarray) -> None:
        self.venv.step_async(unit_vectors(np.asarray(actions, dtype=np.float64)))

    def step_wait(self) -> Any:
        return self.venv.step_wait()

    def reset(self) -> Any:
        return self.venv.reset()



def frozen(model: PPO) -> Predict:
    """A snapshot of ``model``'s policy now: its deterministic action of observations."""
    policy = copy.deepcopy(model.policy)
    policy.set_training_mode(False)
    return lambda batch: policy.predict(batch, deterministic=True)[0]


class PastSelfSnapshots(BaseCallback):
    """``--past-selves``: a snapshot of the learner into the pool after every rollout."""

    def __init__(self, past_selves: PastSelves) -> None:
        super().__init__()
        self.past_selves = past_selves

    def _on_rollout_end(self) -> None:
        self.past_selves.add(frozen(self.model))

    def _on_step(self) -> bool:
        return True


def plot_curve(rows: list[dict[str, float]], path: Path, title: str) -> None:
    """Arrival rate and mean return per rollout (dots) and over the last 10 (line)."""
    steps = np.array([row["timesteps"] for row in rows], dtype=np.float64)
    figure = Figure(figsize=(7, 5), layout="constrained")
    arrival_axes, return_axes = figure.subplots(2, 1, sharex=True)
    for axes, key, label in ((arrival_axes, "arrived_rate", "arrival rate"),
                             (return_axes, "mean_return", "mean return")):
        values = np.array([row[key] for row in rows], dtype=np.float64)
        window = min(10, len(values))
        smooth = np.convolve(np.nan_to_num(values), np.ones(window) / window, mode="valid")
        axes.plot(steps, values, ".", alpha=0.3, label="per rollout")
        axes.plot(steps[window - 1:], smooth, label=f"mean of {window}")
        axes.set_ylabel(label)
        axes.grid(alpha=0.3)
    arrival_axes.legend()
    arrival_axes.set_title(title)
    return_axes.set_xlabel("agent steps (one per attacker per env step)")
    with atomic_write(path, "wb") as handle:
        figure.savefig(handle, format="png", dpi=100)

