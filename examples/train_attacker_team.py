"""Train a team of attackers that share one Stable-Baselines3 PPO policy against the HJ
defenders, and compare it with the scripted and random teams on the same seeded starts.

The recipe lives in ``reachavoid.training.recipe`` (its docstring and docs/training.md
say what every flag does); this script runs it:

    python examples/train_attacker_team.py --scenario paper_2v1 --imitate-from hj-pairs \\
        --imitate-steps 40000 --full-speed --out runs/team_2v1
"""

from __future__ import annotations

import sys
from pathlib import Path

from reachavoid.training.config import ModelError
from reachavoid.training.recipe import main

if __name__ == "__main__":
    try:
        main()
    except ModelError as err:
        print(f"{Path(sys.argv[0]).name}: error: {err}", file=sys.stderr)
        sys.exit(2)
    except KeyboardInterrupt:
        sys.exit(130)
