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

import argparse
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
import pettingzoo

import policies  # noqa: F401  (registers reachavoid/Attackers-v1)
from policies.attackers import target_centres
from policies.learned import load_sb3
from reachavoid.training.flags import add_defender_arguments, defender_options
from reachavoid_env import AttackerStatus, Scenario, load_scenario
from reachavoid_env.environment import STARTS
from reachavoid_env.training_ids import PETTINGZOO_ID
from reachavoid_env.video import RecordEpisode

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


def main(argv: Sequence[str] | None = None) -> list[dict[str, Any]]:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    add_defender_arguments(parser, scenario="paper_6v2")
    parser.add_argument("--policy", default="toward-target",
                        help="toward-target, random, or a Stable-Baselines3 PPO .zip")
    parser.add_argument("--action-repeat", type=int, default=None,
                        help="env steps per hook call (None: the model's, else 1)")
    parser.add_argument("--starts", choices=STARTS, default="random",
                        help="the scenario's start positions or random ones every episode")
    parser.add_argument("--episodes", type=int, default=3, help="episodes to play")
    parser.add_argument("--seed", type=int, default=0, help="seed of the first episode")
    parser.add_argument("--video", default=None, metavar="OUT.mp4|OUT.gif",
                        help="record the first episode (real time)")
    args = parser.parse_args(argv)

    repeat = args.action_repeat
    if args.policy == "toward-target":
        shared = toward_target(load_scenario(args.scenario))
    elif args.policy == "random":
        shared = uniform_random(args.seed)
    elif args.policy.endswith(".zip"):
        shared, trained_repeat = sb3_model(args.policy)
        repeat = repeat or trained_repeat
    else:
        parser.error(f"--policy: expected toward-target, random or a .zip file, "
                     f"got {args.policy!r}")
    env = pettingzoo.make("parallel", PETTINGZOO_ID, scenario=args.scenario,
                          defenders=args.defenders, defender_options=defender_options(args),
                          action_repeat=repeat or 1, starts=args.starts,
                          render_mode=None if args.video is None else "rgb_array")
    hooks = dict.fromkeys(env.possible_agents, shared)
    results = []
    for episode in range(args.episodes):
        if episode == 0 and args.video is not None:
            with RecordEpisode(env, args.video) as recorded:
                result = play(recorded, hooks, seed=args.seed)
            print(f"video: {args.video} ({recorded.frames} frames)")
        else:
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
