"""Train one attacker with Stable-Baselines3 PPO against the HJ defenders, evaluate it
against random and shortest-path attackers on the same seeded starts, and record a video.

The recipe lives in ``reachavoid.training.single`` (its docstring and docs/training.md
say what every flag does); this script runs it:

    python examples/train_attacker_sb3.py --out runs/attacker
    python examples/train_attacker_sb3.py --evaluate-only runs/attacker/model.zip
"""

from __future__ import annotations

import sys

from reachavoid.training.single import main

if __name__ == "__main__":
    try:
        main()
    except KeyboardInterrupt:
        sys.exit(130)
