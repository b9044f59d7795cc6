"""PettingZoo's own conformance checks, for every built-in and for random starts."""

from __future__ import annotations

from dataclasses import replace
from functools import partial
from types import SimpleNamespace

import pytest
from checks import checked
from pettingzoo.test import (
    api_test,
    max_cycles_test,
    parallel_api_test,
    render_test,
    seed_test,
    state_test,
)

import reachavoid_env
from reachavoid_env import builtin_names, builtin_scenario, reach_avoid_v0


def _random(m: int, n: int, **changes):
    return replace(builtin_scenario("paper_2v1").with_players(m, n), **changes)


SCENARIOS = {name: builtin_scenario(name) for name in builtin_names()}
SCENARIOS.update({
    "random_1v1": _random(1, 1),
    "random_3v2": _random(3, 2),
    "random_8v4": _random(8, 4),
    # Large capture discs and long steps, so random play captures and arrives within the
    # API tests' episodes (agents are removed, and some episodes end early).
    "crowded_4v3": _random(4, 3, capture_radius=0.3, dt=0.05),
})


@pytest.fixture(params=sorted(SCENARIOS))
def scenario(request):
    return SCENARIOS[request.param]


def test_parallel_api(scenario):
    checked(parallel_api_test, reachavoid_env.parallel_env(scenario=scenario), num_cycles=400)


def test_parallel_api_with_the_nearest_players():
    """The nearest-players observation (fewer teammates than a side has, more opponents):
    spaces and observations still agree as players leave."""
    env = reachavoid_env.parallel_env(scenario=SCENARIOS["crowded_4v3"],
                                      observation={"teammates": 2, "opponents": 5})
    checked(parallel_api_test, env, num_cycles=400)
    checked(seed_test, partial(reachavoid_env.env, scenario=SCENARIOS["crowded_4v3"],
                               observation={"teammates": 1, "opponents": 1}))


def test_aec_api(scenario):
    checked(api_test, reachavoid_env.env(scenario=scenario, max_cycles=150), num_cycles=150)


def test_max_cycles(scenario):
    module = SimpleNamespace(env=partial(reachavoid_env.env, scenario=scenario),
                             parallel_env=partial(reachavoid_env.parallel_env,
                                                  scenario=scenario))
    max_cycles_test(module)


def test_max_cycles_of_the_versioned_module():
    max_cycles_test(reach_avoid_v0)


def test_state(scenario):
    checked(state_test, reachavoid_env.env(scenario=scenario),
            reachavoid_env.parallel_env(scenario=scenario))


def test_seed(scenario):
    seed_test(partial(reachavoid_env.env, scenario=scenario, max_cycles=100), num_cycles=100)


@pytest.mark.parametrize("name", ["paper_6v2", "crowded_4v3"])
def test_render(name):
    def make(render_mode=None):
        return reachavoid_env.env(scenario=SCENARIOS[name], render_mode=render_mode,
                                  render_width=160)

    render_test(make)
