"""Easy starts for a curriculum: ``Scenario.starts``' ``attacker_reach``, the vector env's
``start_reach`` (through the training view and Stable-Baselines3's ``set_attr``) and the
schedule ``reachavoid.training.curriculum.StartCurriculum``."""

from __future__ import annotations

import numpy as np
import pytest

from reachavoid.training.curriculum import StartCurriculum
from reachavoid.training.views import make_attackers_vector_env
from reachavoid_env import load_scenario
from reachavoid_env.checks import FieldError
from reachavoid_env.scenario import ScenarioError


def test_attackers_start_within_the_reach_and_unchanged_without_it():
    scenario = load_scenario("paper_2v1").with_players(2, 1)
    free = [scenario.starts(np.random.default_rng(seed)) for seed in range(50)]
    distances = np.concatenate([scenario.map.target_signed_distance(a) for a, _ in free])
    assert distances.max() > 1.0            # anywhere: most starts lie far from the target
    for seed in range(50):
        attackers, defenders = scenario.starts(np.random.default_rng(seed), attacker_reach=0.3)
        near = scenario.map.target_signed_distance(attackers)
        assert np.all((near <= 0.3) & (near >= scenario.start_clearance))
        scenario.validate_starts(attackers, defenders)
        again = scenario.starts(np.random.default_rng(seed), attacker_reach=None)
        assert all(np.array_equal(x, y) for x, y in zip(again, free[seed], strict=True))
    with pytest.raises(ScenarioError, match="within 0.01 of the target"):
        scenario.starts(np.random.default_rng(0), attacker_reach=0.01)


def test_the_env_resets_within_the_attacker_reach_option():
    """``reset(options={"attacker_reach": D})`` on the single env: the same rule as the
    vector env's ``start_reach``; without it the starts are those of ``reset(seed)``."""
    from reachavoid_env import reach_avoid_v1

    env = reach_avoid_v1.parallel_env(scenario="paper_2v1", starts="random")
    for seed in range(10):
        env.reset(seed=seed, options={"attacker_reach": 0.3})
        near = env.scenario.map.target_signed_distance(np.asarray(env.scenario.attackers))
        assert np.all(near <= 0.3)
        env.reset(seed=seed, options={"attacker_reach": None})
        plain = env.scenario.attackers
        env.reset(seed=seed)
        assert env.scenario.attackers == plain
    with pytest.raises(ValueError, match=r"options\['attacker_reach'\]: must be > 0, got -1"):
        env.reset(seed=0, options={"attacker_reach": -1})


def test_the_vector_env_draws_new_episodes_within_start_reach():
    view = make_attackers_vector_env("paper_2v1", defenders="greedy", num_envs=8,
                                     starts="random", action_repeat=5)
    view.reset(seed=3)
    target = view.vec.base_scenario.map
    first = [s.attackers for s in view.vec.episode_scenarios]
    view.start_reach = 0.25
    assert view.vec.start_reach == 0.25
    view.reset_copies(np.arange(8))
    near = np.concatenate([target.target_signed_distance(np.asarray(s.attackers))
                           for s in view.vec.episode_scenarios])
    assert near.max() <= 0.25
    view.start_reach = None
    view.reset(seed=3)
    assert [s.attackers for s in view.vec.episode_scenarios] == first
    for bad in (0.0, -1.0, float("nan"), "far"):
        with pytest.raises(FieldError, match="^start_reach: "):
            view.start_reach = bad


def test_the_sb3_adapter_sets_the_reach():
    pytest.importorskip("stable_baselines3")
    from stable_baselines3.common.vec_env import VecMonitor

    from reachavoid_env.integrations.vector import sb3_vec_env

    view = make_attackers_vector_env("paper_1v1", defenders="greedy", num_envs=2)
    envs = VecMonitor(sb3_vec_env(view))
    envs.set_attr("start_reach", 0.4)
    assert view.vec.start_reach == 0.4 and envs.get_attr("start_reach") == [0.4, 0.4]


def test_the_curriculum_grows_from_first_to_anywhere():
    curriculum = StartCurriculum(first=0.4, fraction=0.5)
    diagonal = 2.0 * np.sqrt(2.0)
    assert curriculum.reach(0.0, diagonal) == pytest.approx(0.4)
    assert curriculum.reach(0.25, diagonal) == pytest.approx(0.4 + (diagonal - 0.4) / 2)
    assert curriculum.reach(0.499, diagonal) < diagonal
    assert curriculum.reach(0.5, diagonal) is None and curriculum.reach(1.0, diagonal) is None
    assert StartCurriculum(5.0, 1.0).reach(0.5, diagonal) == 5.0
    for first, fraction, field in ((0.0, 0.5, "easy_starts"), (0.3, 0.0, "easy_fraction"),
                                   (0.3, 1.5, "easy_fraction")):
        with pytest.raises(FieldError) as refused:
            StartCurriculum(first, fraction)
        assert refused.value.field == field
