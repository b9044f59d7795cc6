"""The vector env: copy k is the single env seeded with seed + k, bit for bit, across
autoresets; spaces, masks and errors."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import reachavoid_env
from reachavoid_env import Box, Circle, builtin_scenario
from reachavoid_env.observations import GLOBAL, ObservationConfig
from reachavoid_env.vector import vector_env

CROWDED = replace(builtin_scenario("paper_2v1").with_players(4, 3), capture_radius=0.3,
                  dt=0.05, max_steps=60)


def _play_side_by_side(scenario, copies: int, steps: int, seed: int, **kwargs) -> int:
    """Step the vector env and ``copies`` single envs with the same random actions; return
    how many episodes ended (every array compared on the way)."""
    vec = vector_env(scenario, num_envs=copies, **kwargs)
    singles = [reachavoid_env.parallel_env(scenario=scenario, starts="random", **kwargs)
               for _ in range(copies)]
    observations, infos = vec.reset(seed=seed)
    single_obs = [env.reset(seed=seed + k)[0] for k, env in enumerate(singles)]
    rng = np.random.default_rng(seed)
    names = vec.possible_agents
    ended = 0
    for _ in range(steps):
        for k, env in enumerate(singles):
            for name in env.agents:
                np.testing.assert_array_equal(observations[name][k], single_obs[k][name])
            assert infos["active"][k].tolist() == [n in env.agents for n in names]
        actions = {name: rng.uniform(-1.5, 1.5, (copies, 2)) for name in names}
        observations, rewards, terminations, truncations, infos = vec.step(actions)
        for k, env in enumerate(singles):
            live = env.agents
            obs, rew, term, trunc, info = env.step({n: actions[n][k] for n in live})
            for i, name in enumerate(names):
                assert rewards[name][k] == rew.get(name, 0.0), (k, name)
                assert terminations[name][k] == term.get(name, False)
                assert truncations[name][k] == trunc.get(name, False)
                if i < vec.base_scenario.num_attackers and name in info:
                    assert infos["status"][k, i] == info[name]["status"]
                    assert infos["captured_by"][k, i] == info[name]["captured_by"]
            if live:
                first = info[live[0]]
                assert (infos["captured"][k], infos["arrived"][k]) == (first["captured"],
                                                                      first["arrived"])
            if infos["episode_over"][k]:
                assert not env.agents
                for name in obs:
                    np.testing.assert_array_equal(infos["final_observation"][name][k],
                                                  obs[name])
                obs, _ = env.reset()
                ended += 1
            else:
                assert env.agents
            single_obs[k] = obs
    return ended


@pytest.mark.parametrize("config", [ObservationConfig(), GLOBAL], ids=["v1", "v0"])
def test_copy_k_is_the_single_env_seeded_with_seed_plus_k(config):
    assert _play_side_by_side(CROWDED, copies=12, steps=150, seed=7,
                              observation=config) >= 12


def test_copy_k_is_the_single_env_on_the_paper_map_with_shaping():
    scenario = builtin_scenario("paper_6v2")
    assert _play_side_by_side(scenario, copies=6, steps=400, seed=3, shaping=0.5,
                              max_cycles=120) >= 6


def test_copies_on_a_library_of_maps_in_several_worlds(monkeypatch):
    """Copies draw their maps from a library (each reset draws again) and share worlds a
    few at a time: still the single env, copy by copy."""
    monkeypatch.setattr("reachavoid_env.vector.COPIES_PER_WORLD", 3)
    walls = replace(CROWDED.map, obstacles=(Box((-0.5, -0.5), (-0.2, 0.4)),
                                            Circle((0.2, -0.5), 0.15)))
    library = [replace(CROWDED, name="crowded_a"),
               replace(CROWDED, name="crowded_b", map=walls)]
    assert _play_side_by_side(library, copies=8, steps=150, seed=2) >= 8


def test_copies_per_map_play_each_drawn_map_in_runs():
    """With ``copies_per_map=3`` each map a group of three copies draws serves its next three
    episodes; every copy still plays its own random starts."""
    library = [replace(CROWDED, name=f"{c}_crowded", max_steps=30 + i)
               for i, c in enumerate("abcde")]
    vec = vector_env(library, num_envs=6, copies_per_map=3)
    vec.reset(seed=4)
    played = [[vec.episode_scenarios[c].max_steps for c in range(6)]]
    rng = np.random.default_rng(0)
    for _ in range(200):
        _, _, _, _, infos = vec.step({name: rng.uniform(-1, 1, (6, 2))
                                      for name in vec.possible_agents})
        for c in np.flatnonzero(infos["episode_over"]).tolist():
            played.append([c, vec.episode_scenarios[c].max_steps])
    assert played[0][:3] == [played[0][0]] * 3 and played[0][3:] == [played[0][3]] * 3
    for group in (0, 1):                       # per group: maps in runs of 3 episodes
        maps = played[0][3 * group:3 * group + 3] + [m for c, m in played[1:]
                                                     if c // 3 == group]
        runs = [maps[i:i + 3] for i in range(0, len(maps) - 2, 3)]
        assert len(runs) >= 5 and all(len(set(run)) == 1 for run in runs)
        assert len({run[0] for run in runs}) > 1
    starts = vec.episode_scenarios[0].attackers, vec.episode_scenarios[1].attackers
    assert starts[0] != starts[1]
    with pytest.raises(ValueError, match="copies_per_map"):
        vector_env(library, num_envs=6, copies_per_map=0)


def test_spaces_and_shapes():
    vec = vector_env("paper_8v4", num_envs=5)
    observations, infos = vec.reset(seed=0)
    assert vec.single_observation_space.shape == (7 + 16 + 5 * 11 + 1,)
    for name in vec.possible_agents:
        assert observations[name].shape == (5, 79)
        assert vec.single_observation_space.contains(observations[name][0])
    assert infos["active"].shape == (5, 12) and infos["active"].all()
    state = vec.batch_state()
    assert state.attacker_positions.shape == (5, 8, 2)
    assert state.game_state(3).attacker_positions.shape == (8, 2)


def test_bad_actions_name_the_agent():
    vec = vector_env("paper_2v1", num_envs=3)
    vec.reset(seed=0)
    good = {name: np.zeros((3, 2)) for name in vec.possible_agents}
    with pytest.raises(ValueError, match="action for attacker_1: expected finite real"):
        vec.step({**good, "attacker_1": np.zeros((2, 2))})
    with pytest.raises(ValueError, match="action for defender_0: expected finite real"):
        vec.step({**good, "defender_0": [["0.5", "0"]] * 3})
    with pytest.raises(ValueError, match="action for defender_0: expected finite real"):
        vec.step({**good, "defender_0": np.ones((3, 2), dtype=bool)})
    with pytest.raises(KeyError, match="no action for agent 'defender_0'"):
        vec.step({n: a for n, a in good.items() if n != "defender_0"})
    with pytest.raises(ValueError, match="num_envs"):
        vector_env("paper_2v1", num_envs=0)


def test_copies_that_would_not_fit_in_memory_are_refused_up_front(monkeypatch):
    """64 vs 64 at 4096 copies with 1 GiB available: one line naming ``num_envs`` before
    any copy is made, not numpy's ``MemoryError`` after a long reset."""
    from reachavoid_env import checks

    monkeypatch.setattr(checks, "available_memory", lambda: 1 << 30)
    big = builtin_scenario("paper_2v1").with_players(64, 64)
    with pytest.raises(checks.FieldError, match=r"^num_envs: 4096 copies of 128 players need "
                                                r"about .* GiB .* use fewer copies") as refused:
        vector_env(big, num_envs=4096)
    assert refused.value.field == "num_envs"
    vector_env("paper_2v1", num_envs=16).reset(seed=0)   # a usual size fits
