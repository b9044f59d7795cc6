"""TorchRL (rl extra): the wrapper helper on the parallel, AEC and attacker-only envs, and the
MAPPO example."""

from __future__ import annotations

import math

import pytest

torch = pytest.importorskip("torch")
pytest.importorskip("torchrl")

from checks import records, run_example  # noqa: E402
from torchrl.envs.utils import check_env_specs  # noqa: E402

import reachavoid_env  # noqa: E402
from policies import HJDefenderPolicy  # noqa: E402
from reachavoid_env import AttackerStatus  # noqa: E402
from reachavoid_env.integrations.torchrl import role_groups, torchrl_env  # noqa: E402
from reachavoid_env.wrappers import AttackerParallelEnv  # noqa: E402

# attacker_0 runs east into the target (arrives on step 10); attacker_1 runs east while
# defender_0 runs north at it (captured on step 8, earlier). Then the episode is over.
SCENARIO = reachavoid_env.builtin_scenario("paper_2v1").with_starts(
    [[0.55, 0.2], [0.3, -0.15]], [[0.3, -0.3]])
CAPTURE_STEP, ARRIVAL_STEP = 8, 10


def east_and_north(td):
    """Attackers move east, defenders north (every agent, masked or not)."""
    for group, direction in (("attacker", [1.0, 0.0]), ("defender", [0.0, 1.0])):
        if group in td.keys():
            agents = td[group, "observation"].shape[:-1]
            td[group, "action"] = torch.tensor(direction).expand(*agents, 2).clone()
    return td


def test_role_groups():
    assert role_groups(["attacker_0", "attacker_1", "defender_0"]) == {
        "attacker": ["attacker_0", "attacker_1"], "defender": ["defender_0"]}


def test_parallel_env_passes_specs_and_agents_leave_through_the_mask():
    env = torchrl_env(reachavoid_env.parallel_env(scenario=SCENARIO), seed=0)
    check_env_specs(env)
    assert env.group_map == {"attacker": ["attacker_0", "attacker_1"],
                             "defender": ["defender_0"]}
    rollout = env.rollout(ARRIVAL_STEP, east_and_north)
    after = rollout["next"]
    assert after["done"].squeeze(-1).tolist() == [False] * (ARRIVAL_STEP - 1) + [True]
    rewards = after["attacker", "reward"].squeeze(-1)
    assert rewards.sum(0).tolist() == [1.0, -1.0]
    assert rewards[CAPTURE_STEP - 1].tolist() == [0.0, -1.0]
    defender = after["defender", "reward"].squeeze(-1)[:, 0]
    assert defender[CAPTURE_STEP - 1] == 1.0 and defender[ARRIVAL_STEP - 1] == -1.0
    assert defender.sum() == 0.0
    # An attacker's mask turns False on the step it leaves and stays False.
    mask = after["attacker", "mask"]
    assert mask[:ARRIVAL_STEP - 1, 0].all() and not mask[ARRIVAL_STEP - 1, 0]
    assert mask[:CAPTURE_STEP - 1, 1].all() and not mask[CAPTURE_STEP - 1:, 1].any()
    info = after["attacker", "info"]
    assert info["status"][ARRIVAL_STEP - 1, 0] == AttackerStatus.ARRIVED.code
    assert info["status"][CAPTURE_STEP - 1, 1] == AttackerStatus.CAPTURED.code
    assert info["captured_by"][CAPTURE_STEP - 1].tolist() == [-1.0, 0.0]
    assert rollout["state"].shape == (ARRIVAL_STEP, 9)


def test_aec_env_passes_specs_and_matches_the_parallel_rewards():
    env = torchrl_env(reachavoid_env.env(scenario=SCENARIO), seed=0)
    check_env_specs(env)
    turns = 3 * ARRIVAL_STEP        # one agent acts per AEC step, 3 agents per cycle
    rollout = env.rollout(3 * (ARRIVAL_STEP + 2), east_and_north)
    after = rollout["next"]
    done = after["done"].squeeze(-1)
    assert done.sum() == 1
    last = int(done.nonzero()[0, 0]) + 1
    assert turns - 3 < last <= turns
    assert after["attacker", "reward"][:last].sum(0).squeeze(-1).tolist() == [1.0, -1.0]
    assert after["defender", "reward"][:last].sum() == 0.0
    assert after["defender", "reward"][:last].max() == 1.0
    # Exactly one agent acts (is unmasked) per turn while the episode lasts.
    acting = after["attacker", "mask"].sum(-1) + after["defender", "mask"].sum(-1)
    assert (acting[:last - 1] == 1).all()


def test_attacker_only_env_against_hj_defenders(coarse_tubes):
    env = torchrl_env(AttackerParallelEnv(HJDefenderPolicy(*coarse_tubes),
                                          scenario="paper_2v1", action_repeat=10), seed=0)
    check_env_specs(env)
    assert env.group_map == {"attacker": ["attacker_0", "attacker_1"]}
    rollout = env.rollout(40, break_when_any_done=False)
    assert rollout["next", "attacker", "observation"].shape == (40, 2, 34)
    rewards = rollout["next", "attacker", "reward"]
    status = rollout["next", "attacker", "info", "status"]
    live = rollout["attacker", "mask"]
    # Without shaping, a live attacker's reward is +1 on arrival, -1 on capture, else 0.
    expected = ((status == AttackerStatus.ARRIVED.code).float()
                - (status == AttackerStatus.CAPTURED.code).float())
    assert torch.equal(rewards.squeeze(-1)[live], expected[live])
    assert (status[live] != AttackerStatus.ACTIVE.code).any()   # someone left


def test_readable_infos_are_refused():
    with pytest.raises(ValueError, match="info_format"):
        torchrl_env(reachavoid_env.parallel_env(info_format="readable"))


def test_mappo_example_trains_with_finite_losses():
    from reachavoid.training.mappo import LOSSES

    lines = run_example("torchrl_mappo", "--defenders", "idle", "--iterations", "2", "--frames",
                        "300", "--minibatch", "150", "--epochs", "2", "--shaping", "0",
                        "--timeout-reward", "0")
    history = [record for record in records(lines) if "iteration" in record]
    assert [record["frames"] for record in history] == [300, 300]
    for record in history:
        assert all(math.isfinite(record[key]) for key in LOSSES)
        # Without shaping or time-out reward the live agents' rewards are arrivals minus
        # captures.
        assert record["reward_sum"] == record["arrived"] - record["captured"]
        assert record["captured"] == 0       # idle defenders capture nobody


def test_vector_attackers_env_passes_specs_and_resets_ended_copies_alone():
    from torchrl.envs.utils import check_env_specs

    from reachavoid.training.views import make_attackers_vector_env
    from reachavoid_env.integrations.torchrl import VectorGroupEnv

    view = make_attackers_vector_env("paper_6v2", defenders="greedy", num_envs=4,
                                     max_cycles=60, autoreset=False)
    env = VectorGroupEnv(view)
    check_env_specs(env)
    rollout = env.rollout(150, break_when_any_done=False)
    assert rollout["next", "attacker", "observation"].shape == (4, 150, 6, 59)
    done = rollout["next", "done"][..., 0]
    assert done.sum() >= 8                                # every copy ended twice or more
    # the step after a copy's end is its new episode's first: time left is full again
    after = rollout["next", "attacker", "observation"][:, 1:][done[:, :-1]]
    assert (after[..., -1] > 0.97).all()
    mask = rollout["next", "attacker", "mask"]
    assert (rollout["next", "attacker", "observation"][~mask] == 0).all()


def test_vector_defenders_learn_as_the_defender_group():
    from reachavoid.training.views import make_defenders_vector_env
    from reachavoid_env.integrations.torchrl import VectorGroupEnv

    env = VectorGroupEnv(make_defenders_vector_env("paper_6v2", num_envs=3, max_cycles=40,
                                                   autoreset=False))
    rollout = env.rollout(50, break_when_any_done=False)
    assert env.group == "defender"
    assert rollout["next", "defender", "reward"].shape == (3, 50, 2, 1)
    assert rollout["next", "done"].any()
