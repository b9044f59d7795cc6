"""The picture in README.md and the docs: step 45 of the main job's video.

Plays the main job (``reachavoid play --scenario paper_6v2 --defenders hj --attackers
shortest-path``, the paper's tubes) into a video in a temporary folder, reads its frame 45
and writes it to ``docs/figures/paper_6v2_frame.png`` (atomically)::

    SDL_VIDEODRIVER=dummy python benchmarks/readme_frame.py
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

import imageio.v3 as iio

from reachavoid_env.files import atomic_write

MAIN_JOB = ("play", "--scenario", "paper_6v2", "--defenders", "hj",
            "--attackers", "shortest-path")
FIGURE = Path(__file__).resolve().parent.parent / "docs" / "figures" / "paper_6v2_frame.png"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--frame", type=int, default=45, help="the frame to keep")
    parser.add_argument("--out", type=Path, default=FIGURE, help="the PNG to write")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        video = Path(folder) / "main_job.mp4"
        subprocess.run([sys.executable, "-m", "reachavoid", *MAIN_JOB, "--video", str(video)],
                       check=True)
        frame = iio.imread(video, index=args.frame)
    with atomic_write(args.out, "wb") as handle:
        iio.imwrite(handle, frame, extension=".png")
    print(f"wrote {args.out} (frame {args.frame}, {frame.shape[1]}x{frame.shape[0]})")


if __name__ == "__main__":
    main()
