"""docs/training-code.md's scripts on ReachAvoid-v2 (examples/, imported by nothing), each
run as a command at a tiny budget with the sparse reward: the run ends (``done``) and it
saw a reward other than 0, that is, a capture or an arrival."""

from __future__ import annotations

import re
import subprocess
import sys

import pytest
from checks import ENV, ROOT

RUNS = {
    "sb3_supersuit_v2": ["--timesteps", "3000", "--copies", "2", "--n-steps", "64"],
    "cleanrl_ppo_discrete": ["--total-timesteps", "4000", "--copies", "2", "--num-steps",
                             "128"],
    "torchrl_v2-one": ["--groups", "one", "--iterations", "2", "--frames", "500",
                       "--minibatch", "250"],
    "torchrl_v2-teams": ["--groups", "teams", "--iterations", "2", "--frames", "500",
                         "--minibatch", "250"],
}


@pytest.mark.parametrize("run", sorted(RUNS))
def test_the_script_sees_a_reward_and_ends(run):
    pytest.importorskip("supersuit" if "torchrl" not in run else "torchrl")
    script = ROOT / "examples" / f"{run.split('-')[0]}.py"
    done = subprocess.run([sys.executable, str(script), "--reward", "sparse", *RUNS[run]],
                          capture_output=True, text=True, timeout=300, cwd=ROOT,
                          env={**ENV, "PYTHONPATH": str(ROOT)})
    assert done.returncode == 0, done.stderr[-2000:]
    lines = done.stdout.strip().splitlines()
    assert lines[-1] == "done"
    seen = [float(number) for line in lines
            for number in re.findall(r"(?:reward seen|attacker|defender|agents) ([\d.e+-]+)",
                                     line)]
    assert seen and max(seen) > 0, done.stdout
