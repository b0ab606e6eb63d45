"""The launch files' comments name only ``--transport`` values the CLI accepts.

A comment such as ``--transport dds`` runs it "on Cyclone DDS" outlives the transport it
names; each value a comment of ``config/launch/*.yaml`` gives ``--transport`` is parsed by
the CLI's own parser (``quadmission launch FILE --transport VALUE``), so the accepted
values are never retyped here.
"""

from __future__ import annotations

import contextlib
import io
import re
from pathlib import Path

from quadmission.cli import build_parser

ROOT = Path(__file__).resolve().parents[2]
LAUNCH_FILES = sorted((ROOT / "config" / "launch").glob("*.yaml"))
TRANSPORT = re.compile(r"--transport[= ]+`?([\w.-]+)")


def accepted(transport: str) -> bool:
    """Whether ``quadmission launch FILE --transport transport`` parses."""
    argv = ["launch", "config/launch/example.yaml", "--transport", transport]
    with contextlib.redirect_stderr(io.StringIO()):
        try:
            build_parser().parse_args(argv)
        except SystemExit:
            return False
    return True


def named_transports() -> list[tuple[str, int, str]]:
    """(file, line, value) for every ``--transport VALUE`` in a launch file's comments."""
    found = []
    for path in LAUNCH_FILES:
        for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            _, hash_, comment = line.partition("#")
            if hash_:
                found += [(str(path.relative_to(ROOT)), number, value)
                          for value in TRANSPORT.findall(comment)]
    return found


def test_the_check_asks_the_cli_which_transports_it_accepts() -> None:
    default = build_parser().parse_args(["launch", "config/launch/example.yaml"]).transport
    assert accepted(default), f"the CLI's own default transport {default!r} reads as refused"
    assert not accepted("no-such-transport"), "a transport the CLI refuses reads as accepted"


def test_every_transport_a_launch_file_comment_names_is_accepted() -> None:
    named = named_transports()
    assert {file for file, _, _ in named} >= {"config/launch/companion.yaml",
                                              "config/launch/mission.yaml",
                                              "config/launch/square.yaml"}, named
    refused = [f"{file}:{line}: --transport {value}" for file, line, value in named
               if not accepted(value)]
    assert not refused, ("launch file comments name transports the CLI refuses (see "
                         "quadmission launch --help):\n" + "\n".join(refused))
