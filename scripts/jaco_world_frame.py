"""Save a PNG of the Jaco lab's ``overview`` camera at the ``home`` keyframe (for reviewing the world).

Usage::

    MUJOCO_GL=egl python scripts/jaco_world_frame.py jaco_home.png --width 640 --height 480

The grip and socket_plug sites (group 4, hidden by default) are drawn unless ``--no-sites`` is given. The image is
written atomically (:mod:`mjcable.io`).
"""

import argparse
import os
import sys
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")

import mediapy  # noqa: E402
import mujoco  # noqa: E402

from mjcable.io import atomic_path  # noqa: E402
from mjcable.worlds import jaco  # noqa: E402


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path, help="PNG path to write")
    parser.add_argument("--width", type=int, default=640, help="pixels (default 640)")
    parser.add_argument("--height", type=int, default=480, help="pixels (default 480)")
    parser.add_argument("--arm-control", choices=jaco.ARM_CONTROLS, default="position")
    parser.add_argument("--no-sites", action="store_true", help="hide the group-4 grip and socket_plug sites")
    args = parser.parse_args()

    model = jaco.jaco_lab_spec(args.arm_control).compile()
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key(jaco.HOME_KEY).id)
    mujoco.mj_forward(model, data)
    option = mujoco.MjvOption()
    option.sitegroup[4] = not args.no_sites
    with mujoco.Renderer(model, args.height, args.width) as renderer:
        renderer.update_scene(data, camera=jaco.CAMERA, scene_option=option)
        pixels = renderer.render()

    args.out.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(args.out) as tmp:  # tmp may have no suffix: the format is named
        mediapy.write_image(tmp, pixels, fmt="png")
    grip, socket = jaco.grip_and_socket(model)
    print(f"{args.out}: {args.width}x{args.height}, grip {grip.round(3)} m, socket_plug {socket.round(3)} m, "
          f"distance {float(((grip - socket) ** 2).sum() ** 0.5):.3f} m")
    return 0


if __name__ == "__main__":
    sys.exit(main())
