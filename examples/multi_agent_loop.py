"""A plain PettingZoo loop over the attackers of a game, with learned-policy hooks.

The attacker-only env (``reachavoid/Attackers-v1``) moves the defenders itself; each
attacker is driven by a hook, a callable ``observation -> action`` (a float32 ``(2,)``
velocity in ``[-1, 1]``). Plug a trained network in here, one per attacker or shared:

    python examples/multi_agent_loop.py --scenario paper_6v2 --defenders hj
    python examples/multi_agent_loop.py --scenario paper_1v1 --policy runs/attacker/model.zip \
        --video runs/attacker/loop.mp4

``--policy toward-target`` (default) steers each attacker straight at the target from its
observation alone; ``random`` draws uniform actions; a ``.zip`` path loads a
Stable-Baselines3 PPO model (trained by ``train_attacker_sb3.py`` on a scenario with the
same numbers of players), shares it among all attackers and, unless ``--action-repeat`` is
given, holds its actions as long as in training. Starts are random (``--starts random``,
episode ``k`` seeded with ``--seed`` + k), as in training; ``--video`` records the first
episode in real time. (``reachavoid play --attackers sb3:MODEL.zip`` plays a model
against any defenders without this loop.)
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pettingzoo

import policies  # noqa: F401  (registers reachavoid/Attackers-v1)
from policies.attackers import target_centres
from policies.learned import load_sb3
from reachavoid.training.flags import DefenderFields, config_parser, defender_options
from reachavoid_env import AttackerStatus, Scenario, load_scenario
from reachavoid_env.environment import STARTS
from reachavoid_env.training_ids import PETTINGZOO_ID
from reachavoid_env.video import RecordEpisode

Hook = Callable[[np.ndarray], np.ndarray]


@dataclass
class Config(DefenderFields):
    policy: str = field(default="toward-target", metadata={
        "help": "toward-target, random, or a Stable-Baselines3 PPO .zip"})
    action_repeat: int | None = field(default=None, metadata={
        "type": int, "help": "env steps per hook call (None: the model's, else 1)"})
    starts: str = field(default="random", metadata={
        "choices": STARTS,
        "help": "the scenario's start positions or random ones every episode"})
    episodes: int = field(default=3, metadata={"help": "episodes to play"})
    seed: int = field(default=0, metadata={"help": "seed of the first episode"})
    video: str | None = field(default=None, metadata={
        "metavar": "OUT.mp4|OUT.gif", "help": "record the first episode (real time)"})


def toward_target(scenario: Scenario) -> Hook:
    """Head for the nearest target centre, reading the own position from the observation
    (normalised to the domain: -1 at xmin/ymin, +1 at xmax/ymax)."""
    xmin, xmax, ymin, ymax = scenario.map.domain
    centre = np.array([(xmin + xmax) / 2, (ymin + ymax) / 2])
    half = np.array([(xmax - xmin) / 2, (ymax - ymin) / 2])
    targets = (target_centres(scenario.map) - centre) / half

    def act(obs: np.ndarray) -> np.ndarray:
        gaps = (targets - obs[:2]) * half  # map units, so headings are not distorted
        gap = gaps[np.argmin(np.linalg.norm(gaps, axis=1))]
        return (gap / max(float(np.linalg.norm(gap)), 1e-9)).astype(np.float32)

    return act


def uniform_random(seed: int) -> Hook:
    rng = np.random.default_rng(seed)
    return lambda obs: rng.uniform(-1.0, 1.0, 2).astype(np.float32)


def sb3_model(path: str) -> tuple[Hook, int]:
    """The saved model's deterministic action, and the action repeat it was trained with."""
    policy = load_sb3(path)
    return lambda obs: policy.predict(obs[None])[0], policy.action_repeat


def play(env: pettingzoo.ParallelEnv, hooks: Mapping[str, Hook], seed: int,
         ) -> dict[str, Any]:
    """One episode; ``hooks[agent]`` chooses each attacker's action from its observation."""
    observations, _ = env.reset(seed=seed)
    returns = dict.fromkeys(env.agents, 0.0)
    outcome: dict[str, str] = {}
    while env.agents:
        actions = {agent: hooks[agent](observations[agent]) for agent in env.agents}
        observations, rewards, terminations, truncations, infos = env.step(actions)
        for agent, reward in rewards.items():
            returns[agent] += reward
            if terminations[agent] or truncations[agent]:
                status = AttackerStatus.from_code(infos[agent]["status"])
                outcome[agent] = "timeout" if truncations[agent] else status.value
    return {"steps": env.unwrapped.game_state().step, "returns": returns,
            "outcome": outcome}


def main(config: Config) -> None:
    repeat = config.action_repeat
    if config.policy == "toward-target":
        shared = toward_target(load_scenario(config.scenario))
    elif config.policy == "random":
        shared = uniform_random(config.seed)
    else:   # a .zip (checked with the flags)
        shared, trained_repeat = sb3_model(config.policy)
        repeat = repeat or trained_repeat
    env = pettingzoo.make("parallel", PETTINGZOO_ID, scenario=config.scenario,
                          defenders=config.defenders, defender_options=defender_options(config),
                          action_repeat=repeat or 1, starts=config.starts,
                          render_mode=None if config.video is None else "rgb_array")
    hooks = dict.fromkeys(env.possible_agents, shared)
    for episode in range(config.episodes):
        if episode == 0 and config.video is not None:
            with RecordEpisode(env, config.video) as recorded:
                result = play(recorded, hooks, seed=config.seed)
            print(f"video: {config.video} ({recorded.frames} frames)")
        else:
            result = play(env, hooks, seed=config.seed + episode)
        outcomes = list(result["outcome"].values())
        print(f"episode {episode}: {result['steps']} steps, arrived "
              f"{outcomes.count('arrived')}, captured {outcomes.count('captured')}, "
              f"timed out {outcomes.count('timeout')}")
    env.close()


if __name__ == "__main__":
    parser = config_parser(Config, __doc__.split("\n\n")[0])
    config = Config(**vars(parser.parse_args()))
    if config.policy not in ("toward-target", "random") and not config.policy.endswith(".zip"):
        parser.error(f"--policy: expected toward-target, random or a .zip file, "
                     f"got {config.policy!r}")
    main(config)
