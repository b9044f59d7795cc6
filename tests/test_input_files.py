"""Input files of every kind (scenario, suite, library index and its maps) are read by one
reader and checked before any work: one line naming the file and field, never a
traceback; ``validate`` finds what ``play`` would."""

from __future__ import annotations

from pathlib import Path

import pytest
from checks import SIMPLE, fails_cleanly

from reachavoid.suite import SuiteError, load_suite
from reachavoid_env import ScenarioError, load_scenario
from reachavoid_env.maps import INDEX, MapOptions, load_library, map_file, write_library

ROOT = Path(__file__).resolve().parents[1]
PAPER = (ROOT / "reachavoid_env" / "scenarios" / "paper_2v1.toml").read_text()
OPTIONS = MapOptions(obstacles=(1, 2), shapes=("box",), density=(0.0, 0.3))


@pytest.fixture
def library(tmp_path) -> Path:
    write_library(tmp_path / "lib", OPTIONS, 3, 2)
    return tmp_path / "lib"


def refused_as_nested_too_deeply(capsys, path: Path, load, error: type, args: list[str]):
    """With TOML nested 5,000 deep in ``path``, ``load()`` raises ``error`` and the command
    ``args`` says so in one line."""
    path.write_text("x = " + "[" * 5000 + "]" * 5000 + "\n")
    with pytest.raises(error, match="nested too deeply"):
        load()
    fails_cleanly(capsys, args, "nested too deeply")


def test_a_deeply_nested_suite_is_one_line(tmp_path, capsys):
    path = tmp_path / "deep.toml"
    refused_as_nested_too_deeply(capsys, path, lambda: load_suite(path), SuiteError,
                                 ["bench", "--suite", str(path)])


def test_a_deeply_nested_index_is_one_line(library, capsys):
    refused_as_nested_too_deeply(capsys, library / INDEX, lambda: load_library(library),
                                 ScenarioError, ["play", "--scenario", str(library)])


@pytest.mark.parametrize("value", ["5", "[]", '""'])
def test_an_index_entry_of_the_wrong_type_is_one_line(library, capsys, value):
    index = library / INDEX
    index.write_text(index.read_text().replace(f'file = "{map_file(0)}"', f"file = {value}"))
    fails_cleanly(capsys, ["play", "--scenario", str(index)], "maps[0].file")


def test_suites_accept_a_byte_order_mark(tmp_path):
    text = (ROOT / "reachavoid_env" / "suites" / "default.toml").read_bytes()
    path = tmp_path / "bom.toml"
    path.write_bytes(b"\xef\xbb\xbf" + text)
    assert load_suite(path).name == "default"


def test_an_error_in_one_map_names_its_file(library, capsys):
    broken = library / map_file(1)
    broken.write_text(broken.read_text().replace("capture_radius = ", "capture_radius = -"))
    err = fails_cleanly(capsys, ["play", "--scenario", str(library)], "capture_radius")
    assert str(broken) in err
    index = library / INDEX
    index.unlink()   # a folder without an index: every *.toml
    err = fails_cleanly(capsys, ["play", "--scenario", str(library)], "capture_radius")
    assert str(broken) in err


def test_maps_that_share_a_name_are_refused(tmp_path, capsys):
    for k, speed in enumerate(("1.0", "2.0")):
        (tmp_path / f"m{k}.toml").write_text(
            PAPER.replace("attacker_speed = 1.0", f"attacker_speed = {speed}"))
    with pytest.raises(ScenarioError, match="names in a library are unique"):
        load_library(tmp_path)
    fails_cleanly(capsys, ["solve", "--scenario", str(tmp_path), "--defenders", "hj"],
              "names in a library are unique")
    same = load_library([tmp_path / "m0.toml", tmp_path / "m0.toml"])
    assert len(same) == 1


def test_validate_finds_what_play_would(tmp_path, capsys):
    path = tmp_path / "small.toml"
    path.write_text('name = "small"\n[map]\ndomain = [-10.0, 10.0, -10.0, 10.0]\n'
                    'target = { type = "box", min = [3.01, 3.01], max = [3.03, 3.03] }\n'
                    '[players]\nattackers = [[-5.0, 0.0]]\ndefenders = [[3.0, -3.0]]\n')
    fails_cleanly(capsys, ["validate", str(path)], "no free grid node lies in the target")
    fails_cleanly(capsys, ["play", "--scenario", str(path), "--defenders", "greedy"],
              "no free grid node lies in the target")


def scenario_text(old: str = "", new: str = "") -> str:
    """The built-in paper_2v1 file with ``old`` replaced by ``new``."""
    return PAPER.replace(old, new) if old else PAPER


@pytest.mark.parametrize(("old", "new", "message"), [
    ("dt = 0.005", "dt = 1e7", "sim.dt: must be in (0, 1]"),
    ("dt = 0.005", "dt = 0.005\nplayer_radius = 1e-10", "sim.dt: 0.005 s at speed 1.5 needs"),
    ("domain = [-1.0, 1.0, -1.0, 1.0]", "domain = [-1e6, 1e6, -1.0, 1.0]",
     "map.domain[0]: must be in [-10000, 10000]"),
    ("max_steps = 1000", "max_steps = 1e9", "sim.max_steps: expected an integer"),
])
def test_scenario_numbers_out_of_range(capsys, tmp_path, old, new, message):
    path = tmp_path / "s.toml"
    path.write_text(scenario_text(old, new))
    fails_cleanly(capsys, ["play", "--scenario", str(path), *SIMPLE], message)


def test_non_utf8_scenario(capsys, tmp_path):
    path = tmp_path / "latin.toml"
    path.write_bytes(scenario_text().encode() + "# caf\xe9\n".encode("latin-1"))
    fails_cleanly(capsys, ["play", "--scenario", str(path), *SIMPLE], "not UTF-8 text")


def test_deeply_nested_toml_is_one_line(tmp_path, capsys):
    path = tmp_path / "deep.toml"
    refused_as_nested_too_deeply(capsys, path, lambda: load_scenario(path), ScenarioError,
                                 ["play", "--scenario", str(path)])


def test_a_byte_order_mark_is_accepted(tmp_path):
    text = (ROOT / "reachavoid_env" / "scenarios" / "paper_2v1.toml").read_bytes()
    path = tmp_path / "bom.toml"
    path.write_bytes(b"\xef\xbb\xbf" + text)
    assert load_scenario(path).num_attackers == 2
