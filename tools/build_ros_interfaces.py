"""Build px4_msgs and quadmission_interfaces as ROS 2 packages into the running virtualenv.

    .venv/bin/python tools/build_ros_interfaces.py            build unless the stamp is current
    .venv/bin/python tools/build_ros_interfaces.py --force    build anyway

Run by ``make``'s set-up after pip has installed the ``ros2`` extra. Afterwards any Python
program of the venv can ``from px4_msgs.msg import VehicleOdometry`` with no variables set.
The workspace (generated package.xml/CMakeLists.txt, colcon's build, install and log) is
``build/ros_interfaces`` beside this repository's sources, outside the venv. The logic is in
``interfaces/ros_packages.py``; this script only reports.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from interfaces.errors import InterfaceError  # noqa: E402
from interfaces.ros_packages import ROS_PACKAGES, ensure_built  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--workspace", type=Path, default=ROOT / "build" / "ros_interfaces",
                        help="colcon workspace, outside the venv (default: %(default)s)")
    parser.add_argument("--force", action="store_true", help="build even if the stamp is current")
    args = parser.parse_args(argv)
    start = time.monotonic()
    try:
        result = ensure_built(args.workspace, force=args.force)
    except InterfaceError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    for path in result.patched_exports:
        print(f"patched Python include directories in {path}")
    names = " and ".join(ROS_PACKAGES)
    if result.built:
        print(f"built {names} ({result.installed_files} files installed into {sys.prefix}) "
              f"in {time.monotonic() - start:.0f} s")
    else:
        print(f"{names} are current (stamp {result.digest[:12]})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
