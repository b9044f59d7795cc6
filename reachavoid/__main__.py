"""``python -m reachavoid`` and the ``reachavoid`` console script: the command (``cli``) is
imported here, so that Ctrl-C while its libraries load ends like Ctrl-C during the work
(one line, status 130), not with a traceback."""

from __future__ import annotations

import sys
from collections.abc import Sequence


def main(argv: Sequence[str] | None = None) -> int:
    """Import the command and run it; returns the exit status."""
    try:
        from reachavoid.cli import main as run
    except KeyboardInterrupt:
        print("reachavoid: interrupted", file=sys.stderr)
        return 130
    return run(argv)


if __name__ == "__main__":
    sys.exit(main())
