"""Input files of every kind (scenario, suite, library index and its maps) are read by one
reader and checked before any work: one line naming the file and field, never a
traceback; ``validate`` finds what ``play`` would."""

from __future__ import annotations

from pathlib import Path

import pytest

from reachavoid.cli import main
from reachavoid.suite import SuiteError, load_suite
from reachavoid_env import ScenarioError
from reachavoid_env.maps import INDEX, MapOptions, load_library, map_file, write_library

ROOT = Path(__file__).resolve().parents[1]
PAPER = (ROOT / "reachavoid_env" / "scenarios" / "paper_2v1.toml").read_text()
OPTIONS = MapOptions(obstacles=(1, 2), shapes=("box",), density=(0.0, 0.3))


def _one_line(capsys, args: list[str], message: str) -> str:
    assert main(args) == 2
    out, err = capsys.readouterr()
    assert out == "" and err.count("\n") == 1 and message in err, err
    return err


@pytest.fixture
def library(tmp_path) -> Path:
    write_library(tmp_path / "lib", OPTIONS, 3, 2)
    return tmp_path / "lib"


def test_a_deeply_nested_suite_is_one_line(tmp_path, capsys):
    path = tmp_path / "deep.toml"
    path.write_text("x = " + "[" * 5000 + "]" * 5000 + "\n")
    with pytest.raises(SuiteError, match="nested too deeply"):
        load_suite(path)
    _one_line(capsys, ["bench", "--suite", str(path)], "nested too deeply")


def test_a_deeply_nested_index_is_one_line(library, capsys):
    (library / INDEX).write_text("x = " + "[" * 5000 + "]" * 5000 + "\n")
    with pytest.raises(ScenarioError, match="nested too deeply"):
        load_library(library)
    _one_line(capsys, ["play", "--scenario", str(library)], "nested too deeply")


@pytest.mark.parametrize("value", ["5", "[]", '""'])
def test_an_index_entry_of_the_wrong_type_is_one_line(library, capsys, value):
    index = library / INDEX
    index.write_text(index.read_text().replace(f'file = "{map_file(0)}"', f"file = {value}"))
    _one_line(capsys, ["play", "--scenario", str(index)], "maps[0].file")


def test_suites_accept_a_byte_order_mark(tmp_path):
    text = (ROOT / "reachavoid_env" / "suites" / "default.toml").read_bytes()
    path = tmp_path / "bom.toml"
    path.write_bytes(b"\xef\xbb\xbf" + text)
    assert load_suite(path).name == "default"


def test_an_error_in_one_map_names_its_file(library, capsys):
    broken = library / map_file(1)
    broken.write_text(broken.read_text().replace("capture_radius = ", "capture_radius = -"))
    err = _one_line(capsys, ["play", "--scenario", str(library)], "capture_radius")
    assert str(broken) in err
    index = library / INDEX
    index.unlink()   # a folder without an index: every *.toml
    err = _one_line(capsys, ["play", "--scenario", str(library)], "capture_radius")
    assert str(broken) in err


def test_maps_that_share_a_name_are_refused(tmp_path, capsys):
    for k, speed in enumerate(("1.0", "2.0")):
        (tmp_path / f"m{k}.toml").write_text(
            PAPER.replace("attacker_speed = 1.0", f"attacker_speed = {speed}"))
    with pytest.raises(ScenarioError, match="names in a library are unique"):
        load_library(tmp_path)
    _one_line(capsys, ["solve", "--scenario", str(tmp_path), "--defenders", "hj"],
              "names in a library are unique")
    same = load_library([tmp_path / "m0.toml", tmp_path / "m0.toml"])
    assert len(same) == 1


def test_validate_finds_what_play_would(tmp_path, capsys):
    path = tmp_path / "small.toml"
    path.write_text('name = "small"\n[map]\ndomain = [-10.0, 10.0, -10.0, 10.0]\n'
                    'target = { type = "box", min = [3.01, 3.01], max = [3.03, 3.03] }\n'
                    '[players]\nattackers = [[-5.0, 0.0]]\ndefenders = [[3.0, -3.0]]\n')
    _one_line(capsys, ["validate", str(path)], "no free grid node lies in the target")
    _one_line(capsys, ["play", "--scenario", str(path), "--defenders", "greedy"],
              "no free grid node lies in the target")
