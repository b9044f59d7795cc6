"""Batched defenders (policies.batch_defenders, policies.greedy) at K copies against the
same code at K = 1, one game per copy (reachavoid_env.PerCopy of the single policies,
which are the batched ones at one copy): the same actions, bit for bit, over hundreds of
steps of K random-start games played forward with those actions; over several maps
through reachavoid_env.PerMap."""

import dataclasses

import numpy as np
import pytest
from defenders_reference import ReferenceGreedyDefender

import reachavoid_env
from policies.assignment_defender import AssignmentDefender
from policies.attackers import ShortestPathAttacker
from policies.batch_defenders import BatchAssignmentDefenders, BatchHJDefenders
from policies.certificate import Basis
from policies.defenders import HJDefenderPolicy
from policies.greedy import BatchGreedyDefenders, GreedyDefender
from policies.intercept import BatchInterceptDefenders, InterceptDefender
from policies.registry import BATCHED, DEFENDERS, NamedPolicy, make_batch_policy
from policies.strategy import Program, Spare, Strategy
from reachavoid_env import BatchState, PerCopy, PerMap, Single

EPISODE = 400
"""Steps after which a copy starts a new game (a new random start)."""


class Copies:
    """K random-start games of ``scenario`` (or of a list of maps, one drawn per game);
    even copies' attackers take the shortest
    path, odd ones random actions; a copy whose game ends (or reaches ``EPISODE``) starts
    again, and the policies hear of it through ``reset_copies``."""

    def __init__(self, scenario, count, policies):
        self.envs = [reachavoid_env.parallel_env(scenario=scenario, starts="random")
                     for _ in range(count)]
        self.attackers = [ShortestPathAttacker() for _ in range(count)]
        self.rng = np.random.default_rng(count)
        self.policies = policies
        self.games = 0
        self.restart(list(range(count)))

    def restart(self, copies):
        for k in copies:
            self.envs[k].reset(seed=self.games)
            self.attackers[k].reset(self.envs[k].scenario)
            self.games += 1
        for policy in self.policies:
            policy.reset_copies(np.array(copies), [self.envs[k].scenario for k in copies])

    def state(self):
        return BatchState.of([env.game_state() for env in self.envs])

    def step(self, defender_actions):
        ended = []
        for k, env in enumerate(self.envs):
            state = env.game_state()
            actions = {f"defender_{j}": a for j, a in enumerate(defender_actions[k])}
            if k % 2:
                actions |= {name: self.rng.uniform(-1, 1, 2).astype(np.float32)
                            for name in state.attacker_names}
            else:
                actions |= self.attackers[k].act(state)
            env.step({name: a for name, a in actions.items() if name in env.agents})
            if not env.agents or env.game_state().step >= EPISODE:
                ended.append(k)
        if ended:
            self.restart(ended)


def play_side_by_side(scenario, count, steps, reference, batched, watch=None):
    """Play ``steps`` steps with ``reference``'s actions; fail at the first step where
    ``batched`` differs in any bit. ``watch(reference)`` is called after each step."""
    copies = Copies(scenario, count, [reference, batched])
    for step in range(steps):
        state = copies.state()
        expected, got = reference.act_batch(state), batched.act_batch(state)
        assert got.shape == expected.shape and got.dtype == np.float32
        differ = np.argwhere((expected.view(np.uint32) != got.view(np.uint32)).any(axis=2))
        assert not len(differ), (f"step {step}: copy, defender {differ[0]}: "
                                 f"{expected[tuple(differ[0])]} != {got[tuple(differ[0])]}")
        if watch is not None:
            watch(reference)
        copies.step(expected)
    return copies


@pytest.mark.parametrize(("name", "count", "steps", "margin", "kinds"), [
    ("paper_8v4", 16, 200, 1.0, {(Basis.TUBE, 1), (Basis.OPEN, 1), "solved", "pair",
                                 "pair kept", "single kept"}),
    ("paper_6v2", 8, 200, 1.0, {(Basis.TUBE, 1), "solved", "pair", "pair kept",
                                "single kept"}),
    ("paper_8v4", 64, 100, 1.0, {(Basis.TUBE, 1), (Basis.OPEN, 1), "solved", "pair"}),
    # no certificate: every game of the program is played, none kept
    ("paper_8v4", 8, 200, 0.0, {(Basis.TUBE, 1), (Basis.TUBE, 2), "solved", "pair"}),
])
def test_batched_hj_plays_as_one_policy_per_copy(coarse_tubes, name, count, steps, margin,
                                                 kinds):
    vf11, vf21 = coarse_tubes
    scenario = reachavoid_env.builtin_scenario(name)
    reference = PerCopy(lambda _: HJDefenderPolicy(vf11, vf21, margin_cells=margin))
    seen = set()

    def watch(per_copy):  # the test reaches every kind of game the batch plays
        for policy in per_copy.policies:
            seen.update((game.basis, len(game.attackers)) for game in policy.certified_games)
            if policy.solver.solves:
                seen.add("solved")
            played = policy.last_assignment
            if played is not None and any(len(mine) == 2 for mine in played.by_defender):
                seen.add("pair")
            for game in policy.played_games:
                if game not in policy.certified_games:
                    seen.add("pair kept" if len(game.attackers) == 2 else "single kept")

    copies = play_side_by_side(scenario, count, steps, reference,
                               BatchHJDefenders(vf11, vf21, margin_cells=margin), watch)
    assert copies.games > count  # copies restarted mid-run
    assert kinds <= seen


@pytest.mark.parametrize("strategy", [
    Strategy(Program.MIP, 0.0, Spare.STAND),            # paper
    Strategy(Program.MIP, 1.0, Spare.SHADOW),
    Strategy(Program.MATCHING, 1.0, Spare.PURSUE),
])
def test_every_strategy_plays_as_one_copy_each(coarse_tubes, strategy):
    """The engine plays every strategy at K copies as at one copy each (the paper's
    method, the shadowing spares, the matching baseline pursuing)."""
    vf11, vf21 = coarse_tubes
    scenario = reachavoid_env.builtin_scenario("paper_6v2")
    tubes = (vf11, None if strategy.program is Program.MATCHING else vf21, None)
    copies = play_side_by_side(scenario, 6, 300,
                               PerCopy(lambda _: AssignmentDefender(*tubes, strategy)),
                               BatchAssignmentDefenders(*tubes, strategy))
    assert copies.games > 6


def test_per_map_gives_each_copy_its_maps_batched_policy(coarse_tubes):
    """Copies restart on maps drawn from three (the paper's geometry under three names, so
    one pair of tubes serves them): one batched policy per map, each acting for its copies
    only and keeping each copy's state, still the single policy bit for bit."""
    vf11, vf21 = coarse_tubes
    paper = reachavoid_env.builtin_scenario("paper_6v2")
    maps = [dataclasses.replace(paper, name=f"{c}_paper") for c in "abc"]
    built = []

    def factory(scenario):
        built.append(scenario.name)
        return BatchHJDefenders(vf11, vf21)

    per_map = PerMap(factory)
    copies = play_side_by_side(maps, 8, 250, PerCopy(lambda _: HJDefenderPolicy(vf11, vf21)),
                               per_map)
    assert copies.games > 8 and sorted(built) == [f"{c}_random_6v2" for c in "abc"]
    assert len(set(per_map._map_of.tolist())) > 1   # copies on several maps at the end
    with pytest.raises(ValueError, match="scenarios"):
        per_map.reset_copies(np.array([0, 1]), maps[:1])


def test_per_map_needs_every_copy_reset():
    env = reachavoid_env.parallel_env(scenario="paper_6v2", starts="random")
    env.reset(seed=0)
    policy = PerMap(lambda _: BatchGreedyDefenders())
    policy.reset_copies(np.array([1]), [env.scenario])
    with pytest.raises(RuntimeError, match="reset_copies"):
        policy.act_batch(BatchState.of([env.game_state()] * 2))


def test_batched_greedy_plays_as_one_policy_per_copy():
    """K = 1 against K = 16 of the one greedy, and the greedy of before it was batched (a
    numpy twin in ``tests/defenders_reference.py``), edges included."""
    scenario = reachavoid_env.builtin_scenario("paper_8v4")
    play_side_by_side(scenario, 16, 200, PerCopy(lambda _: GreedyDefender()),
                      BatchGreedyDefenders())
    single, twin = PerCopy(lambda _: GreedyDefender()), PerCopy(
        lambda _: ReferenceGreedyDefender())

    def same_edges(_):
        for mine, theirs in zip(single.policies, twin.policies, strict=True):
            assert mine.overlay() == theirs.overlay()

    copies = Copies(scenario, 4, [single, twin])
    for _ in range(150):
        state = copies.state()
        expected, got = twin.act_batch(state), single.act_batch(state)
        assert np.array_equal(expected.view(np.uint32), got.view(np.uint32))
        same_edges(None)
        copies.step(expected)


def test_batched_intercept_plays_as_one_policy_per_copy():
    scenario = reachavoid_env.builtin_scenario("paper_8v4")
    play_side_by_side(scenario, 12, 200, PerCopy(lambda _: InterceptDefender()),
                      BatchInterceptDefenders())


def test_batch_state_gives_each_copy_as_the_env_does():
    envs = [reachavoid_env.parallel_env(scenario="paper_6v2", starts="random")
            for _ in range(3)]
    for k, env in enumerate(envs):
        env.reset(seed=k)
        for _ in range(k * 40):
            env.step({name: np.ones(2, dtype=np.float32) for name in env.agents})
    batch = BatchState.of([env.game_state() for env in envs])
    for k, env in enumerate(envs):
        single, copied = env.game_state(), batch.game_state(k)
        for name in ("time", "step", "attacker_status", "attacker_speed", "defender_speed",
                     "capture_radius"):
            assert getattr(copied, name) == getattr(single, name)
        for name in ("attacker_positions", "defender_positions"):
            assert np.array_equal(getattr(copied, name), getattr(single, name))
    assert batch.attacker_status.dtype == np.int8 and batch.attacker_status.max() > 0


def test_per_copy_needs_every_copy_reset():
    scenario = reachavoid_env.builtin_scenario("paper_6v2")
    env = reachavoid_env.parallel_env(scenario=scenario, starts="random")
    env.reset(seed=0)
    states = BatchState.of([env.game_state()] * 2)
    policy = PerCopy(lambda _: GreedyDefender())
    policy.reset_copies(np.array([0]), [env.scenario])
    with pytest.raises(RuntimeError, match="reset_copies"):
        policy.act_batch(states)
    with pytest.raises(ValueError, match="side"):
        PerCopy(lambda _: GreedyDefender(), side="both")


def test_registry_builds_the_batched_class_where_there_is_one():
    scenario = reachavoid_env.builtin_scenario("paper_8v4")
    assert isinstance(make_batch_policy("defenders", "greedy", scenario),
                      BatchGreedyDefenders)
    assert isinstance(make_batch_policy("defenders", "intercept", scenario),
                      BatchInterceptDefenders)
    fallback = make_batch_policy("defenders", "idle", scenario)
    assert isinstance(fallback, PerCopy) and fallback.side == "defenders"
    assert isinstance(make_batch_policy("attackers", "shortest-path", scenario), PerCopy)


def test_a_batched_name_whose_factory_builds_a_single_gives_its_engine(monkeypatch):
    """``hj-pairs``, ``paper`` and ``matching`` are the assignment engine at one copy
    (``Single``): ``make_batch_policy`` hands out the engine itself."""
    engine = BatchGreedyDefenders()
    choice = NamedPolicy("a Single", lambda scenario: Single(engine))
    monkeypatch.setitem(DEFENDERS, "engine-test", choice)
    monkeypatch.setitem(BATCHED["defenders"], "engine-test", choice)
    scenario = reachavoid_env.builtin_scenario("paper_8v4")
    assert make_batch_policy("defenders", "engine-test", scenario) is engine
    for name in ("hj-pairs", "paper", "matching"):
        assert BATCHED["defenders"][name] is DEFENDERS[name]


def test_batched_hj_refuses_copies_of_another_game(coarse_tubes):
    vf11, vf21 = coarse_tubes
    policy = BatchHJDefenders(vf11, vf21)
    paper = reachavoid_env.builtin_scenario("paper_8v4")
    env = reachavoid_env.parallel_env(scenario=paper, starts="random")
    env.reset(seed=0)
    with pytest.raises(RuntimeError, match="reset_copies"):
        policy.act_batch(BatchState.of([env.game_state()]))
    policy.reset_copies(np.array([0]), [env.scenario])
    with pytest.raises(ValueError, match="scenarios"):  # another step: another game
        policy.reset_copies(np.array([1]), [dataclasses.replace(paper, dt=paper.dt / 2)])
