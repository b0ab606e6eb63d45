"""Crash-safe recording: the issue's done-when, measured.

    python benchmarks/bench_bag_kill.py --out benchmarks/results/bag_kill.json

Runs ``quadmission sim --scenario square --rtf 1 --record --out DIR``, kills it with
SIGKILL after ``--kill-after`` seconds (32), then: ``quadmission bag info`` (the file has
no summary), ``quadmission bag repair``, and rosbags' ``AnyReader`` reads every message
back. Reports the span of messages read (target >= 29 s), the messages kept, the bytes
of cut tail dropped, and, beside them, the simulated time the run had reached when it
was killed (its last progress line, every 5 s), so what the kill lost is visible. The
span depends on the host keeping up with real time: measure on an idle machine.
"""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from _harness import OPTIONAL, bench_parser, load_1min, write_result
from rosbags.highlevel import AnyReader

import interfaces
from ground_station.bag import bag_info, repair_bag

TARGET_SPAN_S = 29.0


def bench(kill_after_s: float) -> dict[str, Any]:
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "run"
        env = os.environ | {"MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
        started = time.monotonic()
        proc = subprocess.Popen([sys.executable, "-m", "quadmission.cli", "sim", "--scenario",
                                 "square", "--rtf", "1", "--record", "--out", str(out)],
                                stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, env=env,
                                text=True)
        time.sleep(kill_after_s)
        proc.send_signal(signal.SIGKILL)
        _, err = proc.communicate()
        wall = time.monotonic() - started
        reached = [float(m) for m in re.findall(r"t=\s*([0-9.]+) s", err)]
        before = bag_info(out / "bag")
        repaired = repair_bag(out / "bag")
        after = bag_info(out / "bag")
        stamps: list[int] = []
        with AnyReader([out / "bag"], default_typestore=interfaces.typestore()) as reader:
            for connection, t_ns, raw in reader.messages():
                reader.deserialize(raw, connection.msgtype)
                stamps.append(t_ns)
        span = (max(stamps) - min(stamps)) / 1e9 if stamps else 0.0
        return {
            "killed_after_s": round(wall, 2),
            "indexed_before_repair": before.indexed,
            "indexed_after_repair": after.indexed,
            "messages_before_repair": before.message_count,
            "messages_kept": repaired.messages,
            "messages_read_by_anyreader": len(stamps),
            "topics": repaired.topics,
            "bytes_dropped": repaired.bytes_dropped,
            "span_read_s": round(span, 3),
            "target_span_s": TARGET_SPAN_S,
            "ok": after.indexed and span >= TARGET_SPAN_S,
            "last_progress_sim_s": max(reached) if reached else None,
            "load_average_1min": load_1min(),
        }


def main() -> None:
    parser = bench_parser(__doc__, OPTIONAL)
    parser.add_argument("--kill-after", type=float, default=32.0)
    args = parser.parse_args()
    print(write_result(args.out, bench(args.kill_after)), end="")


if __name__ == "__main__":
    main()
