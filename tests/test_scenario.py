"""Scenario files: built-ins, round trips, random starts and every validation error."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import reachavoid_env
from reachavoid_env import (
    Box,
    ScenarioError,
    builtin_map,
    builtin_names,
    builtin_scenario,
    load_scenario,
    save_scenario,
)

VALID = """
name = "test"
[map]
domain = [-1.0, 1.0, -1.0, 1.0]
target = { type = "box", min = [0.6, 0.1], max = [0.8, 0.3] }
obstacles = [
  { type = "box", min = [-0.1, -1.0], max = [0.1, -0.3] },
  { type = "circle", center = [0.5, -0.5], radius = 0.1 },
  { type = "polygon", vertices = [[-0.6, 0.3], [-0.3, 0.3], [-0.45, 0.6]] },
]
[players]
attacker_speed = 1.0
defender_speed = 1.5
capture_radius = 0.1
attackers = [[-0.5, 0.0], [0.0, 0.8]]
defenders = [[0.3, -0.3]]
[sim]
dt = 0.005
max_steps = 1000
"""


def load_text(tmp_path, text: str):
    path = tmp_path / "scenario.toml"
    path.write_text(text)
    return load_scenario(path)


def test_valid_file_loads(tmp_path):
    scenario = load_text(tmp_path, VALID)
    assert scenario.num_attackers == 2 and scenario.num_defenders == 1
    assert scenario.attackers == ((-0.5, 0.0), (0.0, 0.8))
    assert len(scenario.map.obstacles) == 3


@pytest.mark.parametrize(("old", "new", "field"), [
    ("[players]", "[players", "malformed TOML"),
    ('{ type = "circle", center = [0.5, -0.5], radius = 0.1 }',
     '{ type = "ellipse", center = [0.5, -0.5], radius = 0.1 }',
     "map.obstacles[1].type: unknown shape type 'ellipse'"),
    ("center = [0.5, -0.5]", "center = [0.5, -0.5, 0.0]",
     "map.obstacles[1].center: expected a vector [x, y] of length 2"),
    ("attackers = [[-0.5, 0.0], [0.0, 0.8]]", "attackers = [[-0.5, 0.0], [0.0]]",
     "players.attackers[1]: expected a vector [x, y] of length 2"),
    ("domain = [-1.0, 1.0, -1.0, 1.0]", "domain = [-1.0, 1.0, -1.0]", "map.domain"),
    ("attacker_speed = 1.0", "attacker_speed = 0.0",
     "players.attacker_speed: must be in (0, 1000]"),
    ("defender_speed = 1.5", "defender_speed = -1.5",
     "players.defender_speed: must be in (0, 1000]"),
    ("capture_radius = 0.1", "capture_radius = 0", "players.capture_radius: must be in (0, 2]"),
    ("dt = 0.005", "dt = -0.005", "sim.dt: must be in (0, 1]"),
    ("max_steps = 1000", "max_steps = 0", "sim.max_steps: must be an integer in [1, 10000000]"),
    ("dt = 0.005", "dt = 0.005\nplayer_radius = 0.0", "sim.player_radius: must be in (0, 0.2]"),
    ("attackers = [[-0.5, 0.0], [0.0, 0.8]]", "attackers = [[-0.5, 0.0], [0.0, -0.5]]",
     "players.attackers[1]: (0, -0.5) lies inside obstacle 0"),
    ("defenders = [[0.3, -0.3]]", "defenders = [[0.5, -0.55]]",
     "players.defenders[0]: (0.5, -0.55) lies inside obstacle 1"),
    ("attackers = [[-0.5, 0.0], [0.0, 0.8]]", "attackers = [[-0.5, 0.0], [-0.45, 0.4]]",
     "players.attackers[1]: (-0.45, 0.4) lies inside obstacle 2"),
    ("attackers = [[-0.5, 0.0], [0.0, 0.8]]", "attackers = [[-0.5, 0.0], [0.0, 1.2]]",
     "players.attackers[1]: (0, 1.2) lies outside the domain"),
    ("defenders = [[0.3, -0.3]]", "defenders = [[-1.5, -0.3]]",
     "players.defenders[0]: (-1.5, -0.3) lies outside the domain"),
    ("attackers = [[-0.5, 0.0], [0.0, 0.8]]", "attackers = [[0.7, 0.3], [0.0, 0.8]]",
     "players.attackers[0]: (0.7, 0.3) starts inside the target"),
    ("attackers = [[-0.5, 0.0], [0.0, 0.8]]", "attackers = [[-0.5, 0.0], [0.3, -0.25]]",
     "players.attackers[1]: (0.3, -0.25) starts captured by defenders[0]"),
    ('target = { type = "box", min = [0.6, 0.1], max = [0.8, 0.3] }',
     'target = { type = "box", min = [0.45, -0.45], max = [0.8, 0.3] }',
     "map.target: overlaps obstacle 1"),
    ("[sim]", "[sim]\nspeed = 3", "sim: unknown keys ['speed']"),
])
def test_validation_error_names_the_field(tmp_path, old, new, field):
    assert old in VALID
    with pytest.raises(ScenarioError) as info:
        load_text(tmp_path, VALID.replace(old, new, 1))
    assert field in str(info.value)
    assert str(info.value).startswith(f"{info.value.field}: ")   # the attribute names it too


def test_missing_file_and_unknown_builtin_are_errors(tmp_path):
    with pytest.raises(ScenarioError, match="no such file or built-in"):
        load_scenario(tmp_path / "missing.toml")
    with pytest.raises(ScenarioError, match="unknown built-in"):
        builtin_scenario("paper_99v1")


def test_builtins_match_design():
    assert builtin_names() == ["paper_1v1", "paper_2v1", "paper_6v2", "paper_6v4_equal",
                               "paper_8v4"]
    sizes = {name: (builtin_scenario(name).num_attackers, builtin_scenario(name).num_defenders)
             for name in builtin_names()}
    assert sizes == {"paper_1v1": (1, 1), "paper_2v1": (2, 1), "paper_6v2": (6, 2),
                     "paper_6v4_equal": (6, 4), "paper_8v4": (8, 4)}
    game_map = builtin_map("paper")
    assert game_map.target == (Box((0.6, 0.1), (0.8, 0.3)),)
    assert game_map.obstacles == (Box((-0.1, -1.0), (0.1, -0.3)), Box((-0.1, 0.3), (0.1, 0.6)))
    paper = builtin_scenario("paper_2v1")
    assert (paper.attacker_speed, paper.defender_speed, paper.capture_radius, paper.dt) == (
        1.0, 1.5, 0.1, 0.005)
    equal = builtin_scenario("paper_6v4_equal")
    assert equal.map == game_map
    assert (equal.attacker_speed, equal.defender_speed, equal.capture_radius, equal.dt) == (
        1.0, 1.0, 0.1, 0.005)


def test_save_load_round_trip(tmp_path):
    scenario = load_text(tmp_path, VALID)
    path = tmp_path / "copy.toml"
    save_scenario(scenario, path)
    assert load_scenario(path) == scenario
    assert [p.name for p in tmp_path.iterdir() if p.name.endswith(".tmp")] == []


def test_random_starts_are_valid_and_seeded():
    scenario = builtin_scenario("paper_6v2").with_players(8, 4)
    a1, d1 = scenario.starts(np.random.default_rng(7))
    a2, d2 = scenario.starts(np.random.default_rng(7))
    a3, _ = scenario.starts(np.random.default_rng(8))
    assert np.array_equal(a1, a2) and np.array_equal(d1, d2) and not np.array_equal(a1, a3)
    assert a1.shape == (8, 2) and d1.shape == (4, 2)
    scenario.validate_starts(a1, d1)
    assert np.all(scenario.map.obstacle_signed_distance(np.concatenate([a1, d1]))
                  >= scenario.start_clearance)


def test_attacker_inside_a_closed_ring_polygon_is_refused(tmp_path):
    text = (Path(reachavoid_env.__file__).parent / "scenarios" / "paper_2v1.toml").read_text()
    text = text.replace('  { type = "box", min = [-0.1, 0.3], max = [0.1, 0.6] },',
                        '  { type = "polygon", vertices = [[-0.6, -0.1], [-0.4, -0.1], '
                        '[-0.4, 0.1], [-0.6, 0.1], [-0.6, -0.1]] },')
    path = tmp_path / "ring.toml"
    path.write_text(text)
    with pytest.raises(ScenarioError, match=r"players.attackers\[0\].*inside obstacle 1"):
        load_scenario(path)


def test_saved_scenario_round_trips_paper_table(tmp_path):
    path = tmp_path / "p.toml"
    save_scenario(builtin_scenario("paper_6v2"), path)
    assert dict(load_scenario(path).paper_captures) == {"paper": 6, "matching": 4}
