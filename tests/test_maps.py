"""Generated maps and map libraries (reachavoid_env/maps.py, `reachavoid maps`)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from reachavoid.cli import main
from reachavoid_env import Box, GameMap, Scenario, builtin_map, load_scenario
from reachavoid_env.maps import (
    INDEX,
    MapError,
    MapOptions,
    connected_to_target,
    generate_map,
    library_files,
    load_library,
    map_file,
    options_from_text,
    raster_points,
    shape_gap,
    write_library,
)

OPTIONS = MapOptions()
BUSY = MapOptions(obstacles=(6, 9), shapes=("polygon", "circle"), density=(0.15, 0.35),
                  target_region=(0.2, 1.0, -1.0, 1.0), attackers=6, defenders=2)


def test_same_seed_same_map_and_map_k_independent_of_the_count():
    assert generate_map(OPTIONS, 7, 3) == generate_map(OPTIONS, 7, 3)
    assert generate_map(OPTIONS, 7, 3) != generate_map(OPTIONS, 8, 3)
    assert generate_map(OPTIONS, 7, 3) != generate_map(OPTIONS, 7, 4)
    two, three = library_files(OPTIONS, 7, 2), library_files(OPTIONS, 7, 3)
    assert two[map_file(1)] == three[map_file(1)]
    assert library_files(OPTIONS, 7, 2) == two


@pytest.mark.parametrize(("options", "seed"), [(OPTIONS, 0), (OPTIONS, 11), (BUSY, 2)])
def test_every_generated_map_passes_the_checks(options, seed):
    for index in range(4):
        scenario = generate_map(options, seed, index)
        game_map = scenario.map
        # The scenario checks: a round trip through the TOML data validates it again.
        assert Scenario.from_dict(scenario.to_dict()) == scenario
        assert (scenario.attackers, scenario.defenders) == (None, None)
        assert (scenario.num_attackers, scenario.num_defenders) == (options.attackers,
                                                                    options.defenders)
        assert options.obstacles[0] <= len(game_map.obstacles) <= options.obstacles[1]
        assert connected_to_target(game_map, options.free_clearance, options.raster)
        shapes = list(game_map.obstacles)
        for k, shape in enumerate(shapes):
            assert shape.type in options.shapes
            assert shape_gap(shape, game_map.target[0]) >= options.clearance
            x0, x1, y0, y1 = shape.bounds()
            d = options.domain
            assert min(x0 - d[0], d[1] - x1, y0 - d[2], d[3] - y1) >= options.clearance
            for other in shapes[k + 1:]:
                assert shape_gap(shape, other) >= options.clearance
        points = raster_points(game_map.domain, 400)
        density = float(np.mean(game_map.in_obstacle(points)))
        assert options.density[0] - 0.01 <= density <= options.density[1] + 0.01
        tx0, tx1, ty0, ty1 = game_map.target[0].bounds()
        r = options.target_region or options.domain
        assert r[0] <= tx0 and tx1 <= r[1] and r[2] <= ty0 and ty1 <= r[3]
        side = tx1 - tx0
        assert options.target_size[0] - 1e-3 <= side <= options.target_size[1] + 1e-3
        rng = np.random.default_rng(index)
        for _ in range(20):
            attackers, defenders = scenario.starts(rng)
            scenario.validate_starts(attackers, defenders)
            assert np.all(game_map.obstacle_signed_distance(attackers) >= options.start_clearance)


def test_the_connectivity_check_finds_cut_off_regions():
    target = (Box((0.6, 0.1), (0.8, 0.3)),)
    assert connected_to_target(builtin_map("paper"), 0.05)
    wall = GameMap((-1, 1, -1, 1), target, (Box((-0.1, -1.0), (0.1, 1.0)),))
    assert not connected_to_target(wall, 0.05)
    ring = tuple(Box(lo, hi) for lo, hi in [((-0.8, -0.8), (-0.2, -0.7)),
                                            ((-0.8, -0.3), (-0.2, -0.2)),
                                            ((-0.8, -0.8), (-0.7, -0.2)),
                                            ((-0.3, -0.8), (-0.2, -0.2))])
    assert not connected_to_target(GameMap((-1, 1, -1, 1), target, ring), 0.05)
    # A gap narrower than twice the clearance cuts the pocket off; a wider one does not.
    narrow = ring[:3] + (Box((-0.3, -0.8), (-0.2, -0.56)), Box((-0.3, -0.5), (-0.2, -0.2)))
    assert not connected_to_target(GameMap((-1, 1, -1, 1), target, narrow), 0.05)
    wide = ring[:3] + (Box((-0.3, -0.8), (-0.2, -0.6)), Box((-0.3, -0.4), (-0.2, -0.2)))
    assert connected_to_target(GameMap((-1, 1, -1, 1), target, wide), 0.05)


@pytest.mark.parametrize(("options", "field"), [
    ({"obstacles": (5, 2)}, "obstacles"),
    ({"obstacles": (1, 1000)}, "obstacles[1]"),
    ({"shapes": ("box", "blob")}, "shapes"),
    ({"density": (0.5, 0.6)}, "density"),
    ({"clearance": -0.1}, "clearance"),
    ({"target_size": (0.0, 0.2)}, "target_size[0]"),
    ({"target_region": (0.9, 1.0, 0.9, 1.0)}, "target_region"),
    ({"target_region": (0.0, 2.0, 0.0, 1.0)}, "target_region"),
    ({"attackers": 0}, "attackers"),
    ({"defender_speed": float("nan")}, "defender_speed"),
    ({"capture_radius": 5.0}, "capture_radius"),
    ({"raster": 40}, "raster"),
    ({"domain": (1.0, -1.0, -1.0, 1.0)}, "domain"),
])
def test_each_option_is_checked_by_name(options, field):
    with pytest.raises(MapError, match=rf"^{field.replace('[', '.').replace(']', '.')}: "):
        MapOptions(**options)


def test_a_target_that_fills_the_domain_is_blamed_before_any_draw(tmp_path, capsys):
    from checks import fails_cleanly

    for size in ((2.0, 2.0), (1.9, 2.0)):
        with pytest.raises(MapError, match="^target_size: a target of side"):
            MapOptions(target_size=size)
    fails_cleanly(capsys, ["maps", "--target-size", "2,2", "--out", str(tmp_path / "lib")],
                  "--target-size: a target of side 2 leaves no room")
    assert list(tmp_path.iterdir()) == []


def test_options_from_text():
    options = options_from_text({"obstacles": "1,3", "shapes": "circle", "attackers": "4",
                                 "clearance": "0.2", "density": None})
    assert (options.obstacles, options.shapes, options.attackers, options.clearance) == \
        ((1, 3), ("circle",), 4, 0.2)
    with pytest.raises(MapError, match="^attackers: "):
        options_from_text({"attackers": "1.5"})


def test_impossible_options_fail_naming_the_option():
    with pytest.raises(MapError, match="^obstacles: "):
        generate_map(MapOptions(obstacles=(40, 40), obstacle_size=(0.4, 0.5),
                                density=(0.0, 0.9)), 0, attempts=3)


def test_write_library_is_repeatable_and_refuses_foreign_files(tmp_path):
    out = tmp_path / "lib"
    write_library(out, OPTIONS, 1, 3)
    first = {p.name: p.read_bytes() for p in out.iterdir()}
    assert set(first) == {INDEX, "map-0000.toml", "map-0001.toml", "map-0002.toml"}
    write_library(out, OPTIONS, 1, 3)                  # ours: replaced by the same bytes
    assert {p.name: p.read_bytes() for p in out.iterdir()} == first
    write_library(out, OPTIONS, 2, 3)                  # ours (indexed): may be replaced
    assert (out / "map-0000.toml").read_bytes() != first["map-0000.toml"]
    (out / "map-0001.toml").write_text("# edited by hand\n")
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    with pytest.raises(MapError, match="^out: .*map-0001.toml.* not written"):
        write_library(out, OPTIONS, 1, 3)
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before
    foreign = tmp_path / "foreign"
    foreign.mkdir()
    (foreign / INDEX).write_text("not = 'ours'\n")
    with pytest.raises(MapError, match="^out: .*not a map library index"):
        write_library(foreign, OPTIONS, 1, 1)


def test_load_library_from_folder_index_and_list(tmp_path):
    write_library(tmp_path, OPTIONS, 4, 3)
    maps = load_library(tmp_path)
    assert [s.name for s in maps] == ["gen-s4-0000", "gen-s4-0001", "gen-s4-0002"]
    assert maps == load_library(tmp_path / INDEX)
    assert maps[1] == generate_map(OPTIONS, 4, 1) == load_scenario(tmp_path / map_file(1))
    assert load_library([tmp_path / map_file(0), "paper_2v1"])[1].name == "paper_2v1"


def test_cli_maps_writes_the_same_bytes(tmp_path, capsys):
    args = ["maps", "--count", "2", "--seed", "5", "--obstacles", "1,3", "--shapes",
            "box,circle"]
    assert main([*args, "--out", str(tmp_path / "a")]) == 0
    assert main([*args, "--out", str(tmp_path / "b")]) == 0
    a = {p.name: p.read_bytes() for p in (tmp_path / "a").iterdir()}
    assert a == {p.name: p.read_bytes() for p in (tmp_path / "b").iterdir()}
    capsys.readouterr()
    assert main(["maps", "--out", str(tmp_path / "c"), "--density", "0.5,0.2"]) == 2
    assert capsys.readouterr().err.strip() == (
        "reachavoid maps: error: --density: the low end 0.5 exceeds the high end 0.2")
    assert not (tmp_path / "c").exists()


SMALL = MapOptions(obstacles=(1, 2), shapes=("box", "circle"), density=(0.0, 0.3))


def test_an_env_over_a_library_draws_a_map_per_reset_from_the_seed(tmp_path):
    import reachavoid_env

    write_library(tmp_path, SMALL, 0, 4)
    env = reachavoid_env.parallel_env(scenario=str(tmp_path))
    assert len(env.scenarios) == 4
    played = {}
    for seed in range(12):
        observations, _ = env.reset(seed=seed)
        played[seed] = (env.scenario.name, observations["attacker_0"].tolist())
    assert len({name for name, _ in played.values()}) >= 3
    again = reachavoid_env.parallel_env(scenario=load_library(tmp_path / INDEX))
    for seed in (3, 7):
        observations, _ = again.reset(seed=seed)
        assert (again.scenario.name, observations["attacker_0"].tolist()) == played[seed]
    one = reachavoid_env.parallel_env(scenario="paper_2v1")   # one map: nothing drawn
    assert one.reset(seed=1)[0]["attacker_0"].tolist() == \
        reachavoid_env.parallel_env(scenario="paper_2v1").reset(seed=1)[0]["attacker_0"].tolist()
    with pytest.raises(ValueError, match="share the counts"):
        reachavoid_env.parallel_env(scenario=[str(tmp_path / map_file(0)), "paper_6v2"])


def test_play_names_the_map_the_env_draws_without_building_one(tmp_path):
    import reachavoid_env
    from reachavoid.play import drawn_map

    write_library(tmp_path, SMALL, 0, 4)
    scenarios = load_library(tmp_path)
    env = reachavoid_env.parallel_env(scenario=scenarios)
    for seed in range(16):
        env.reset(seed=seed)
        assert drawn_map(scenarios, seed).name == env.scenario.name


def test_attacker_envs_over_a_library_build_defenders_per_map_once(tmp_path):
    from policies import tubes
    from reachavoid.training.views import make_attackers_parallel_env
    from reachavoid_env import PerMapPolicy

    write_library(tmp_path, SMALL, 1, 2)
    options = {"grid1": 11, "progress": False}
    first = make_attackers_parallel_env(str(tmp_path), defenders="matching",
                                        defender_options=options)
    second = make_attackers_parallel_env(str(tmp_path), defenders="matching",
                                         defender_options=options)
    assert isinstance(first.defenders, PerMapPolicy)
    names = set()
    for seed in range(8):
        for env in (first, second):
            env.reset(seed=seed)
            env.step({name: np.zeros(2) for name in env.agents})
            names.add(env.game.scenario.name)
            assert env.defenders.current.vf11.game_map == env.game.scenario.map
    assert names == {"gen-s1-0000", "gen-s1-0001"}
    assert len(first.defenders.built) == 2
    for scenario in load_library(tmp_path):   # each map's tube loaded once in this process
        key = replace(scenario, attackers=None, defenders=None)
        assert first.defenders.built[key].vf11 is second.defenders.built[key].vf11
        assert first.defenders.built[key].vf11 is tubes.tube_1v1(scenario, 11)


def test_a_library_is_accepted_by_the_registered_ids_and_by_play(tmp_path, capsys):
    import json

    import gymnasium

    import policies  # noqa: F401  (registers the ids)
    import reachavoid_env

    write_library(tmp_path, SMALL, 2, 3)
    env = gymnasium.make("reachavoid/Attacker-v1", scenario=str(tmp_path), defenders="greedy")
    names = set()
    for seed in range(6):
        env.reset(seed=seed)
        names.add(env.unwrapped.game.scenario.name)
    assert len(names) >= 2
    drawn = reachavoid_env.parallel_env(scenario=str(tmp_path))
    drawn.reset(seed=4)
    assert main(["play", "--scenario", str(tmp_path / INDEX), "--defenders", "greedy",
                 "--attackers", "straight", "--seed", "4", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["scenario"] == drawn.scenario.name


def test_bench_over_a_library_plays_a_cell_per_map_and_pools_them(tmp_path, capsys):
    import json

    write_library(tmp_path, SMALL, 5, 2)
    assert main(["bench", "--scenario", str(tmp_path), "--defenders", "greedy,idle",
                 "--attackers", "straight", "--episodes", "3", "--seed", "7", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    maps = [s.name for s in load_library(tmp_path)]
    assert [c["cell"] for c in report["cells"]] == [f"{name} / straight" for name in maps]
    assert all(c["methods"][0]["attackers"] == SMALL.attackers for c in report["cells"])
    [pooled] = report["pooled"]
    assert (pooled["attackers"], pooled["cells"], pooled["episodes"]) == ("straight", 2, 6)
    for k, method in enumerate(pooled["methods"]):   # the pool is the cells' episodes
        rates = [c["methods"][k]["capture_rate"] for c in report["cells"]]
        assert method["capture_rate"] == pytest.approx(np.mean(rates))
    [difference] = pooled["differences"]
    assert (difference["label"], difference["baseline"], difference["episodes"]) == (
        "idle", "greedy", 6)
    assert main(["bench", "--scenario", str(tmp_path), "--config", "3v1", "--defenders",
                 "greedy", "--attackers", "straight", "--episodes", "2"]) == 0
    table = capsys.readouterr().out
    assert "pooled / straight: 2 maps, 4 episodes" in table
    assert all(f"{s.with_players(3, 1).name} / straight: 2 episode(s)" in table
               for s in load_library(tmp_path))
    assert main(["bench", "--scenario", str(tmp_path), "--config", "3v1", "--defenders",
                 "greedy", "--attackers", "straight", "--episodes", "1", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)["rows"]
    assert {r["num_attackers"] for r in rows} == {3}


def test_a_hand_edited_index_is_not_replaced(tmp_path):
    write_library(tmp_path, OPTIONS, 1, 2)
    write_library(tmp_path, OPTIONS, 1, 2)             # unedited: rewritten
    index = tmp_path / INDEX
    edited = index.read_text().replace("[[maps]]", '[[maps]]\nfile = "mine.toml"\n'
                                       'name = "mine"\nsha256 = "0"\n\n[[maps]]', 1)
    index.write_text(edited)
    with pytest.raises(MapError, match=r"^out: .*index.toml.* changed since"):
        write_library(tmp_path, OPTIONS, 1, 2)
    assert index.read_text() == edited
