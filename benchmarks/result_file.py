"""The result file every benchmark writes: one JSON record under ``benchmarks/results/``.

``BENCHMARKS.md`` quotes only figures that such a file holds (its dashboard rows name the
file and the keys; ``tests/test_docs.py`` checks each quoted number against them). A
record (schema 1) is::

    {"schema": 1, "benchmark": "policy_latency", "command": "python benchmarks/...",
     "machine": "...", "date": "2026-12-03", "commit": "be90688", "source": "measured",
     "units": {"p50_ms": "what the numbers are"}, "figures": {"p50_ms.hj.paper_8v4": 0.75}}

``figures`` maps dotted keys to a number or a list of numbers (a value with its interval:
``[value, low, high]``); ``units`` says, per leading key, what they measure. Scripts take
``--json PATH`` and write this record there (atomically, ``reachavoid_env.files``); to
refresh the dashboard, write it to ``benchmarks/results/NAME.json`` and update the row.
"""

from __future__ import annotations

import datetime
import os
import platform
import shlex
import sys

from harness import ROOT, commit_of

from reachavoid_env.files import write_json

SCHEMA = 1


def machine() -> str:
    """The machine in words: CPU count, processor, memory, the load average now."""
    cpus = os.cpu_count() or 0
    words = [f"{cpus}-core {platform.machine()}", platform.processor() or platform.system()]
    try:
        pages = os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
        words.append(f"{pages / 2**30:.0f} GiB")
    except (ValueError, OSError, AttributeError):
        pass
    if hasattr(os, "getloadavg"):
        words.append(f"load average {os.getloadavg()[0]:.1f} at the end")
    return ", ".join(word for word in words if word)


def commit() -> str:
    """The checkout's short commit hash (``+dirty`` with uncommitted changes), or why not."""
    return commit_of(ROOT) or "unknown (not a git checkout)"


def write_result(path: str | os.PathLike[str], benchmark: str,
                 figures: dict[str, float | list[float]], units: dict[str, str]) -> None:
    """Write one benchmark's record to ``path`` (the schema above).

    Args:
        path: destination, usually ``benchmarks/results/NAME.json``.
        benchmark: the script's name without ``.py``.
        figures: dotted key -> number, or [value, low, high] for a value with its interval.
        units: leading key -> what its numbers measure, in words.
    """
    record = {
        "schema": SCHEMA,
        "benchmark": benchmark,
        "command": shlex.join(["python", *sys.argv]),
        "machine": machine(),
        "date": datetime.datetime.now(datetime.timezone.utc).date().isoformat(),
        "commit": commit(),
        "source": "measured",
        "units": units,
        "figures": {key: (round(value, 6) if isinstance(value, float)
                          else [round(v, 6) for v in value] if isinstance(value, list)
                          else value)
                    for key, value in figures.items()},
    }
    write_json(path, record)
