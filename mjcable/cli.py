"""The ``mjcable`` command: argument parsing only; the work is done by the library.

Subcommands::

    mjcable demo                                   side-by-side video of every available model on the table scene,
                                                   then of those that simulate several cables on the Y-harness
    mjcable render --scene S --model M -o out.mp4  one model (or several side by side, or "all") on a built-in scene
    mjcable render --env TASK --model M --policy random -o out.mp4   an episode of a dm_control task (mjcable.envs)
    mjcable render --family F --model M -o out.mp4 a bench family's video (mjcable.bench.videos: pulley)
    mjcable export [--out models] [--check]        MJCF of every native model x built-in scene
    mjcable bench [--quick] [--out DIR] [--jobs N | --scheduler ADDRESS] [--models ...]
                                                   work-precision benchmarks (mjcable.bench) on a Dask cluster
    mjcable stress [--quick] [--out DIR] [--jobs N | --scheduler ADDRESS] [--models ...]
                                                   stability stress tests (mjcable.bench) on a Dask cluster

Exit status: 0 on success, 1 when some model failed (the rest still ran), 2 on bad arguments.
"""

from __future__ import annotations

import argparse
import os
import importlib
import sys
import time
from pathlib import Path
from typing import Callable, Dict, Optional, Sequence, Tuple

__all__ = ["main", "build_parser", "demo_selection", "demo_harness_selection", "DEMO_FILE", "DEMO_SCENE",
           "DEMO_HARNESS_SEGMENTS"]

DEMO_FILE = "mjcable-demo.mp4"
DEMO_SCENE = "table"
DEMO_SECONDS = 3.0  # s of video per part: a few minutes of rendering for every model on 2 CPU cores
DEMO_HARNESS_SEGMENTS = 20  # segments per leg of the demo's Y-harness (mjcable.bench.harness.y_harness_scene)
DEMO_TILE = (320, 240)  # pixels per tile (width, height)
RENDER_SIZE = (640, 480)  # pixels (width, height) of `mjcable render` with one model
GRID_TILE = (320, 240)  # pixels per tile of `mjcable render` with several models
RENDER_SECONDS = 5.0  # s of `mjcable render --scene/--env` unless --seconds says
DEFAULT_DT = 0.002  # s, the Simulator's default
EXIT_OK, EXIT_FAILED, EXIT_USAGE = 0, 1, 2


def _positive_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not value > 0 or value == float("inf"):
        raise argparse.ArgumentTypeError(f"expected a finite number > 0, got {text!r}")
    return value


def _folder(text: str) -> str:
    """An output folder: a path that is not an existing file."""
    if os.path.exists(text) and not os.path.isdir(text):
        raise argparse.ArgumentTypeError(f"expected a folder, got {text!r}, an existing file")
    return text


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected an integer >= 1, got {text!r}")
    return value


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``mjcable`` command."""
    from mjcable import __version__, catalog, scenes

    parser = argparse.ArgumentParser(prog="mjcable", description="Cable scenes on MuJoCo: native cable models and "
                                     "Jakobsen/PBD/XPBD solvers, simulated, rendered and compared.")
    parser.add_argument("--version", action="version", version=f"mjcable {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    demo = sub.add_parser("demo", help="side-by-side video of every available model on the table scene, then of "
                          "those that simulate several cables on a Y-harness",
                          description="Render every available cable model on the 'table' scene side by side, then "
                                      "every model that simulates several cables on a Y-harness of three cables (each "
                                      f"in its colour), into an MP4 in the current folder ({DEMO_FILE}) and print its "
                                      "path.")
    demo.add_argument("-o", "--out", default=DEMO_FILE, help=f"video file (default: ./{DEMO_FILE})")
    demo.add_argument("--seconds", type=_positive_float, default=DEMO_SECONDS, help=argparse.SUPPRESS)
    demo.add_argument("--fps", type=_positive_int, default=30, help=argparse.SUPPRESS)
    demo.add_argument("--width", type=_positive_int, default=DEMO_TILE[0], help=argparse.SUPPRESS)
    demo.add_argument("--height", type=_positive_int, default=DEMO_TILE[1], help=argparse.SUPPRESS)
    demo.set_defaults(func=_demo)

    render = sub.add_parser("render", help="render a scene (or a dm_control task) to MP4",
                            description="Render one model, or several side by side, on a built-in scene; or record "
                                        "an episode of a dm_control task from mjcable.envs.")
    source = render.add_mutually_exclusive_group(required=True)
    source.add_argument("--scene", choices=scenes.names(), help="built-in scene")
    source.add_argument("--env", metavar="TASK", help="dm_control task of mjcable.envs (e.g. reach_sag)")
    source.add_argument("--family", metavar="FAMILY", help="a bench family's video scene (mjcable.bench.videos, e.g. "
                                                          "pulley: the rope turning a pulley)")
    render.add_argument("--model", nargs="+", required=True, metavar="MODEL",
                        help=f"one or more of {', '.join(catalog.names())}, or 'all' (every available model); several "
                             "models are rendered side by side")
    render.add_argument("-o", "--out", required=True, help="video file (.mp4)")
    render.add_argument("--seconds", type=_positive_float, default=None,
                        help=f"simulated seconds (default {RENDER_SECONDS:g}; for --family, the family's)")
    render.add_argument("--fps", type=_positive_int, default=30, help="frames per second (default 30)")
    render.add_argument("--width", type=_positive_int, default=None,
                        help=f"width in pixels, per tile (default {RENDER_SIZE[0]}, or {GRID_TILE[0]} side by side)")
    render.add_argument("--height", type=_positive_int, default=None,
                        help=f"height in pixels, per tile (default {RENDER_SIZE[1]}, or {GRID_TILE[1]} side by side)")
    render.add_argument("--dt", type=_positive_float, default=None,
                        help=f"simulation step in seconds (default {DEFAULT_DT}; for --env, the task's)")
    render.add_argument("--camera", default=None,
                        help="'track' (follows the cable; the default but for a --family with its own camera) or a "
                             "camera of the model, e.g. 'overview'")
    render.add_argument("--stripe", action="store_true", help="draw a stripe along the material frame, so that twist "
                        "shows (models with frames: cosserat, joints, composite)")
    render.add_argument("--policy", choices=("random", "zero"), default="random", help="policy for --env (default "
                        "random)")
    render.add_argument("--seed", type=int, default=None, help="seed for --env")
    render.set_defaults(func=_render)

    export = sub.add_parser("export", help="write the MJCF of every native model x built-in scene",
                            description="Write models/{scene}_{model}.xml for every native model and built-in scene.")
    export.add_argument("--out", default="models", help="folder (default: models)")
    export.add_argument("--check", action="store_true", help="also load every file with MuJoCo and dm_control and "
                        "step it 2 s, failing on MuJoCo warnings")
    export.set_defaults(func=_export)

    for name, helptext in (("bench", "work-precision benchmarks of all models (mjcable.bench)"),
                           ("stress", "stability stress tests of all models (mjcable.bench)")):
        # The flags of mjcable.bench.add_arguments, declared here so that mjcable.bench is imported only when used.
        p = sub.add_parser(name, help=helptext, description=helptext)
        p.add_argument("--quick", action="store_true", help="reduced sweep")
        p.add_argument("--out", type=_folder, default=None, help=f"output folder (default: {name}_out)")
        workers = p.add_mutually_exclusive_group()
        workers.add_argument("--jobs", type=_positive_int, default=None,
                             help="worker processes of a local Dask cluster (default: CPU count; 1: no cluster, "
                                  "one run after the other in this process)")
        workers.add_argument("--scheduler", default=None, metavar="ADDRESS",
                             help="run on the existing Dask cluster whose scheduler is at ADDRESS (e.g. "
                                  "tcp://10.0.0.5:8786); this process still writes every output")
        p.add_argument("--models", nargs="+", default=None, metavar="MODEL", help="model labels to run (default all)")
        p.set_defaults(func=_bench_command(name))
    return parser


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Run the ``mjcable`` command with ``argv`` (default: ``sys.argv[1:]``); returns the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except ValueError as exc:  # the library's validation: a usage error
        parser.exit(EXIT_USAGE, f"mjcable {args.command}: error: {exc}\n")


def _report_problems(problems: dict) -> None:
    for model, exc in problems.items():
        print(f"mjcable: model {model!r} failed and was left out: {type(exc).__name__}: {exc}", file=sys.stderr)


def _report_unavailable() -> None:
    """Say which built-in models the installed MuJoCo cannot run (``composite`` on MuJoCo 4) and why."""
    from mjcable import catalog

    for model, reason in catalog.unavailable().items():
        print(f"mjcable: model {model!r} is not available here and was left out: {reason}", file=sys.stderr)


def demo_selection() -> Tuple[str, Tuple[str, ...], Dict[str, Exception]]:
    """What ``mjcable demo`` renders: ``(scene, models, problems)``, the models being every model of the catalogue
    (asked at call time, so a model registered at run time is in it) that builds :data:`DEMO_SCENE`, and
    ``problems`` ``{model: exception}`` those that failed to."""
    from mjcable import render

    models, problems = render.available_models(DEMO_SCENE)
    return DEMO_SCENE, models, problems


def demo_harness_selection() -> Tuple[object, Tuple[str, ...], Dict[str, Exception], Tuple[str, ...]]:
    """The second part of ``mjcable demo``: ``(scene, models, problems, left_out)``, the scene being the Y-harness
    (:func:`mjcable.bench.harness.y_harness_scene`, :data:`DEMO_HARNESS_SEGMENTS` segments per leg), the models every
    model of the catalogue (at call time) that simulates several cables with junctions and builds it, ``problems``
    ``{model: exception}`` those of them that failed to, and ``left_out`` the models without those capabilities."""
    from mjcable import catalog, render
    from mjcable.bench.harness import y_harness_scene

    scene = y_harness_scene(DEMO_HARNESS_SEGMENTS)
    able = tuple(m for m in catalog.names() if catalog.get(m).several_cables and catalog.get(m).junctions)
    left_out = tuple(m for m in catalog.names() if m not in able)
    if not able:
        return scene, (), {}, left_out
    models, problems = render.available_models(scene, models=able)
    return scene, models, problems, left_out


def _demo(args) -> int:
    from mjcable import render

    start = time.perf_counter()
    scene, models, problems = demo_selection()
    _report_unavailable()
    _report_problems(problems)
    if not models:
        print("mjcable demo: no model is available", file=sys.stderr)
        return EXIT_FAILED
    harness, harness_models, harness_problems, left_out = demo_harness_selection()
    _report_problems(harness_problems)
    parts = [(scene, models)]
    print(f"mjcable demo: rendering {', '.join(models)} on the {scene!r} scene ({args.seconds:g} s)", file=sys.stderr)
    if harness_models:
        parts.append((harness, harness_models))
        print(f"mjcable demo: then {', '.join(harness_models)} on a Y-harness of three cables ({args.seconds:g} s)",
              file=sys.stderr)
    if left_out:
        print(f"mjcable demo: the Y-harness leaves out {', '.join(left_out)}: they don't simulate several cables with "
              f"junctions yet", file=sys.stderr)
    path = render.render_parts(parts, Path(args.out), seconds=args.seconds, fps=args.fps,
                               tile_width=args.width, tile_height=args.height)
    problems = {**problems, **harness_problems}
    print(f"mjcable demo: done in {time.perf_counter() - start:.1f} s", file=sys.stderr)
    print(path.resolve())
    return EXIT_FAILED if problems else EXIT_OK


def _render(args) -> int:
    from mjcable import catalog, render

    if args.env is not None:
        return _render_env(args)
    videos = family = None
    if args.family is not None:
        videos = importlib.import_module("mjcable.bench.videos")  # imported here: mjcable.bench is slow to import
        family = videos.get(args.family)
    models = list(args.model)
    problems = {}
    dt = DEFAULT_DT if args.dt is None else args.dt
    if models == ["all"]:
        models, problems = render.available_models(args.scene if family is None else family.make_scene(), dt=dt)
        _report_unavailable()
        _report_problems(problems)
        if not models:
            print("mjcable render: no model is available", file=sys.stderr)
            return EXIT_FAILED
    bad = [m for m in models if m not in catalog.names()]
    if bad:
        raise ValueError(f"--model must be 'all' or names from {catalog.names()}, got {bad}")
    width, height = _size(args, RENDER_SIZE if len(models) == 1 else GRID_TILE)
    if family is not None:
        path = videos.render(family.name, models[0] if len(models) == 1 else models, args.out, seconds=args.seconds,
                             fps=args.fps, width=width, height=height, dt=dt, camera=args.camera, stripe=args.stripe)
    elif len(models) == 1:
        path = render.render_video(args.scene, models[0], args.out, seconds=_seconds(args), fps=args.fps,
                                   width=width, height=height, dt=dt, camera=args.camera or render.TRACK,
                                   stripe=args.stripe)
    else:
        path = render.render_grid(args.scene, models, args.out, seconds=_seconds(args), fps=args.fps,
                                  tile_width=width, tile_height=height, dt=dt, camera=args.camera or render.TRACK,
                                  stripe=args.stripe)
    print(path.resolve())
    return EXIT_FAILED if problems else EXIT_OK


def _render_env(args) -> int:
    from mjcable import render

    if len(args.model) != 1 or args.model[0] == "all":
        raise ValueError(f"--env takes exactly one --model, got {args.model}")
    if args.stripe:
        raise ValueError("--stripe draws on --scene renders; an environment's video (--env) has no stripe")
    envs = importlib.import_module("mjcable.envs")  # imported here: dm_control is slow to import
    settings = {} if args.dt is None else {"dt": args.dt}
    env = envs.load(args.env, args.model[0], random=args.seed, **settings)
    camera = "overview" if args.camera in (None, "track") else args.camera
    width, height = _size(args, RENDER_SIZE)
    path = render.render_env(env, args.out, seconds=_seconds(args), fps=args.fps, width=width, height=height,
                             camera=camera, policy=args.policy, seed=args.seed)
    print(path.resolve())
    return EXIT_OK


def _seconds(args) -> float:
    return RENDER_SECONDS if args.seconds is None else args.seconds


def _size(args, default) -> tuple:
    return (default[0] if args.width is None else args.width, default[1] if args.height is None else args.height)


def _export(args) -> int:
    from mjcable import export

    written = export.export(args.out)
    failed = 0
    for path in written:
        if args.check:
            try:
                export.check_file(path)
            except RuntimeError as exc:
                failed += 1
                print(f"mjcable export: check failed: {exc}", file=sys.stderr)
                continue
        print(path)
    return EXIT_FAILED if failed else EXIT_OK


def _bench_command(name: str) -> Callable[[argparse.Namespace], int]:
    def run(args) -> int:
        bench = importlib.import_module("mjcable.bench")  # imported here: only bench and stress need it
        result = getattr(bench, f"cli_{name}")(args)
        return EXIT_OK if result is None else int(result)

    return run


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
