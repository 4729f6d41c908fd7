"""Render every built-in scene, and every bench family's video scene, with every available model side by side:
``{out}/{scene}.mp4`` and ``{out}/{family}.mp4``.

Usage::

    python scripts/render_all.py --out videos --seconds 4
    python scripts/render_all.py --out videos --scenes --families pulley    # the pulley only, its own length
"""

import argparse
import sys
from pathlib import Path

from mjcable import render, scenes
from mjcable.bench import videos


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="videos", help="output folder (default: videos)")
    parser.add_argument("--seconds", type=float, default=None,
                        help="simulated seconds per video (default 4 for the scenes, the family's own for a family)")
    parser.add_argument("--scenes", nargs="*", default=list(scenes.names()), choices=scenes.names())
    parser.add_argument("--families", nargs="*", default=list(videos.names()), choices=videos.names(),
                        help="bench families' videos (mjcable.bench.videos)")
    args = parser.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    failed = False
    jobs = [(name, name, None) for name in args.scenes]
    jobs += [(name, videos.get(name).make_scene(), name) for name in args.families]
    for name, scene, family in jobs:
        models, problems = render.available_models(scene)
        for model, exc in problems.items():
            failed = True
            print(f"{name}: model {model!r} left out: {type(exc).__name__}: {exc}", file=sys.stderr)
        if not models:
            continue
        if family is None:
            print(render.render_grid(scene, models, out / f"{name}.mp4", seconds=args.seconds or 4.0))
        else:
            print(videos.render(family, models, out / f"{name}.mp4", seconds=args.seconds))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
