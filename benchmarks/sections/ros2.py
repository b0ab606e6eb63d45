"""The results page's section for `benchmarks/bench_ros2.py`."""

from __future__ import annotations

from . import Json, Results, Row, Section
from ._markdown import host_line, num, span, table


def _ros2(d: Json) -> list[str]:
    return table(["figure", "ours", "bare rclpy", "ratio (range over rounds)", "target"], [
        ["one-way latency p50, 115 B at 200 Hz", f"{d['p50_us']:.0f} us",
         f"{d['bare_p50_us']:.0f} us",
         f"{num(d['p50_ratio'])} ({span(d['p50_ratio_range'])})", "<= 1.2"],
        ["one-way latency p99", f"{d['p99_us']:.0f} us", f"{d['bare_p99_us']:.0f} us",
         f"{num(d['p99_ratio'])} ({span(d['p99_ratio_range'])})", "<= 1.5"],
        ["square under ros2 at full speed, real-time factor", num(d["square_rtf"]), "-", "-",
         "-"],
        *([[f"square under ros2 at 3x beside {b['busy_loops']} busy loops: exit code, reason, "
            "real-time factor", f"{b['exit_code']}, {b['reason']}, {num(b['rtf'])}", "-", "-",
            "exit 0, landed"]] if (b := d.get("square_beside_busy_loops")) else []),
    ]) + host_line(None, d.get("load_avg_1min"))


def _headline(r: Results) -> list[Row]:
    ros2 = r["ros2"]
    return [["ROS 2 one-way latency between processes (Fast DDS), p50 / p99",
             f"{ros2['p50_us']:.0f} / {ros2['p99_us']:.0f} us",
             f"bare rclpy (ratio {num(ros2['p50_ratio'])} / {num(ros2['p99_ratio'])})"]]


SECTIONS = {
    "ros2": Section(
        "ROS 2 transport: latency against bare rclpy",
        "Ping-pong between two processes on rclpy with Fast DDS (localhost), through our "
        "transport and through bare rclpy side by side, in alternating rounds.",
        body=_ros2, headline=_headline),
}
