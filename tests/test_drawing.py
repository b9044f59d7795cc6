"""The assignment defenders' overlay (policies.drawing): a race is drawn along the way
the defender races, around the obstacles, and the renderer draws it there."""

import numpy as np
import pytest

import reachavoid_env
from policies.defenders import HJDefenderPolicy, IdleDefender
from policies.drawing import race_routes
from policies.intercept import plan_intercepts, race_all
from reachavoid_env import AttackerStatus, GameState, Overlay, merged_overlay
from reachavoid_env import palette as P
from reachavoid_env.geodesic import distance_field
from reachavoid_env.overlay import EdgeKind, Route
from reachavoid_env.render import Renderer

SCENARIO = reachavoid_env.builtin_scenario("paper_2v1")
"""The paper map: a wall from (-0.1, -1) to (0.1, -0.3), the target right of it."""


def behind_the_wall(defender=(-0.5, -0.9), attacker=(0.5, -0.8)):
    """A defender left of the paper map's lower wall racing an attacker right of it: the
    state, the race's plan and its route."""
    state = GameState(time=0.0, step=0, attacker_positions=np.array([attacker]),
                      defender_positions=np.array([defender]),
                      attacker_status=(AttackerStatus.ACTIVE,), attacker_speed=1.0,
                      defender_speed=1.5, capture_radius=0.1)
    field = distance_field(SCENARIO.map, SCENARIO.player_radius)
    plan = plan_intercepts(race_all(field, state), np.ones(1, bool), state.active_attackers)
    return state, plan, race_routes(field, state, plan, ((0, 0),))[0]


def clearance_along(points):
    """The least distance to the obstacles along the segments through ``points``."""
    points = np.asarray(points)
    t = np.linspace(0.0, 1.0, 50)[None, :, None]
    samples = points[:-1, None] + t * (points[1:, None] - points[:-1, None])
    return SCENARIO.map.obstacle_signed_distance(samples.reshape(-1, 2)).min()


@pytest.mark.parametrize("defender", [(-0.5, -0.9), (-0.4, -0.7)])
def test_the_race_is_drawn_around_the_wall(defender):
    state, plan, route = behind_the_wall(defender)
    assert clearance_along([defender, plan.aims[0]]) < 0    # straight: through the wall
    assert (route.defender, route.attacker) == ("defender_0", "attacker_0")
    assert np.allclose(route.points[0], defender) and np.allclose(route.points[-1],
                                                                  state.attacker_positions[0])
    assert np.min(np.hypot(*(np.array(route.points) - plan.aims[0]).T)) < 1e-9
    assert clearance_along(route.points) > 0


def test_the_renderer_draws_an_edge_along_its_route():
    state, _, route = behind_the_wall()
    edge = (("defender_0", "attacker_0"),)
    renderer = Renderer(SCENARIO.map, SCENARIO.capture_radius)
    straight = np.linspace(route.points[0], route.points[-1], 400)
    in_wall = straight[SCENARIO.map.obstacle_signed_distance(straight) < -0.02]

    def drawn_in_the_wall(overlay):
        """Whether anything but the wall shows where the straight edge crosses it."""
        renderer.reset()
        renderer.draw(state, overlay)
        frame = renderer.rgb_array()
        x, y = np.round(renderer.to_pixels(in_wall)).astype(int).T
        return (frame[y, x] != np.asarray(P.OBSTACLE)).any()

    assert len(in_wall) and drawn_in_the_wall(Overlay(edges=edge, kinds=(EdgeKind.RACE,)))
    assert not drawn_in_the_wall(Overlay(edges=edge, kinds=(EdgeKind.RACE,), ways=lambda: (route,)))


def test_a_route_must_belong_to_an_edge():
    stray = Overlay(ways=lambda: (Route("defender_0", "attacker_0", ((0.0, 0.0), (1.0, 1.0))),))
    with pytest.raises(ValueError, match="routes"):
        assert stray.routes


def test_hj_draws_every_race_along_its_route(coarse_tubes):
    """The reference defenders' overlay: a route for every race edge, each keeping clear
    of the obstacles (merged with another policy's overlay, still there)."""
    vf11, vf21 = coarse_tubes
    env = reachavoid_env.parallel_env(scenario="paper_8v4", starts="random")
    env.reset(seed=1)
    policy = HJDefenderPolicy(vf11, vf21)
    policy.reset(env.unwrapped.scenario)
    raced = set()
    for _ in range(30):
        state = env.unwrapped.game_state()
        actions = policy.act(state)
        overlay = merged_overlay(policy, IdleDefender())
        races = {edge.defender + edge.attacker for edge in overlay.kinded_edges
                 if edge.kind is EdgeKind.RACE}
        assert {r.defender + r.attacker for r in overlay.routes} == races
        raced |= races
        for route in overlay.routes:
            assert clearance_along(route.points) > 0
        env.step({name: actions.get(name, np.zeros(2, np.float32)) for name in env.agents})
    assert raced
