"""The launch files' comments name only ``--transport`` values the CLI accepts.

A comment such as ``--transport dds`` runs it "on Cyclone DDS" outlives the transport it
names; each value a comment of ``config/launch/*.yaml`` gives ``--transport`` is parsed by
the CLI's own parser (``quadmission launch FILE --transport VALUE``), so the accepted
values are never retyped here. The same comments must not speak of the retired transport
by other words either: "Cyclone", or running "over DDS" / "on DDS" (ROS 2's own
"Fast DDS" and PX4's "uXRCE-DDS" are what the graph runs on and through, and stay).
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
#: Words for the retired Cyclone DDS transport: its name, or DDS as where nodes run (a
#: comment wrapped between the two words still reads as one phrase).
RETIRED = re.compile(r"\bcyclone\b|\b(?:over|on)\s+(?:the\s+)?DDS\b", re.IGNORECASE)

#: Comments of config/launch/mission.yaml at 4ac5417, when it ran on Cyclone DDS.
OLD_MISSION_COMMENTS = """\
# one process (the simulator steps every node in lockstep); `--transport dds` runs the
# simulator (physics, FCU, cameras) and four groups of nodes each in its own process on
# Cyclone DDS, following /clock. It exits 0 once the mission is completed, 1 with the
      # PX4's own filter (100 ms deviation gate; converged stays converged): over DDS a
      # s: over DDS the bridge's time sync sees real round trips and converges later
"""


def accepted(transport: str) -> bool:
    """Whether ``quadmission launch FILE --transport transport`` parses."""
    argv = ["launch", "config/launch/example.yaml", "--transport", transport]
    with contextlib.redirect_stderr(io.StringIO()):
        try:
            build_parser().parse_args(argv)
        except SystemExit:
            return False
    return True


def comments(text: str) -> list[tuple[int, str]]:
    """(line, comment) for every line of a YAML text with a ``#`` comment."""
    found = []
    for number, line in enumerate(text.splitlines(), 1):
        _, hash_, comment = line.partition("#")
        if hash_:
            found.append((number, comment))
    return found


def retired_phrases(text: str) -> list[tuple[int, str]]:
    """(line, phrase) for every phrase of :data:`RETIRED` in a YAML text's comments, the
    comments read as one text so that a phrase wrapped across two lines is found."""
    lines = comments(text)
    joined = "\n".join(comment for _, comment in lines)
    return [(lines[joined.count("\n", 0, match.start())][0], " ".join(match.group().split()))
            for match in RETIRED.finditer(joined)]


def named_transports() -> list[tuple[str, int, str]]:
    """(file, line, value) for every ``--transport VALUE`` in a launch file's comments."""
    found = []
    for path in LAUNCH_FILES:
        for number, comment in comments(path.read_text(encoding="utf-8")):
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


def test_the_retired_transport_check_flags_the_old_texts_and_spares_fast_dds() -> None:
    assert retired_phrases(OLD_MISSION_COMMENTS) == [
        (3, "Cyclone"), (4, "over DDS"), (5, "over DDS")]
    # the --transport check alone caught only the first line
    old_values = [v for _, c in comments(OLD_MISSION_COMMENTS) for v in TRANSPORT.findall(c)]
    assert old_values == ["dds"] and not accepted("dds")
    assert retired_phrases("# each in its own process over\n# DDS, following /clock\n") == [
        (1, "over DDS")]
    spared = ("# node a real rcl node (rclpy on Fast DDS), following /clock\n"
              "# The companion alone, for a real PX4 (v1.17) behind its uXRCE-DDS agent:\n"
              "# PX4 has no Timesync topic since v1.14: the XRCE-DDS session syncs the clocks\n"
              "# through the agent on uXRCE-DDS, over ROS 2 processes\n"
              "key: on DDS  # a value, not a comment\n")
    assert retired_phrases(spared) == []


def test_no_launch_file_comment_speaks_of_the_retired_transport() -> None:
    found = [f"{path.relative_to(ROOT)}:{line}: {phrase!r}" for path in LAUNCH_FILES
             for line, phrase in retired_phrases(path.read_text(encoding="utf-8"))]
    assert not found, ("launch file comments speak of the retired Cyclone DDS transport "
                       "(the process transport is --transport ros2, rclpy on Fast DDS):\n"
                       + "\n".join(found))
