"""``reachavoid_env.Single``: a batched policy played as one ``Policy`` (copy 0)."""

from __future__ import annotations

import numpy as np
import pytest

import reachavoid_env
from policies.attackers import ShortestPathAttacker
from policies.intercept import InterceptDefender
from reachavoid_env import BatchPolicy, Overlay, PerCopy, Policy, Single


class Drawn(PerCopy):
    """A ``PerCopy`` that draws each copy's overlay and carries an attribute."""

    label = "drawn"

    def overlay(self, copy: int) -> Overlay:
        return self.policies[copy].overlay()


def test_single_plays_copy_zero_of_its_batched_policy():
    scenario = reachavoid_env.builtin_scenario("paper_6v2")
    env = reachavoid_env.parallel_env(scenario=scenario, starts="random")
    env.reset(seed=1)
    reference, single = InterceptDefender(), Single(Drawn(lambda _: InterceptDefender()))
    attackers = ShortestPathAttacker()
    for policy in (reference, single, attackers):
        policy.reset(env.scenario)
    assert isinstance(single, Policy) and not isinstance(single, BatchPolicy)
    assert single.label == "drawn" and single.side == "defenders"
    while env.agents:
        state = env.game_state()
        expected, got = reference.act(state), single.act(state)
        assert list(got) == list(expected) == state.defender_names
        for name, action in expected.items():
            assert got[name].dtype == np.float32
            assert np.array_equal(got[name].view(np.uint32), action.view(np.uint32))
        assert single.overlay() == reference.overlay()
        env.step({name: a for name, a in (expected | attackers.act(state)).items()
                  if name in env.agents})


def test_single_attackers_act_for_the_active_ones_and_draw_nothing_without_overlay():
    scenario = reachavoid_env.builtin_scenario("paper_2v1")
    env = reachavoid_env.parallel_env(scenario=scenario)
    env.reset(seed=0)
    single = Single(PerCopy(lambda _: ShortestPathAttacker(), side="attackers"),
                    side="attackers")
    single.reset(env.scenario)
    assert sorted(single.act(env.game_state())) == ["attacker_0", "attacker_1"]
    assert single.overlay() is None
    assert not hasattr(single, "act_batch") and not hasattr(single, "reset_copies")
    with pytest.raises(ValueError, match="side"):
        Single(PerCopy(lambda _: ShortestPathAttacker()), side="both")
