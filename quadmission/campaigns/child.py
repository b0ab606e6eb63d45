"""A campaign cell's process: ``quadmission sim ...`` that dies with the worker running it.

``python -m quadmission.campaigns.child PARENT_PID sim ...`` asks Linux to kill it when
its parent (the worker's thread that waits for it) goes (``PR_SET_PDEATHSIG``), so a run
whose worker is lost stops too, and the re-queued run does not share its folder with an
orphan. Then it is :func:`quadmission.cli.main`, the command the replay line names.
"""

from __future__ import annotations

import ctypes
import os
import signal
import sys

PR_SET_PDEATHSIG = 1  # linux/prctl.h
EXIT_ORPHAN = 3  # the parent was gone before the process could tie itself to it


def _die_with_parent(parent_pid: int) -> bool:
    """Tie this process's life to its parent's; False when the parent is already gone."""
    if sys.platform.startswith("linux"):
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(PR_SET_PDEATHSIG, signal.SIGKILL)
    return os.getppid() == parent_pid


def main(argv: list[str]) -> int:
    if not _die_with_parent(int(argv[0])):
        return EXIT_ORPHAN
    from quadmission.cli import main as cli_main

    return cli_main(argv[1:])


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
