"""The seven cable models in the Jaco lab doing the same scripted unplug: a labelled video grid and the pin forces.

Every model runs the ``jaco_unplug`` environment (:mod:`mjcable.envs.jaco_unplug`, same seed, so the same target)
under the same open-loop policy, :func:`mjcable.envs.jaco_unplug.retreat_action`: the arm's shoulder and elbow
targets ramp over :data:`~mjcable.envs.jaco_unplug.RETREAT_RAMP` seconds to :data:`~mjcable.envs.jaco_unplug.RETREAT`,
drawing the hand about 0.24 m back from the wall, which pulls the plug out of the socket. The models step in lock
step, one Simulator step (:data:`~mjcable.envs.jaco_unplug.DT`, the control step here) at a time, so that the pin
forces are sampled at every step; a frame is taken whenever the next frame time ``k / fps`` is reached.

Writes, under ``--out`` (created if missing), each file atomically (a temporary file in the folder replaced into
place, :mod:`mjcable.io`):

* ``jaco_compare.mp4``: the ``overview`` camera, one labelled tile per model (:mod:`mjcable.render.grid`);
* ``pin_forces.png``: the magnitude (N) of the force of the hand's pin and of the socket's pin on the cable against
  time (s) (:attr:`mjcable.Simulator.pin_forces` after every step), one line per model, the socket's release force
  dashed. The socket lets go inside the step in which the solver's force on it exceeds the release force, and a
  released pin reads zero, so a socket's line drops to zero from its last value below the release force;
* ``pin_forces.csv``: the same numbers, one row per step and model (``model,time_s,hand_N,socket_N,
  released``).

A model that diverges (:class:`mjcable.SimulationDivergedError`) stops there: its tile says so, its lines end, the
error goes to stderr and the exit status is 1.

Usage::

    MUJOCO_GL=egl python scripts/jaco_compare.py --out jaco_compare     # 3 s, 240x180 tiles, 15 fps: about 2.5 min
    python scripts/jaco_compare.py --out out --models joints xpbd --seconds 1 --width 96 --height 72 --fps 10
"""

from __future__ import annotations

import argparse
import csv
import os
import sys
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np  # noqa: E402

import mjcable  # noqa: E402
from mjcable import catalog, envs  # noqa: E402
from mjcable.envs import jaco_unplug as ju  # noqa: E402
from mjcable.io import atomic_write  # noqa: E402
from mjcable.render.grid import compose, grid_layout  # noqa: E402
from mjcable.render.camera import scene_pixel_size  # noqa: E402
from mjcable.render.overlays import add_centreline, draw_label  # noqa: E402
from mjcable.render.video_io import write_video  # noqa: E402
from mjcable.worlds import jaco  # noqa: E402

VIDEO, PLOT, TABLE = "jaco_compare.mp4", "pin_forces.png", "pin_forces.csv"
MIN_CABLE_PX = 1.5  # the least radius in pixels the cable is drawn with (it is thinner than a pixel in small tiles)
_HAND, _SOCKET = 0, 1  # pin indices of jaco_unplug's scene (the hand's body pin, the socket)


class Run:
    """One model's episode: the environment, the pin force magnitudes per control step, and its end."""

    def __init__(self, model: str, *, seed: int, seconds: float):
        self.model = model
        self.seconds = seconds
        # one Simulator step per control step, so that the forces are sampled at every step (the release peak shows)
        self.env = envs.load(ju.JacoUnplug.name, model, random=seed, time_limit=seconds, control_timestep=ju.DT)
        self.env.reset()
        self.times, self.hand, self.socket, self.released = [], [], [], []
        self.error = None  # the SimulationDivergedError that stopped it
        self._record()

    def _record(self) -> None:
        physics = self.env.physics
        forces = np.linalg.norm(physics.simulator.pin_forces, axis=1)
        self.times.append(physics.time())
        self.hand.append(float(forces[_HAND]))
        self.socket.append(float(forces[_SOCKET]))
        self.released.append(physics.released())

    def advance_to(self, t: float) -> None:
        """Control steps until the episode time reaches ``t`` seconds (to within half a step), or it ends."""
        dt = self.env.control_timestep()
        physics = self.env.physics
        while self.error is None and physics.time() + 0.5 * dt < t and physics.time() + 0.5 * dt < self.seconds:
            try:
                self.env.step(ju.retreat_action(physics.time() + dt))
            except mjcable.SimulationDivergedError as exc:
                self.error = exc
                print(f"jaco_compare: {self.model}: {exc}", file=sys.stderr)
                return
            self._record()

    def frame(self, height: int, width: int) -> np.ndarray:
        def draw_cable(physics, scn) -> None:  # the centreline, at least MIN_CABLE_PX in radius (as render_env)
            points = physics.centreline()
            pixel = scene_pixel_size(scn, points.mean(axis=0), height)
            add_centreline(scn, points, max(physics.scene.cable.radius, MIN_CABLE_PX * pixel))

        image = np.array(self.env.physics.render(height, width, camera_id=jaco.CAMERA, scene_callback=draw_cable))
        label = self.model if self.error is None else f"{self.model}: diverged"
        if self.released[-1]:
            label += "  (out)"
        draw_label(image, label, corner="left")
        draw_label(image, f"{self.times[-1]:.2f} s", corner="right")
        return image


def _frames(runs, *, seconds: float, fps: int, height: int, width: int):
    layout = grid_layout(len(runs))
    for k in range(max(1, int(round(seconds * fps)))):
        for run in runs:
            run.advance_to(k / fps)
        yield compose([run.frame(height, width) for run in runs], layout)


def write_plot(runs, path: Path) -> Path:
    """The pin force magnitudes against time, one line per model (hand above, socket below), as a PNG."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib import pyplot as plt

    fig, (top, bottom) = plt.subplots(2, 1, sharex=True, figsize=(8.0, 6.0), constrained_layout=True)
    for run in runs:
        line, = top.plot(run.times, run.hand, label=run.model + (" (diverged)" if run.error else ""))
        bottom.plot(run.times, run.socket, color=line.get_color())
    bottom.axhline(ju.RELEASE_FORCE, color="k", linestyle="--", linewidth=1.0, label="release force")
    top.set_ylabel("hand pin force (N)")
    bottom.set_ylabel("socket pin force (N)")
    bottom.set_xlabel("time (s)")
    top.set_title("jaco_unplug, scripted retreat: pin force magnitudes")
    top.legend(fontsize="small", ncol=2)
    bottom.legend(fontsize="small")
    for ax in (top, bottom):
        ax.grid(True, alpha=0.3)
    with atomic_write(path, "wb") as f:
        fig.savefig(f, format="png", dpi=100)
    plt.close(fig)
    return path


def write_table(runs, path: Path) -> Path:
    with atomic_write(path, newline="") as f:
        writer = csv.writer(f)
        writer.writerow(["model", "time_s", "hand_N", "socket_N", "released"])
        for run in runs:
            for row in zip(run.times, run.hand, run.socket, run.released):
                writer.writerow([run.model, f"{row[0]:.4f}", f"{row[1]:.6g}", f"{row[2]:.6g}", int(row[3])])
    return path


def _even(value: str) -> int:
    n = int(value)
    if n < 16 or n % 2:
        raise argparse.ArgumentTypeError(f"must be an even number of pixels >= 16, got {value}")
    return n


def _positive(kind):
    def check(value: str):
        x = kind(value)
        if not x > 0:
            raise argparse.ArgumentTypeError(f"must be > 0, got {value}")
        return x

    return check


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("jaco_compare"), help="output folder (default jaco_compare)")
    parser.add_argument("--models", nargs="+", default=list(catalog.names()), choices=catalog.names(),
                        help="models to compare (default: all seven)")
    parser.add_argument("--seconds", type=_positive(float), default=3.0, help="simulated seconds (default 3)")
    parser.add_argument("--fps", type=_positive(int), default=15, help="video frames per second (default 15)")
    parser.add_argument("--width", type=_even, default=240, help="tile width in pixels (default 240)")
    parser.add_argument("--height", type=_even, default=180, help="tile height in pixels (default 180)")
    parser.add_argument("--seed", type=int, default=0, help="environment seed (the target; default 0)")
    parser.add_argument("--no-video", action="store_true", help="only the pin forces (no rendering)")
    args = parser.parse_args(argv)

    args.out.mkdir(parents=True, exist_ok=True)
    runs = [Run(model, seed=args.seed, seconds=args.seconds) for model in args.models]
    if args.no_video:
        for run in runs:
            run.advance_to(args.seconds)
    else:
        layout = grid_layout(len(runs))
        print(write_video(args.out / VIDEO, _frames(runs, seconds=args.seconds, fps=args.fps, height=args.height,
                                                    width=args.width),
                          fps=args.fps, shape=layout.shape(args.height, args.width)))
        for run in runs:  # the rest of the episode after the last frame
            run.advance_to(args.seconds)
    print(write_plot(runs, args.out / PLOT))
    print(write_table(runs, args.out / TABLE))
    for run in runs:
        out = next((t for t, r in zip(run.times, run.released) if r), None)
        print(f"{run.model:10s} peak hand {max(run.hand):6.2f} N, peak socket {max(run.socket):6.2f} N, "
              + ("plug out at %.2f s" % out if out is not None else "plug still in")
              + (f", DIVERGED at {run.times[-1]:.2f} s" if run.error else ""))
    return 1 if any(run.error for run in runs) else 0


if __name__ == "__main__":
    sys.exit(main())
