"""Render every built-in scene with every available model side by side: ``{out}/{scene}.mp4``.

Usage::

    python scripts/render_all.py --out videos --seconds 4
"""

import argparse
import sys
from pathlib import Path

from mjcable import render, scenes


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="videos", help="output folder (default: videos)")
    parser.add_argument("--seconds", type=float, default=4.0, help="simulated seconds per video (default 4)")
    parser.add_argument("--scenes", nargs="+", default=list(scenes.names()), choices=scenes.names())
    args = parser.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    failed = False
    for scene in args.scenes:
        models, problems = render.available_models(scene)
        for model, exc in problems.items():
            failed = True
            print(f"{scene}: model {model!r} left out: {type(exc).__name__}: {exc}", file=sys.stderr)
        if models:
            print(render.render_grid(scene, models, out / f"{scene}.mp4", seconds=args.seconds))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
