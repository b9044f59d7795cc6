"""A plain PettingZoo loop over the attackers of a game, with learned-policy hooks.

The attacker-only env (``reachavoid/Attackers-v0``) moves the defenders itself; each
attacker is driven by a hook, a callable ``observation -> action`` (a float32 ``(2,)``
velocity in ``[-1, 1]``). Plug a trained network in here, one per attacker or shared:

    python examples/multi_agent_loop.py --scenario paper_6v2 --defenders hj
    python examples/multi_agent_loop.py --scenario paper_1v1 --policy runs/attacker/model.zip \
        --action-repeat 10

``--policy toward-target`` (default) steers each attacker straight at the target from its
observation alone; ``random`` draws uniform actions; a ``.zip`` path loads a
Stable-Baselines3 PPO model (trained by ``train_attacker_sb3.py`` on a scenario with the
same numbers of players) and shares it among all attackers.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
import pettingzoo

import policies  # noqa: F401  (registers reachavoid/Attackers-v0)
from policies.attackers import target_centres
from policies.training import PETTINGZOO_ID, add_defender_arguments, defender_options
from reachavoid_env import AttackerStatus, Scenario

Hook = Callable[[np.ndarray], np.ndarray]


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


def sb3_model(path: str) -> Hook:
    from stable_baselines3 import PPO

    model = PPO.load(path, device="cpu")
    return lambda obs: model.predict(obs, deterministic=True)[0]


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
    return {"steps": env.game_state().step, "returns": returns, "outcome": outcome}


def main(argv: Sequence[str] | None = None) -> list[dict[str, Any]]:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    add_defender_arguments(parser, scenario="paper_6v2")
    parser.add_argument("--policy", default="toward-target",
                        help="toward-target, random, or a Stable-Baselines3 PPO .zip")
    parser.add_argument("--action-repeat", type=int, default=1,
                        help="env steps per hook call; match the training's (10 for "
                             "train_attacker_sb3.py)")
    parser.add_argument("--episodes", type=int, default=3)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)

    options = defender_options(args)
    env = pettingzoo.make("parallel", PETTINGZOO_ID, scenario=args.scenario,
                          defenders=args.defenders, defender_options=options,
                          action_repeat=args.action_repeat)
    scenario = env.game.base_scenario
    if args.policy == "toward-target":
        shared = toward_target(scenario)
    elif args.policy == "random":
        shared = uniform_random(args.seed)
    elif args.policy.endswith(".zip"):
        shared = sb3_model(args.policy)
    else:
        parser.error(f"--policy: expected toward-target, random or a .zip file, "
                     f"got {args.policy!r}")
    hooks = dict.fromkeys(env.possible_agents, shared)
    results = []
    for episode in range(args.episodes):
        result = play(env, hooks, seed=args.seed + episode)
        outcomes = list(result["outcome"].values())
        print(f"episode {episode}: {result['steps']} steps, arrived "
              f"{outcomes.count('arrived')}, captured {outcomes.count('captured')}, "
              f"timed out {outcomes.count('timeout')}")
        results.append(result)
    env.close()
    return results


if __name__ == "__main__":
    main()
