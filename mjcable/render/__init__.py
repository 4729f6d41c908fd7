"""Offscreen video of cable simulations: one model, or a labelled side-by-side grid of several models of one scene,
or an episode of a dm_control environment.

One module per concern:

* :mod:`~mjcable.render.api`: the public functions (:func:`frames`, :func:`render_video`, :func:`grid_frames`,
  :func:`render_grid`, :func:`render_parts`, :func:`render_env`, :func:`available_models`);
* :mod:`~mjcable.render.tiles`: one simulation and its offscreen renderer per tile, stepped ``1 / fps`` seconds a
  frame; a diverged model's tile freezes, darkens and says so while the others go on;
* :mod:`~mjcable.render.grid`: the layout of tiles in a side-by-side frame;
* :mod:`~mjcable.render.camera`: the tracking camera (``camera="track"``) and checks of camera names;
* :mod:`~mjcable.render.overlays`: the cable's centreline as capsules (:func:`add_centreline`, shared with
  ``mjcable.envs``) and text labels;
* :mod:`~mjcable.render.video_io`: MP4 writing (atomic, streaming) and reading with imageio-ffmpeg's ffmpeg;
* :mod:`~mjcable.render.options`: argument checks.

What a frame shows: the scene as every model builds it (``mjcable/mjcf/world.py``: obstacles, lights, the same
materials), plus each cable's centreline (:attr:`Simulator.positions`) drawn as capsules of its radius in its colour
(:data:`mjcable.mjcf.world.CABLE_COLOURS`), so that every model looks like the same cables; a label (the model's
name) and the simulated time in each tile. :func:`render_parts` puts several scenes' grids one after another into one
video (``mjcable demo``: the table, then the Y-harness).

Example::

    import mjcable
    from mjcable import render

    render.render_video("hang", "springs", "hang.mp4", seconds=3)
    models, problems = render.available_models("table")
    render.render_grid("table", models, "table.mp4", seconds=3)
"""

from mjcable.render.api import (available_models, frames, grid_frames, render_env, render_grid, render_parts,
                                render_video)
from mjcable.render.camera import TRACK
from mjcable.render.overlays import add_centreline, add_stripe
from mjcable.render.video_io import read_video, write_video

__all__ = [
    "frames",
    "grid_frames",
    "render_video",
    "render_grid",
    "render_parts",
    "render_env",
    "available_models",
    "add_centreline",
    "add_stripe",
    "write_video",
    "read_video",
    "TRACK",
]
