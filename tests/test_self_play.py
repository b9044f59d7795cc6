"""Self-play with past policies (``reachavoid.training.self_play.PastSelves``): the
snapshots see exactly the observations the env gives the attackers, each copy plays the
snapshot it drew for its whole episode, decisions are held for ``action_repeat`` steps, and
the recipe's ``--past-selves`` trains one attacker per copy beside them."""

from __future__ import annotations

import numpy as np
import pytest

from reachavoid.training.self_play import PastSelves
from reachavoid.training.views import make_attacker_vector_env
from reachavoid_env import ObservationConfig, ReachAvoidVectorEnv


class Recorder:
    """A snapshot that records what it is shown and answers ``value`` everywhere."""

    def __init__(self, value: float = 0.5) -> None:
        self.value, self.batches = value, []

    def __call__(self, batch: np.ndarray) -> np.ndarray:
        self.batches.append(batch.copy())
        return np.full((len(batch), 2), self.value)


@pytest.mark.parametrize("observation", [ObservationConfig(),
                                         ObservationConfig(teammates=2, opponents=1)])
def test_snapshots_see_the_observations_the_env_gives(observation):
    vec = ReachAvoidVectorEnv("paper_6v2", num_envs=3, autoreset=False,
                              observation=observation)
    recorder = Recorder()
    past = PastSelves(observation)
    past.add(recorder)
    observations, _ = vec.reset(seed=4)
    past.reset_copies(np.arange(3), vec.episode_scenarios)
    rng = np.random.default_rng(1)
    attackers = vec.base_scenario.attacker_names
    size = vec.single_observation_space.shape[0]
    for _ in range(40):
        past.act_batch(vec.batch_state())
        expected = np.stack([observations[name] for name in attackers], axis=1)
        np.testing.assert_array_equal(recorder.batches[-1], expected.reshape(-1, size))
        observations, *_ = vec.step({name: rng.uniform(-1, 1, (3, 2))
                                     for name in vec.possible_agents})


def test_each_copy_keeps_its_draw_and_holds_its_decisions():
    vec = ReachAvoidVectorEnv("paper_6v2", num_envs=16, autoreset=False)
    past = PastSelves(pool=2, action_repeat=3, seed=0)
    snapshots = [Recorder(value) for value in (0.1, 0.2, 0.3)]
    for snapshot in snapshots:
        past.add(snapshot)                 # the pool keeps the newest two
    vec.reset(seed=0)
    past.reset_copies(np.arange(16), vec.episode_scenarios)
    first = past.act_batch(vec.batch_state())
    drawn = first[:, 0, 0]
    assert set(np.round(drawn.astype(float), 6).tolist()) == {0.2, 0.3}
    assert (first == drawn[:, None, None]).all()
    assert snapshots[0].batches == []
    calls = sum(len(s.batches) for s in snapshots)
    for step in range(1, 7):
        vec.step({name: np.zeros((16, 2)) for name in vec.possible_agents})
        again = past.act_batch(vec.batch_state())
        np.testing.assert_array_equal(again, first)          # the same snapshot per copy
        decided = sum(len(s.batches) for s in snapshots) - calls
        assert decided == (2 if step % 3 == 0 else 0)       # one call per snapshot drawn
        calls += decided


def test_full_speed_scales_and_a_pool_is_needed():
    vec = ReachAvoidVectorEnv("paper_2v1", num_envs=2, autoreset=False)
    vec.reset(seed=0)
    past = PastSelves(full_speed=True)
    with pytest.raises(RuntimeError, match="add a snapshot"):
        past.reset_copies(np.arange(2), vec.episode_scenarios)
    past.add(lambda batch: np.tile([0.3, 0.4], (len(batch), 1)))
    past.reset_copies(np.arange(2), vec.episode_scenarios)
    np.testing.assert_allclose(past.act_batch(vec.batch_state()), [[[0.6, 0.8]] * 2] * 2,
                               rtol=1e-6)
    with pytest.raises(ValueError, match="pool"):
        PastSelves(pool=0)


def test_the_learner_plays_beside_its_past_selves():
    """In the training view the learner's row is its own; the teammates' are the pool's."""
    past = PastSelves()
    past.add(lambda batch: np.tile([1.0, 0.0], (len(batch), 1)))
    view = make_attacker_vector_env("paper_2v1", defenders="greedy", teammates=past,
                                    num_envs=4)
    before, _ = view.reset(seed=3)
    start = view.vec.batch_state().attacker_positions
    view.step(np.zeros((4, 1, 2)))
    moved = view.vec.batch_state().attacker_positions - start
    assert np.abs(moved[:, 0]).max() == 0.0                  # the learner stood still
    assert (moved[:, 1, 0] > 0).all()                        # its past self ran +x
    assert before.shape == (4, 1, view.single_observation_space.shape[0])
