"""Benchmarking defenders: policies from anywhere, options from signatures, suites, honest
intervals and paired differences."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from policies.defenders import IdleDefender
from policies.registry import (
    SCHEMES,
    NamedPolicy,
    PolicySpec,
    make_policy,
    policy_names,
    policy_specs,
    resolve,
    scenario_free,
)
from reachavoid import compare_defenders, summarize
from reachavoid.cli import main
from reachavoid.evaluation import OneStartWarning, mean_interval, paired_difference
from reachavoid.rollout import EpisodeResult
from reachavoid.suite import load_suite
from reachavoid_env import Policy, builtin_names, builtin_scenario

ROOT = Path(__file__).resolve().parents[1]
TINY = ("--grid1", "11", "--grid2", "8")

POLICY_MODULE = '''
"""A defender of one's own: chase the nearest attacker, aiming ``lead`` of the way from it
towards the target (a time-to-intercept heuristic in a few lines)."""
import numpy as np


class Mine:
    def __init__(self, scenario, lead=0.3):
        x0, x1, y0, y1 = scenario.map.target[0].bounds()
        self.goal = np.array([(x0 + x1) / 2, (y0 + y1) / 2])
        self.lead = lead

    def reset(self, scenario):
        pass

    def act(self, state):
        active = np.flatnonzero(state.active_attackers)
        actions = {}
        for j, name in enumerate(state.defender_names):
            if len(active) == 0:
                actions[name] = np.zeros(2, dtype=np.float32)
                continue
            gaps = state.attacker_positions[active] - state.defender_positions[j]
            a = state.attacker_positions[active[np.argmin(np.hypot(*gaps.T))]]
            aim = a + self.lead * (self.goal - a) - state.defender_positions[j]
            norm = np.hypot(*aim)
            actions[name] = (aim / norm if norm > 0 else aim).astype(np.float32)
        return actions
'''


@pytest.fixture
def policy_folder(tmp_path, monkeypatch):
    """A folder holding ``tmpmod.py`` (not installed), put on ``sys.path``."""
    (tmp_path / "tmpmod.py").write_text(POLICY_MODULE)
    monkeypatch.syspath_prepend(str(tmp_path))
    return tmp_path


def cli(folder: Path, *args: str, python: str = sys.executable) -> subprocess.CompletedProcess:
    """``reachavoid ARGS`` in a fresh interpreter with ``folder`` on ``PYTHONPATH``."""
    env = os.environ | {"PYTHONPATH": os.pathsep.join([str(folder), str(ROOT)])}
    return subprocess.run([python, "-m", "reachavoid.cli", *args], capture_output=True,
                          text=True, env=env, cwd=folder, timeout=900)


def bench_json(folder: Path, *extra: str, python: str = sys.executable) -> dict:
    done = cli(folder, "bench", "--defenders", "tmpmod:Mine,hj", "--config", "2v1",
               "--episodes", "4", "--json", *TINY, *extra, python=python)
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout)


def check_rows(report: dict) -> None:
    rows = report["rows"]
    assert {(r["defenders"], r["seed"]) for r in rows} == {
        (m, k) for m in ("tmpmod:Mine", "hj") for k in range(4)}
    assert all(r["captured_count"] + r["arrived_count"] <= 2 for r in rows)
    [cell] = report["cells"]
    assert [d["label"] for d in cell["differences"]] == ["tmpmod:Mine"]


def test_policy_module_of_ones_own_on_a_process_pool(tmp_path):
    (tmp_path / "tmpmod.py").write_text(POLICY_MODULE)
    report = bench_json(tmp_path, "--backend", "process", "--workers", "2")
    check_rows(report)
    serial = bench_json(tmp_path)
    strip = [{k: v for k, v in r.items() if k != "seconds"} for r in serial["rows"]]
    assert strip == [{k: v for k, v in r.items() if k != "seconds"} for r in report["rows"]]


def test_a_factory_object_and_its_options(policy_folder):
    import tmpmod

    scenario = builtin_scenario("paper_2v1").with_players(2, 1)
    spec = PolicySpec.of("defenders", tmpmod.Mine, lead=0.5)
    assert spec.label == "tmpmod:Mine" and spec(scenario).lead == 0.5
    assert make_policy("defenders", "tmpmod:Mine", scenario, lead=0.1).lead == 0.1
    with pytest.raises(ValueError, match=r"unknown option\(s\) \['speed'\] \(accepted: lead\)"):
        make_policy("defenders", "tmpmod:Mine", scenario, speed=2)
    comparison = compare_defenders(scenario, [tmpmod.Mine, "greedy"], "straight", 3,
                                   progress=False, baseline="greedy", lead=0.0)
    assert [s.label for s in comparison.summaries] == ["tmpmod:Mine", "greedy"]
    assert [d.label for d in comparison.differences] == ["tmpmod:Mine"]
    assert {r["defenders"] for r in comparison.rows} == {"tmpmod:Mine", "greedy"}


def test_options_come_from_signatures_and_one_rule_holds_everywhere():
    assert resolve("defenders", "hj").options == {"grid1", "grid2", "idle", "margin_cells",
                                                  "progress"}
    assert resolve("defenders", "matching").options == {"grid1", "unmatched", "margin_cells",
                                                        "progress"}
    assert resolve("attackers", "random").options == {"seed", "hold"}
    assert resolve("defenders", "greedy").options == frozenset()
    scenario = builtin_scenario("paper_2v1")
    with pytest.raises(ValueError, match=r"unknown option\(s\) \['grid2'\]"):
        make_policy("defenders", "matching", scenario, grid1=25, grid2=15)
    hj, matching = policy_specs([("defenders", "hj"), ("defenders", "matching")],
                                {"grid1": 25, "grid2": 15})
    assert dict(hj.options) == {"grid1": 25, "grid2": 15}
    assert dict(matching.options) == {"grid1": 25}
    with pytest.raises(ValueError, match=r"grid2: no chosen policy takes it \(straight, "
                                         r"greedy\)"):
        compare_defenders(scenario.with_players(2, 1), ["greedy"], "straight", 2, grid2=15)
    with pytest.raises(ValueError, match="takes the scenario first"):
        PolicySpec("defenders", lambda: None)


def test_an_installed_package_is_found_by_name(tmp_path, monkeypatch, capsys):
    """An installed distribution (a ``.dist-info`` with ``entry_points.txt``) on the path:
    ``importlib.metadata`` finds its policy, which then shows by name everywhere."""
    package = tmp_path / "tinypolicies"
    package.mkdir()
    (package / "__init__.py").write_text(POLICY_MODULE)
    info = tmp_path / "tinypolicies-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: tinypolicies\n"
                                   "Version: 0.1\n")
    (info / "entry_points.txt").write_text("[reachavoid.defenders]\n"
                                           "mine = tinypolicies:Mine\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    assert "mine" in policy_names("defenders") and "mine" not in policy_names("attackers")
    assert resolve("defenders", "mine").options == {"lead"}
    assert main(["bench", "--help"]) == 0
    assert "mine: from tinypolicies" in " ".join(capsys.readouterr().out.split())
    assert main(["bench", "--defenders", "mine,greedy", "--config", "2v1", "--episodes", "2",
                 "--attackers", "straight", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert [m["label"] for m in report["cells"][0]["methods"]] == ["mine", "greedy"]
    assert report["baseline"] == "mine"


def result(seed: int, captured: int, attackers: int = 2) -> EpisodeResult:
    names = tuple(f"attacker_{i}" for i in range(attackers))
    return EpisodeResult("x", seed, attackers, 10, 0.05, names[:captured], names[captured:],
                         0.01)


def test_intervals_are_never_of_zero_width():
    one = summarize("hj", [result(0, 2)])
    assert one.attackers == 2 and one.capture_rate == 1.0
    assert one.capture_rate_ci[0] < 0.5 and one.capture_rate_method == "wilson"
    assert one.all_captured_ci[0] < 0.5
    same = mean_interval([0.5] * 100)
    assert same.method == "wilson-bound" and same.high - same.low > 0.15
    varied = mean_interval(np.linspace(0.2, 0.8, 40))
    assert varied.method == "bootstrap" and varied.low < 0.5 < varied.high
    few = mean_interval([0.5, 1.0, 0.5])
    assert few.method == "wilson-bound"
    with pytest.raises(ValueError, match="one attacker count"):
        summarize("hj", [result(0, 1, 2), result(1, 1, 3)])


def test_paired_differences_are_per_seed():
    hj = [result(k, 2) for k in range(40)]
    worse = [result(k, 1 if k % 2 else 0) for k in range(40)]
    difference = paired_difference("greedy", worse, "hj", hj)
    assert difference.difference == pytest.approx(-0.75)
    assert difference.method == "bootstrap" and difference.ci[1] < 0
    with pytest.raises(ValueError, match="same seeds"):
        paired_difference("greedy", worse[1:], "hj", hj[:-1])


def test_bench_one_episode_has_a_real_interval(capsys):
    assert main(["bench", "--defenders", "greedy,idle", "--attackers", "straight",
                 "--config", "2v1", "--episodes", "1", "--json"]) == 0
    [cell] = json.loads(capsys.readouterr().out)["cells"]
    for method in cell["methods"]:
        low, high = method["capture_rate_ci"]
        assert high - low > 0.5
    [difference] = cell["differences"]
    assert difference["ci"][1] - difference["ci"][0] > 0.5


def test_a_suite_of_ones_own_with_a_fixed_start_warns_once_and_plots(tmp_path, capsys):
    mine = tmp_path / "mine.toml"
    mine.write_text(textwrap.dedent("""\
        name = "mine"
        version = 3
        seed = 10
        attackers = ["random"]

        [[cells]]
        scenario = "paper_2v1"          # fixed starts: every episode the same start

        [[cells]]
        scenario = "paper_2v1"
        players = "3v1"
        attackers = ["straight", "random"]
        """))
    plot = tmp_path / "suite.png"
    assert main(["bench", "--suite", str(mine), "--defenders", "greedy,idle", "--episodes",
                 "3", "--json", "--plot", str(plot)]) == 0
    out, err = capsys.readouterr()
    assert err.count("\n") == 1 and "warning: 1 cell(s)" in err and "paper_2v1 / random" in err
    report = json.loads(out)
    assert (report["suite"], report["version"], report["seed"]) == ("mine", 3, 10)
    assert [c["cell"] for c in report["cells"]] == [
        "paper_2v1 / random", "paper_2v1 random 3v1 / straight",
        "paper_2v1 random 3v1 / random"]
    assert [c["one_start"] for c in report["cells"]] == [True, False, False]
    assert len(report["rows"]) == 3 * 2 * 3
    assert {r["seed"] for r in report["rows"]} == {10, 11, 12}
    assert plot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and plot.stat().st_size > 20_000
    written = tmp_path / "suite.json"
    assert main(["bench", "--suite", str(mine), "--defenders", "greedy,idle",
                 "--episodes", "2", "--json", str(written)]) == 0
    table = capsys.readouterr().out
    assert len(json.loads(written.read_text())["rows"]) == 3 * 2 * 2
    assert "paper_2v1 random 3v1 / straight: 2 episode(s)" in table
    assert "idle - greedy: capture rate" in table and "Wilson" in table


def test_one_start_comparison_warns():
    with pytest.warns(OneStartWarning, match="paper_2v1"):
        compare_defenders(builtin_scenario("paper_2v1"), ["greedy"], "random", 2,
                          progress=False)


@pytest.mark.parametrize(("text", "message"), [
    ('name = "x"\nversion = 1\ncells = []', "cells: expected a non-empty array"),
    ('name = "x"\nversion = 1\n[[cells]]\nscenario = "paper_2v1"', "cells[0].attackers: missing"),
    ('name = "x"\nversion = 1\nattackers = ["random"]\n[[cells]]\nscenario = "paper_2v1"\n'
     'players = "2x1"', "cells[0].players: expected MvN"),
    ('name = "x"\nversion = 1\nattackers = ["random"]\n[[cells]]\nscenario = "nowhere"',
     "cells[0].scenario: scenario: no such file or built-in 'nowhere'"),
    ('name = "x"\nversion = 0\ncells = []', "version: must be an integer >= 1"),
])
def test_bad_suites_give_one_line(tmp_path, capsys, text, message):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    assert main(["bench", "--suite", str(path), "--defenders", "greedy"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err and str(path) in err


def test_the_default_suite():
    suite = load_suite("default")
    assert (suite.name, suite.version, suite.seed) == ("default", 1, 0)
    fixed = {c.scenario.name for c in suite.cells if c.scenario.attackers is not None}
    assert fixed == set(builtin_names())
    labels = [c.label for c in suite.cells]
    for players in ("paper_2v1 random 2v1", "paper_2v1 random 6v2", "paper_2v1 random 8v4",
                    "paper_6v4_equal random 6v4"):
        assert [f"{players} / {a}" for a in ("shortest-path", "hj", "random")] == [
            label for label in labels if label.startswith(players + " /")]
    equal = next(c for c in suite.cells if c.label.startswith("paper_6v4_equal random"))
    assert equal.scenario.defender_speed == equal.scenario.attacker_speed
    assert all(c.episodes == 1 for c in suite.cells
               if c.scenario.attackers is not None and c.attackers != "random")


def test_policies_follow_the_protocol(policy_folder):
    scenario = builtin_scenario("paper_2v1")
    assert isinstance(make_policy("defenders", "tmpmod:Mine", scenario), Policy)


def test_the_guides_name_every_built_in_and_their_policy_file_plays(tmp_path, capsys,
                                                                    monkeypatch):
    environment = (ROOT / "docs" / "environment.md").read_text()
    assert all(f"`{name}`" in environment for name in builtin_names())
    defenders = (ROOT / "docs" / "defenders.md").read_text()
    section = defenders[defenders.index("## Benchmark your defender"):]
    (tmp_path / "mine.py").write_text(section.split("```python\n")[1].split("```")[0])
    monkeypatch.syspath_prepend(str(tmp_path))
    assert main(["bench", "--defenders", "mine:Intercept,greedy", "--attackers", "straight",
                 "--config", "3v2", "--episodes", "2", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert {r["defenders"] for r in report["rows"]} == {"mine:Intercept", "greedy"}


def still_scheme(side: str, spec: str) -> NamedPolicy:
    """A spec scheme for the test: ``still:ANYTHING`` is a defender that stands still."""
    return NamedPolicy(f"standing still ({spec})", scenario_free(IdleDefender))


def test_a_spec_scheme_resolves_in_one_place(monkeypatch):
    monkeypatch.setitem(SCHEMES, "still", "test_bench:still_scheme")
    assert resolve("defenders", "still:here").help == "standing still (still:here)"
    scenario = builtin_scenario("paper_2v1")
    assert isinstance(make_policy("defenders", "still:there", scenario), IdleDefender)
    monkeypatch.setitem(SCHEMES, "gone", "test_bench:no_such_function")
    with pytest.raises(ValueError, match="defenders scheme 'gone': module 'test_bench' has no"):
        resolve("defenders", "gone:x")
