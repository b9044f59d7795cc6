"""The open-space 1 vs 1 certificate inside the reference defenders
(``policies.certificate.OpenSpace``): counted, seen by the program, played by parallel
navigation, and sound in play against many attackers."""

from __future__ import annotations

import numpy as np
import pytest
from lookups_reference import slack as game_slack

import reachavoid_env
from policies import (
    HJAttacker,
    HJDefenderPolicy,
    MatchingDefenderPolicy,
    RandomAttacker,
    ShortestPathAttacker,
)
from policies.certificate import Basis, Match
from reachavoid.rollout import run_episode
from reachavoid_env import Box, GameMap, Scenario
from solvers import open_space
from solvers.hj import solve_1v1

OPEN = GameMap((-1.0, 1.0, -1.0, 1.0), (Box((0.6, -0.1), (0.8, 0.1)),))
"""An open map: a small target, no obstacle."""


@pytest.fixture(scope="module")
def open_tube():
    """The open map's 1 vs 1 tube at 21^4 (a few seconds, not cached)."""
    return solve_1v1(OPEN, (1.0, 1.5), 0.1, 21, cache=False, progress=False)


def _open_scenario(attackers: int, defenders: int) -> Scenario:
    return Scenario(map=OPEN, num_attackers=attackers, num_defenders=defenders, name="open")


class ZigzagAttacker:
    """Every attacker heads for the target's centre turned 70 degrees left or right,
    switching every ``period`` steps: the parallel-navigation defender reads a stale
    velocity each switch."""

    def __init__(self, period: int) -> None:
        self.period = period

    def reset(self, scenario: Scenario) -> None:
        self._goal = np.mean([s.bounds() for s in scenario.map.target], axis=0)[[0, 2, 1, 3]]
        self._goal = (self._goal[:2] + self._goal[2:]) / 2

    def act(self, state) -> dict[str, np.ndarray]:
        aim = self._goal - state.attacker_positions
        angle = np.arctan2(aim[:, 1], aim[:, 0]) + np.radians(70) * (
            1 if (state.step // self.period) % 2 else -1)
        heading = np.stack([np.cos(angle), np.sin(angle)], axis=1).astype(np.float32)
        return dict(zip(state.attacker_names, heading, strict=True))


def test_an_open_space_game_certifies_where_the_tube_margin_cannot(open_tube):
    """With a margin of 2 cells (0.2, above the 1 vs 1 value's cap, the capture radius)
    the tube certifies nothing; a defender between the attacker and the target is
    certified by the open-space condition, counted, and the program sees the win."""
    policy = HJDefenderPolicy(open_tube, None, margin_cells=2.0)
    env = reachavoid_env.parallel_env(scenario=_open_scenario(1, 1))
    env.reset(seed=0, options={"attackers": np.array([[-0.6, 0.0]]),
                               "defenders": np.array([[-0.2, 0.0]])})
    policy.reset(env.unwrapped.scenario)
    state = env.unwrapped.game_state()
    policy.act(state)
    assert game_slack(policy.tubes, [Match((0,), (0,))], state, open_tube.value(
        np.concatenate([state.attacker_positions, state.defender_positions], 1))[:, None]) <= 0
    assert policy.certified_games == [Match((0,), (0,))]
    assert policy.certified_games[0].basis is Basis.OPEN
    assert policy.guaranteed_captures == 1 == policy.nominal_captures
    # a start the defender loses by the tube but wins in the open is still a program win:
    # the same at equal speeds has no Apollonius disc and certifies nothing
    equal = HJDefenderPolicy(solve_1v1(OPEN, (1.0, 1.0), 0.1, 21, cache=False,
                                       progress=False), None, margin_cells=2.0)
    env = reachavoid_env.parallel_env(scenario=Scenario(
        map=OPEN, num_attackers=1, num_defenders=1, defender_speed=1.0, name="equal"))
    env.reset(seed=0, options={"attackers": np.array([[-0.6, 0.0]]),
                               "defenders": np.array([[-0.2, 0.0]])})
    equal.reset(env.unwrapped.scenario)
    equal.act(env.unwrapped.game_state())
    assert equal.guaranteed_captures == 0


def test_open_space_games_are_counted_and_played_by_parallel_navigation(coarse_tubes):
    """Over played 8v4 episodes on the paper map: every open-space game is a 1 vs 1 game
    counted in ``guaranteed_captures``, and its defender's action is the
    parallel-navigation heading with the attacker's velocity of its last step (pure
    pursuit on the first)."""
    vf11, vf21 = coarse_tubes
    scenario = reachavoid_env.builtin_scenario("paper_2v1").with_players(8, 4)
    env = reachavoid_env.parallel_env(scenario=scenario)
    opened = 0
    for seed, attackers in ((1, ShortestPathAttacker()), (2, RandomAttacker(seed=2))):
        policy = HJDefenderPolicy(vf11, vf21)
        env.reset(seed=seed)
        attackers.reset(env.unwrapped.scenario)
        policy.reset(env.unwrapped.scenario)
        previous = None
        while env.agents:
            state = env.unwrapped.game_state()
            actions = {**attackers.act(state), **policy.act(state)}
            games = policy.certified_games
            assert policy.guaranteed_captures == sum(len(g.attackers) for g in games)
            for game in games:
                if game.basis is not Basis.OPEN:
                    continue
                opened += 1
                (i,), (j,) = game.attackers, game.defenders
                velocity = (np.zeros((1, 2)) if previous is None
                            else (state.attacker_positions[[i]] - previous[[i]]) / scenario.dt)
                expected = open_space.parallel_navigation(
                    state.attacker_positions[[i]], state.defender_positions[[j]], velocity,
                    scenario.defender_speed)[0]
                np.testing.assert_allclose(actions[f"defender_{j}"], expected, atol=1e-6)
            previous = state.attacker_positions.copy()
            env.step({a: actions[a] for a in env.agents})
    assert opened > 0, "no open-space game was played: the test is vacuous"


ATTACKERS = {"shortest-path": lambda vf: ShortestPathAttacker(),
             "random": lambda vf: RandomAttacker(seed=3, hold=0.005),
             "random-held": lambda vf: RandomAttacker(seed=4),
             "hj": HJAttacker,
             "zigzag-1": lambda vf: ZigzagAttacker(1),
             "zigzag-7": lambda vf: ZigzagAttacker(7)}


@pytest.mark.parametrize("attacker", list(ATTACKERS))
def test_open_space_certificate_holds_in_play(open_tube, attacker):
    """On the open map, with the tube's margin out of reach (2 cells: every guarantee is
    an open-space one), seeded 1v1 and 3v2 starts: no guarantee falls and no attacker
    arrives that one ruled out, against each attacker (zigzags included, which keep the
    defender's velocity estimate stale)."""
    guaranteed = 0
    for (m, n), make in (((1, 1), lambda: HJDefenderPolicy(open_tube, None, margin_cells=2.0)),
                         ((3, 2), lambda: MatchingDefenderPolicy(
                             open_tube, unmatched="pursue", margin_cells=2.0))):
        env = reachavoid_env.parallel_env(scenario=_open_scenario(m, n))
        for seed in range(6):
            result = run_episode(env, ATTACKERS[attacker](open_tube), make(), seed=seed)
            assert result.guarantee_violations == 0, (m, n, seed, result.guarantees)
            assert result.arrivals_beyond_promise == 0, (m, n, seed)
            guaranteed += max(result.guarantees)
    assert guaranteed >= 6, "too few open-space guarantees: the test would be vacuous"


@pytest.mark.parametrize("attacker", ["shortest-path", "random", "zigzag-1"])
def test_open_space_certificate_holds_among_obstacles(coarse_tubes, attacker):
    """The paper map (walls and two obstacles) with the tubes' margin out of reach
    (10 cells): 8v4 starts, every guarantee an open-space one, none breaks."""
    vf11, vf21 = coarse_tubes
    scenario = reachavoid_env.builtin_scenario("paper_2v1").with_players(8, 4)
    env = reachavoid_env.parallel_env(scenario=scenario)
    guaranteed = 0
    for seed in range(3):
        result = run_episode(env, ATTACKERS[attacker](vf11),
                             HJDefenderPolicy(vf11, vf21, margin_cells=10.0), seed=seed)
        assert result.guarantee_violations == 0, (seed, result.guarantees)
        assert result.arrivals_beyond_promise == 0, seed
        guaranteed += max(result.guarantees)
    assert guaranteed > 0
