"""reachavoid/ReachAvoid-v2 (``reach_avoid_v2``, ``decisions.DecisionEnv``): PettingZoo's
checks in both action modes, decisions as held physics steps, the shaped reward's
telescoping sum, discrete actions, agents that stay, infos with one set of keys."""

from __future__ import annotations

from functools import partial
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest
from checks import checked
from pettingzoo.test import (
    api_test,
    max_cycles_test,
    parallel_api_test,
    parallel_seed_test,
    seed_test,
)

from policies import IdleDefender, ShortestPathAttacker
from reachavoid_env import builtin_scenario, reach_avoid_v1, reach_avoid_v2
from reachavoid_env.actions import HEADINGS, TABLE
from reachavoid_env.rewards import GeodesicPotential

CROWDED = builtin_scenario("paper_2v1").with_players(3, 2)
MODES = [True, False]
KEYS = {"captured", "arrived", "status", "captured_by", "active"}


@pytest.mark.parametrize("continuous", MODES)
@pytest.mark.parametrize("remove", [True, False])
def test_parallel_api(continuous, remove):
    env = reach_avoid_v2.parallel_env(scenario=CROWDED, continuous_actions=continuous,
                                      remove_agents=remove)
    checked(parallel_api_test, env, num_cycles=300)


@pytest.mark.parametrize("continuous", MODES)
def test_aec_api_seed_and_max_cycles(continuous):
    make = partial(reach_avoid_v2.env, continuous_actions=continuous, max_cycles=60)
    checked(api_test, make(), num_cycles=60)
    seed_test(make, num_cycles=60)
    parallel_seed_test(partial(reach_avoid_v2.parallel_env, continuous_actions=continuous))
    max_cycles_test(SimpleNamespace(
        env=partial(reach_avoid_v2.env, continuous_actions=continuous),
        parallel_env=partial(reach_avoid_v2.parallel_env, continuous_actions=continuous)))


def test_max_cycles_of_the_module():
    max_cycles_test(reach_avoid_v2)


def test_a_decision_is_held_physics_steps_of_v1():
    """One decision of v2 plays exactly ``decision_steps`` steps of v1 with the actions
    held (same seed, same random starts)."""
    v2 = reach_avoid_v2.parallel_env(decision_steps=7)
    v1 = reach_avoid_v1.parallel_env(starts="random", max_cycles=v2.max_cycles * 7)
    v2.reset(seed=3)
    v1.reset(seed=3)
    rng = np.random.default_rng(0)
    for _ in range(5):
        actions = {a: rng.uniform(-1, 1, 2).astype(np.float32) for a in v2.agents}
        v2.step(actions)
        for _ in range(7):
            if v1.agents:
                v1.step({a: actions[a] for a in v1.agents})
        ours, theirs = v2.game_state(), v1.game_state()
        np.testing.assert_array_equal(ours.attacker_positions, theirs.attacker_positions)
        np.testing.assert_array_equal(ours.defender_positions, theirs.defender_positions)
        assert ours.step == theirs.step


def _episode(reward: str, seed: int, remove: bool = True) -> tuple[list, Any, Any]:
    env = reach_avoid_v2.parallel_env(scenario=CROWDED, reward=reward, max_cycles=80,
                                      remove_agents=remove)
    env.reset(seed=seed)
    start = env.game_state()
    rng = np.random.default_rng(seed)
    history = []
    while env.agents:
        actions = {a: rng.uniform(-1, 1, 2).astype(np.float32) for a in env.possible_agents}
        _, rewards, *_ = env.step({a: actions[a] for a in env.agents})
        history.append(rewards)
    return history, start, env


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_shaping_telescopes_over_an_episode(seed):
    """sum_t gamma^t F_t = gamma^n Phi(s_n) - Phi(s_0) for every attacker (Phi = 0 once it
    left), and every defender gets minus the attackers' summed shaping."""
    sparse, start, _ = _episode("sparse", seed)
    shaped, _, env = _episode("shaped", seed)
    assert len(sparse) == len(shaped)
    sc, end = env.scenario, env.game_state()
    phi = GeodesicPotential(sc.map, sc.player_radius, sc.attacker_speed)
    phi_start = phi(start.attacker_positions, start.active_attackers)
    phi_end = phi(end.attacker_positions, end.active_attackers)
    n, gamma = len(shaped), env.gamma
    for i, name in enumerate(env.possible_agents[:CROWDED.num_attackers]):
        total = sum(gamma ** t * (shaped[t].get(name, 0.0) - sparse[t].get(name, 0.0))
                    for t in range(n))
        assert total == pytest.approx(gamma ** n * phi_end[i] - phi_start[i], abs=1e-9)
    for t in range(n):
        shaping = sum(shaped[t].get(a, 0.0) - sparse[t].get(a, 0.0)
                      for a in env.possible_agents[:CROWDED.num_attackers])
        for name in env.possible_agents[CROWDED.num_attackers:]:
            if name in shaped[t]:
                assert shaped[t][name] - sparse[t][name] == pytest.approx(-shaping, abs=1e-12)


def test_discrete_actions_are_headings_at_full_speed():
    env = reach_avoid_v2.parallel_env(continuous_actions=False, decision_steps=1)
    assert env.action_space("attacker_0").n == HEADINGS + 1
    env.reset(seed=0)
    before = env.game_state().attacker_positions.copy()
    env.step({a: (1 if a == "attacker_0" else 0) for a in env.agents})
    moved = env.game_state().attacker_positions - before
    speed, dt = env.scenario.attacker_speed, env.scenario.dt
    np.testing.assert_allclose(moved[0], TABLE[1] * speed * dt, atol=1e-9)
    np.testing.assert_array_equal(moved[1], 0.0)
    env.reset(seed=0)
    with pytest.raises(ValueError, match="action for attacker_1: expected an integer in 0..8"):
        env.step({a: (9 if a == "attacker_1" else 0) for a in env.agents})


def test_agents_stay_until_the_episode_ends():
    env = reach_avoid_v2.parallel_env(scenario=CROWDED, remove_agents=False, max_cycles=80)
    for seed in range(6):
        _, infos = env.reset(seed=seed)
        assert all(set(info) == KEYS for info in infos.values())
        rng = np.random.default_rng(seed)
        left: set[str] = set()
        while env.agents:
            assert env.agents == env.possible_agents
            obs, rewards, terms, truncs, infos = env.step(
                {a: rng.uniform(-1, 1, 2).astype(np.float32) for a in env.agents})
            assert set(obs) == set(env.possible_agents) and all(
                set(info) == KEYS for info in infos.values())
            for name in left:
                assert rewards[name] == 0.0 and not obs[name].any()
                assert infos[name]["active"] is False
            left |= {name for name, info in infos.items() if not info["active"]}
        assert all(terms[a] or truncs[a] for a in env.possible_agents)


def test_supersuit_markov_vector_env_without_black_death():
    supersuit = pytest.importorskip("supersuit")
    env = reach_avoid_v2.parallel_env(scenario=CROWDED, remove_agents=False, max_cycles=40)
    vec = supersuit.pettingzoo_env_to_vec_env_v1(env)
    vec.reset(seed=0)
    rng = np.random.default_rng(0)
    dones = 0
    for _ in range(200):
        *_, terms, truncs, _ = vec.step(rng.uniform(-1, 1, (vec.num_envs, 2)))
        dones += int((terms | truncs).all())
    assert dones >= 5


def test_shortest_path_arrives_well_within_max_cycles():
    env = reach_avoid_v2.parallel_env()
    attackers, defenders = ShortestPathAttacker(), IdleDefender()
    for seed in range(5):
        env.reset(seed=seed)
        attackers.reset(env.scenario)
        decisions = 0
        while env.agents:
            state = env.game_state()
            actions = {**attackers.act(state), **defenders.act(state)}
            _, _, _, _, infos = env.step({a: actions[a] for a in env.agents})
            decisions += 1
        assert infos["attacker_0"]["arrived"] >= 1 and decisions < env.max_cycles // 4


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"reward": "dense"}, "reward: 'dense' is not one of"),
    ({"decision_steps": 0}, "decision_steps: must be an integer"),
    ({"gamma": 1.5}, "gamma: must be in"),
    ({"continuous_actions": "no"}, "continuous_actions: expected True or False"),
    ({"max_cycles": 0}, "max_cycles: must be an integer"),
])
def test_bad_arguments_name_their_field(kwargs, message):
    with pytest.raises((ValueError, TypeError), match=message):
        reach_avoid_v2.parallel_env(**kwargs)


def test_discrete_actions_in_every_view():
    """The vector env, its training view and both attacker views take ``Discrete(9)``
    actions with ``continuous_actions=False`` and play them as ``actions.TABLE``'s rows."""
    from reachavoid.training.views import (
        make_attacker_env,
        make_attackers_parallel_env,
        make_attackers_vector_env,
    )
    from reachavoid_env import vector_env

    rng = np.random.default_rng(0)
    chosen = {name: rng.integers(0, HEADINGS + 1, 4) for name in CROWDED.attacker_names
              + CROWDED.defender_names}
    runs = []
    for continuous in MODES:
        vec = vector_env(CROWDED, num_envs=4, continuous_actions=continuous)
        vec.reset(seed=0)
        assert vec.single_action_space == reach_avoid_v2.parallel_env(
            continuous_actions=continuous).action_space("attacker_0")
        vec.step({name: (TABLE[a] if continuous else a) for name, a in chosen.items()})
        runs.append(vec.batch_state().attacker_positions)
    np.testing.assert_array_equal(*runs)
    view = make_attackers_vector_env(CROWDED, defenders="idle", num_envs=3,
                                     continuous_actions=False)
    view.reset(seed=0)
    table, *_ = view.step(np.full((3, CROWDED.num_attackers), 3))
    assert table.shape[:2] == (3, CROWDED.num_attackers)
    with pytest.raises(ValueError, match="actions: expected integers in 0..8"):
        view.step(np.full((3, CROWDED.num_attackers, 2), 0.5))
    single = make_attacker_env(CROWDED, defenders="idle", continuous_actions=False)
    single.reset(seed=0)
    assert single.action_space.n == HEADINGS + 1
    single.step(single.action_space.sample())
    parallel = make_attackers_parallel_env(CROWDED, defenders="idle",
                                           continuous_actions=False)
    parallel.reset(seed=0)
    parallel.step({a: parallel.action_space(a).sample() for a in parallel.agents})
    assert parallel.action_space("attacker_0") is parallel.action_space("attacker_0")


def test_discrete_actions_through_the_vector_integrations():
    """Stable-Baselines3's and Gymnasium's vector forms and TorchRL's batched env of a
    view with discrete actions take integers."""
    from reachavoid.training.views import make_attacker_vector_env, make_attackers_vector_env
    from reachavoid_env.integrations.vector import GymVectorEnv, sb3_vec_env

    view = make_attackers_vector_env(CROWDED, defenders="idle", num_envs=2,
                                     continuous_actions=False)
    assert view.action_shape == ()
    sb3 = sb3_vec_env(view)
    sb3.reset()
    sb3.step(np.full(sb3.num_envs, 2))
    gym = GymVectorEnv(make_attacker_vector_env(CROWDED, defenders="idle", num_envs=2,
                                                continuous_actions=False))
    gym.reset(seed=0)
    gym.step(gym.action_space.sample())
    torch = pytest.importorskip("torch")
    pytest.importorskip("torchrl")
    from torchrl.envs.utils import check_env_specs

    from reachavoid_env.integrations.torchrl import VectorGroupEnv

    env = VectorGroupEnv(make_attackers_vector_env(CROWDED, defenders="idle", num_envs=2,
                                                   continuous_actions=False, autoreset=False))
    check_env_specs(env)
    assert env.rollout(5)["attacker", "action"].dtype == torch.int64
