"""Train the ``learned-mappo`` defenders (MAPPO with TorchRL, ``rl`` extra) and write
their actor as the weights file the registry plays (``policies/mappo.py``).

The recipe and its flags live in ``reachavoid.training.mappo`` (its docstring and
docs/training.md say what they do); this script runs it:

    python examples/train_defender_mappo.py --out policies/weights/learned_mappo.npz
"""

from __future__ import annotations

import sys

from reachavoid.training.mappo import main

if __name__ == "__main__":
    try:
        main()
    except KeyboardInterrupt:
        sys.exit(130)
