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


def _lockstep(d: Json) -> list[str]:
    after, before = d["lockstep_mission"], d.get("lockstep_mission_before")
    ros2, alone = after["ros2"], after["in_process"]
    names = [n for n in ros2["cpu_per_sim_s"] if n != "launcher"] + ["launcher"]
    was = before["ros2"]["cpu_per_sim_s"] if before else {}
    head = ["process", *([f"before ({before['commit']})"] if before else []),
            f"now ({after['commit']})"]
    rows = [[n, *([num(was[n], 3)] if before else []), num(ros2["cpu_per_sim_s"][n], 3)]
            for n in names]
    rows.append(["**all, under ros2**",
                 *([f"**{num(before['ros2']['cpu_per_sim_s_total'], 3)}**"] if before else []),
                 f"**{num(ros2['cpu_per_sim_s_total'], 3)}**"])
    rows.append(["the same slice in one process",
                 *([num(before["in_process"]["cpu_per_sim_s_total"], 3)] if before else []),
                 num(alone["cpu_per_sim_s_total"], 3)])
    rtf = (f"Real-time factors: under ros2, the simulator's own (from its first /clock), "
           f"{num(ros2['rtf'])} at a 1-min load of {after['load_avg_1min']:g} (the host's "
           "2 cores: a load above 2 lowers it)" + (f" (before: {num(before['ros2']['rtf'])} at "
                                          f"{before['load_avg_1min']:g})" if before else "")
           + f"; in one process, from the command's start, {num(alone['rtf'])}. The "
             "launcher's figure (about 0) shows the method's noise.")
    return [f"CPU seconds per simulated second, the first {after['slice_s']:g} s of the "
            "mission, start-up taken out:", "", *table(head, rows), rtf, ""]


def _mission_headline(r: Results) -> list[Row]:
    d = r.get("ros2_lockstep_mission")
    if not d:
        return []
    ros2, alone = d["lockstep_mission"]["ros2"], d["lockstep_mission"]["in_process"]
    return [["the whole mission over ROS 2 in lockstep at full speed: real-time factor",
             f"{num(ros2['rtf'])} (in process {num(alone['rtf'])}; "
             f"{num(ros2['cpu_per_sim_s_total'], 2)} CPU-s per simulated s)",
             "target 2 on 2 idle cores"]]


SECTIONS = {
    "ros2": Section(
        "ROS 2 transport: latency against bare rclpy",
        "Ping-pong between two processes on rclpy with Fast DDS (localhost), through our "
        "transport and through bare rclpy side by side, in alternating rounds.",
        body=_ros2, headline=_headline),
    "ros2_lockstep": Section(
        "ROS 2 transport: what the lockstep mission costs",
        "The mission's first simulated seconds under `--transport ros2` at full speed, every "
        "node process in lockstep with the simulator, against the same slice in one "
        "process: each process's CPU (user + system, threads included) per simulated "
        "second, the start-up (a 2 s run's CPU) taken out; before and after the lockstep's "
        "cuts (docs/processes.md, \"What the lockstep costs\").",
        body=_lockstep),
    "ros2_lockstep_mission": Section(
        "ROS 2 transport: the whole lockstep mission at full speed",
        "`quadmission launch config/launch/mission.yaml --transport ros2 --rtf 1000` to the "
        "mission's end (default arena, seed 0), every node process in lockstep with the "
        "simulator, beside the same mission in one process (`bench_ros2.py --lockstep-only "
        "--slice 600`): the real-time factor it reaches and each process's CPU per "
        "simulated second.",
        body=_lockstep, headline=_mission_headline),
}
