"""The env's step against a slow reference path: the event phase (the rules at every
step, no ``EventWatch``) and the infos as they were before the step was made faster
(issue 34), kept here verbatim. Same seeds and actions must give the same trajectories,
rewards, flags and infos, bit for bit; a step the watch calls quiet has no event."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from reachavoid_env import Box, Circle, GameMap, Polygon, ReachAvoidEnv, Scenario, rules
from reachavoid_env.environment import _STATUSES
from reachavoid_env.observations import GLOBAL

MIXED_MAP = GameMap(
    domain=(-1.0, 1.0, -0.8, 0.8),
    target=(Box((0.6, 0.1), (0.8, 0.3)), Circle((-0.7, 0.6), 0.1)),
    obstacles=(
        Box((-0.1, -0.8), (0.1, -0.3)),
        Circle((-0.5, -0.3), 0.12),
        Polygon(((0.4, -0.7), (0.9, -0.7), (0.9, -0.2), (0.75, -0.2), (0.65, -0.55),
                 (0.55, -0.2), (0.4, -0.2))),
    ),
)
MIXED = Scenario(map=MIXED_MAP, num_attackers=4, num_defenders=3, capture_radius=0.08,
                 max_steps=10_000)


class ReferenceEnv(ReachAvoidEnv):
    """The env with the reference event phase (the rules at every step: the core without
    its watch) and infos."""

    def reset(self, seed=None, options=None):
        out = super().reset(seed=seed, options=options)
        self._core._watch = None
        return out

    def _infos(self, agents, captor):
        captured, arrived = self._core.counts[0]
        counts = {"captured": int(captured), "arrived": int(arrived)}
        infos: dict[str, dict[str, Any]] = {}
        for name in agents:
            i = self._index[name]
            info = dict(counts)
            if i < self._m:
                code, by = int(self._core.status[0, i]), int(captor[i])
                if self.info_format == "numeric":
                    info.update({"status": code, "captured_by": by})
                elif by < 0:
                    info.update({"status": _STATUSES[code]})
                else:
                    info.update({"status": _STATUSES[code],
                                 "captured_by": self.possible_agents[self._m + by]})
            infos[name] = info
        return infos


def chase_actions(env: ReachAvoidEnv, rng: np.random.Generator) -> dict[str, np.ndarray]:
    """Attackers run for the target, defenders now and then for the nearest attacker in
    play, with noise and lengths from 0.2 to 2 (so captures, arrivals and scaled actions
    all happen)."""
    state = env.game_state()
    goal = np.mean(np.array(env.scenario.map.target[0].bounds()).reshape(2, 2), axis=1)
    live = state.attacker_positions[state.active_attackers]
    actions = {}
    for name in env.agents:
        i = env.possible_agents.index(name)
        if i < env.scenario.num_attackers:
            heading = goal - state.attacker_positions[i]
        elif rng.random() < 0.4:
            me = state.defender_positions[i - env.scenario.num_attackers]
            heading = live[np.argmin(((live - me) ** 2).sum(axis=1))] - me
        else:
            heading = rng.normal(0.0, 1.0, 2)
        heading = heading / max(float(np.hypot(*heading)), 1e-9) * rng.uniform(0.2, 2.0)
        actions[name] = (heading + rng.normal(0.0, 0.7, 2)).astype(np.float32)
    return actions


def assert_same(a: Any, b: Any) -> None:
    """Equal values of equal types, arrays bit for bit, dicts in the same key order."""
    assert type(a) is type(b)
    if isinstance(a, dict):
        assert list(a) == list(b)
        for key in a:
            assert_same(a[key], b[key])
    elif isinstance(a, tuple):
        assert len(a) == len(b)
        for x, y in zip(a, b, strict=True):
            assert_same(x, y)
    elif isinstance(a, np.ndarray):
        assert a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()
    else:
        assert a == b


@pytest.mark.parametrize("kwargs", [
    {"scenario": "paper_8v4", "observation": GLOBAL},
    {"scenario": "paper_8v4", "starts": "random", "shaping": 0.5, "info_format": "readable"},
    {"scenario": MIXED, "shaping": 0.25, "max_cycles": 300, "observation": GLOBAL},
], ids=["paper_8v4-v0", "random-starts-shaping-readable-v1", "mixed-map-v0"])
def test_rollouts_match_the_reference_bit_for_bit(kwargs):
    fast, slow = ReachAvoidEnv(**kwargs), ReferenceEnv(**kwargs)
    rng = np.random.default_rng(7)
    events = {"captured": 0, "arrived": 0, "episodes": 0}
    for seed in range(3):
        assert_same(fast.reset(seed=seed), slow.reset(seed=seed))
        while fast.agents:
            actions = chase_actions(fast, rng)
            out = fast.step(actions)
            assert_same(out, slow.step(actions))
            assert fast.agents == slow.agents
            assert_same(fast.game_state().attacker_positions,
                        slow.game_state().attacker_positions)
        state = fast.game_state()
        events["captured"] += len(state.captured)
        events["arrived"] += len(state.arrived)
        events["episodes"] += 1
    assert events["captured"] > 0 and events["arrived"] > 0, events  # both rules are tested


def test_a_step_the_watch_calls_quiet_has_no_event():
    # Players rush at each other and at the target, each move exactly as long as the
    # longest allowed: the watch's slack may be spent to the last bit, never past an event.
    rng = np.random.default_rng(11)
    bounds = rules.target_bounds(MIXED_MAP)
    goal = np.array([0.7, 0.2])
    quiet = 0
    for _ in range(300):
        m, n = int(rng.integers(1, 5)), int(rng.integers(1, 4))
        a, d = rng.uniform(-1.0, 1.0, (m, 2)), rng.uniform(-1.0, 1.0, (n, 2))
        active = rng.random(m) < 0.8
        longest = float(rng.choice([0.001, 0.004, 0.02]))
        watch = rules.EventWatch(0.08, bounds, longest)
        watch.anchor(active, a, d)
        for _ in range(60):
            to_goal = rng.random(m)[:, None] < 0.5
            a_aim = np.where(to_goal, goal, d[rng.integers(0, n, m)]) - a
            d_aim = a[rng.integers(0, m, n)] - d
            a_new = a + longest * rules.unit_vectors(a_aim)
            d_new = d + longest * rules.unit_vectors(d_aim)
            if not watch.quiet():
                break  # the env resolves this step and anchors again
            quiet += 1
            assert not rules.resolve_events(MIXED_MAP, 0.08, active, a, a_new, d, d_new,
                                            bounds).left.any()
            a, d = a_new, d_new
    assert quiet > 500
