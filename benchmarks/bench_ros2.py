"""One-way latency over ROS 2 between two processes: our transport vs bare rclpy; the square's
real-time factor under ROS 2.

    python benchmarks/bench_ros2.py --out benchmarks/results/ros2.json [--duration 10]

The seed's stream (seed 000: 115-byte messages at 200 Hz) as a ping-pong between two
processes on a localhost-only domain (rclpy on Fast DDS, the wheels' rmw_fastrtps_cpp):
the pinger sends at 200 Hz, the echoer sends each message straight back, the pinger takes
half the round trip as the one-way latency (p50, p99, max [us]).

- **ours**: two node processes (:class:`~runtime.processes.executor.ClockedExecutor` on the
  wall clock, :class:`~runtime.ros2.transport.Ros2Transport`): a timer publishes, a
  subscription callback gets the deserialised (rosbags) message and publishes the echo;
  node code as any node writes it. On the wire: our CDR, raw publish / raw subscription.
- **bare**: plain rclpy with the rosidl class (typed publisher and subscription, a timer,
  ``SingleThreadedExecutor``), no runtime of ours: the baseline, measured in the same run,
  in alternating rounds; ``p50_ratio`` and ``p99_ratio`` = ours / bare.
- **conversion**: what converting each message to rclpy's class would cost on top of our
  CDR (``deserialize_message``), against what the raw path costs (rosbags serialize).
- **square_rtf**: ``quadmission launch config/launch/square.yaml --transport ros2`` paced
  at 1000x (as fast as it goes), the simulator's own figure (simulated / wall seconds from
  its first ``/clock`` to the landing).
- **square_beside_busy_loops**: the same launch at ``--rtf 3`` beside two processes that
  each burn a core (``while True: pass``): its exit code and reason (0, landed) and its
  real-time factor. The lockstep keeps the flight valid however starved the processes are;
  the starvation shows as a lower real-time factor.
- **lockstep_mission** (``--lockstep-only`` runs only this): the first ``--slice`` simulated
  seconds of ``mission.yaml`` under ``--transport ros2`` at full speed (every process in
  lockstep with the simulator), and the same slice in one process: CPU seconds (user +
  system, threads included, from ``/proc``) per simulated second for each process and in
  all, with the start-up taken out (a 2 s run's CPU subtracted). CPU per simulated second
  holds on a loaded host, where the real-time factor does not. ``--compare-tree DIR``
  measures another checkout the same way beside it (``lockstep_mission_before``).

The message is ``std_msgs/UInt8MultiArray`` with 99 data bytes: 115 bytes of CDR. The send
time (CLOCK_MONOTONIC, the same in every process) travels in its first 8 data bytes.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import struct
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from _harness import (  # noqa: E402
    OPTIONAL,
    bench_parser,
    children,
    cpu_seconds,
    load_1min,
    process_name,
    write_result,
)

import interfaces  # noqa: E402
from interfaces.qos import QoSProfile  # noqa: E402

TYPE = "std_msgs/msg/UInt8MultiArray"
DATA_BYTES = 99  # 4 header + 8 layout + 4 length + 99 = 115 bytes of CDR
RATE_HZ = 200.0
QOS = QoSProfile(depth=10)  # reliable, volatile, keep last 10
PING, PONG = "/bench/ping", "/bench/pong"
_SETTLE_S = 0.2


def _message(stamp_ns: int) -> Any:
    data = np.zeros(DATA_BYTES, dtype=np.uint8)
    data[:8] = np.frombuffer(struct.pack("<Q", stamp_ns), dtype=np.uint8)
    return interfaces.new(TYPE, data=data)


def _stamp(data: Any) -> int:
    return int(struct.unpack("<Q", bytes(np.asarray(data[:8], dtype=np.uint8)))[0])


def _stats(latencies_ns: list[int], sent: int, duration_s: float) -> dict[str, Any]:
    us = np.asarray(latencies_ns, dtype=np.float64) / 1e3
    return {"samples": len(us), "sent": sent,
            "throughput_msg_s": round(len(us) / duration_s, 1),
            "p50_us": round(float(np.percentile(us, 50)), 1),
            "p99_us": round(float(np.percentile(us, 99)), 1),
            "max_us": round(float(us.max()), 1)}


# -- ours -----------------------------------------------------------------------------------
def _ours(domain: int, name: str) -> Any:
    from runtime.processes.executor import ClockedExecutor
    from runtime.ros2 import Ros2Config, Ros2Transport

    return ClockedExecutor(Ros2Transport(Ros2Config(domain), name=name), use_sim_time=False,
                           config_dir=None)


def ours_echo(domain: int) -> None:
    from runtime import Node

    ex = _ours(domain, "echo")
    node = Node("bench_echo", context=ex.context)
    pub = node.create_publisher(TYPE, PONG, QOS)
    node.create_subscription(TYPE, PING, pub.publish, QOS)
    print("ready", flush=True)
    ex.spin(until=lambda: sys.stdin.closed)


def ours_ping(domain: int, duration_s: float) -> dict[str, Any]:
    from runtime import Node

    ex = _ours(domain, "ping")
    node = Node("bench_ping", context=ex.context)
    pub = node.create_publisher(TYPE, PING, QOS)
    rtts: list[int] = []
    sub = node.create_subscription(
        TYPE, PONG, lambda m: rtts.append(time.monotonic_ns() - _stamp(m.data)), QOS)
    sent = [0]

    def tick() -> None:
        pub.publish(_message(time.monotonic_ns()))
        sent[0] += 1

    deadline = time.monotonic() + 20
    while (pub.get_subscription_count() == 0 or sub.get_publisher_count() == 0) \
            and time.monotonic() < deadline:
        ex.spin_once_realtime()
    ex.spin_until(time.time_ns())
    timer = node.create_timer(1.0 / RATE_HZ, tick)
    end = time.monotonic() + duration_s
    ex.spin(until=lambda: time.monotonic() > end)
    timer.cancel()  # then only collect the echoes still on their way
    settle = time.monotonic() + _SETTLE_S
    ex.spin(until=lambda: time.monotonic() > settle)
    return _stats([r // 2 for r in rtts], sent[0], duration_s)


# -- bare rclpy -----------------------------------------------------------------------------
def _bare(domain: int, name: str) -> Any:
    import rclpy
    from rclpy.executors import SingleThreadedExecutor

    from runtime.ros2 import Ros2Config
    from runtime.ros2.qos import rclpy_qos

    Ros2Config(domain).apply()  # the same discovery range as ours
    rclpy.init(domain_id=domain)
    node = rclpy.create_node(name)
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    return node, executor, rclpy_qos(QOS)


def bare_echo(domain: int) -> None:
    from rclpy.executors import ExternalShutdownException
    from std_msgs.msg import UInt8MultiArray

    node, executor, qos = _bare(domain, "bare_echo")
    pub = node.create_publisher(UInt8MultiArray, PONG, qos)
    node.create_subscription(UInt8MultiArray, PING, pub.publish, qos)
    print("ready", flush=True)
    try:  # terminate() reaches rclpy's signal handler, which shuts the context down
        while not sys.stdin.closed:
            executor.spin_once(timeout_sec=0.05)
    except ExternalShutdownException:
        pass


def bare_ping(domain: int, duration_s: float) -> dict[str, Any]:
    from std_msgs.msg import UInt8MultiArray

    node, executor, qos = _bare(domain, "bare_ping")
    pub = node.create_publisher(UInt8MultiArray, PING, qos)
    rtts: list[int] = []

    def echoed(msg: Any) -> None:
        rtts.append(time.monotonic_ns() - struct.unpack("<Q", bytes(msg.data[:8]))[0])

    sub = node.create_subscription(UInt8MultiArray, PONG, echoed, qos)
    deadline = time.monotonic() + 20
    while (pub.get_subscription_count() == 0 or sub.get_publisher_count() == 0) \
            and time.monotonic() < deadline:
        executor.spin_once(timeout_sec=0.01)
    sent = [0]

    def tick() -> None:
        data = np.zeros(DATA_BYTES, dtype=np.uint8)
        data[:8] = np.frombuffer(struct.pack("<Q", time.monotonic_ns()), dtype=np.uint8)
        pub.publish(UInt8MultiArray(data=data.tobytes()))
        sent[0] += 1

    timer = node.create_timer(1.0 / RATE_HZ, tick)
    end = time.monotonic() + duration_s
    while time.monotonic() < end:
        executor.spin_once(timeout_sec=0.05)
    timer.cancel()
    settle = time.monotonic() + _SETTLE_S
    while time.monotonic() < settle:
        executor.spin_once(timeout_sec=0.02)
    return _stats([r // 2 for r in rtts], sent[0], duration_s)


# -- conversion cost ------------------------------------------------------------------------
def conversion(samples: int = 20000) -> dict[str, Any]:
    """Per message: our raw path (rosbags serialize, then publish_raw) against the extra
    step a typed path would take (our CDR into rclpy's class)."""
    from rclpy.serialization import deserialize_message
    from std_msgs.msg import UInt8MultiArray

    msg = _message(0)
    t0 = time.perf_counter_ns()
    for _ in range(samples):
        data = interfaces.serialize(msg, TYPE)
    t1 = time.perf_counter_ns()
    for _ in range(samples):
        deserialize_message(data, UInt8MultiArray)
    t2 = time.perf_counter_ns()
    return {"rosbags_serialize_us": round((t1 - t0) / samples / 1e3, 2),
            "to_rclpy_class_extra_us": round((t2 - t1) / samples / 1e3, 2)}


# -- the square: at full speed, and at 3x beside two busy loops -----------------------------
def _square(domain: int, rtf: float) -> tuple[subprocess.CompletedProcess[str], dict[str, float]]:
    out = subprocess.run(
        [sys.executable, "-m", "quadmission.cli", "launch", "config/launch/square.yaml",
         "--transport", "ros2", "--domain-id", str(domain), "--rtf", f"{rtf:g}",
         "--duration", "240"],
        cwd=ROOT, capture_output=True, text=True, timeout=1800,
        env=dict(os.environ, MUJOCO_GL=os.environ.get("MUJOCO_GL", "egl")))
    if out.returncode != 0:
        raise RuntimeError(f"square under ros2 at --rtf {rtf:g} failed: {out.stderr[-2000:]}")
    found = re.search(r"\[simulator\] ran ([\d.]+) s simulated in ([\d.]+) s "
                      r"\(real-time factor ([\d.]+)\)", out.stderr)
    if found is None:
        raise RuntimeError("the simulator did not say its real-time factor")
    return out, {"rtf": float(found[3]), "sim_s": float(found[1]), "wall_s": float(found[2])}


def square_rtf(domain: int) -> dict[str, Any]:
    _, run = _square(domain, 1000.0)
    return {"square_rtf": run["rtf"], "square_sim_s": run["sim_s"],
            "square_wall_s": run["wall_s"]}


def square_beside_busy_loops(domain: int, loops: int = 2) -> dict[str, Any]:
    hogs = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(loops)]
    try:
        out, run = _square(domain, 3.0)
    finally:
        for hog in hogs:
            hog.kill()
            hog.wait()
    return {"square_beside_busy_loops": {
        "busy_loops": loops, "exit_code": out.returncode,
        "reason": json.loads(out.stdout)["reason"], **run}}


# -- the lockstep mission: CPU per simulated second, per process, beside the in-process run --
def _launch_cpu(argv: list[str], root: Path) -> tuple[dict[str, float], float, str, int]:
    """Run a launch; the CPU seconds of each of its processes (sampled every 0.2 s, the
    last one at exit from the kernel's count of waited-for children), the total, its
    stderr and exit code."""
    import resource

    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    env = dict(os.environ, PYTHONPATH=str(root), MUJOCO_GL=os.environ.get("MUJOCO_GL", "egl"))
    with subprocess.Popen(argv, cwd=root, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                          text=True, env=env) as proc:
        assert proc.stderr is not None
        import threading
        err: list[str] = []
        reader = threading.Thread(target=lambda: err.extend(proc.stderr or ()), daemon=True)
        reader.start()
        seen: dict[int, tuple[str, float]] = {}
        while proc.poll() is None:
            for pid in [proc.pid, *children(proc.pid)]:
                name = "launcher" if pid == proc.pid else (
                    seen[pid][0] if pid in seen else process_name(pid))
                cpu = cpu_seconds(pid)
                if name is not None and cpu is not None:
                    seen[pid] = (name, cpu)
            time.sleep(0.2)
        reader.join(10)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    total = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    per: dict[str, float] = {}
    for name, cpu in seen.values():
        per[name] = per.get(name, 0.0) + cpu
    return per, total, "".join(err), proc.returncode


def _simulated_s(stderr: str) -> float:
    found = re.findall(r"\[simulator\] ran ([\d.]+) s simulated in ([\d.]+) s", stderr)
    if not found:
        raise RuntimeError(f"the simulator did not say how far it ran: {stderr[-2000:]}")
    return float(found[-1][0])


def lockstep_mission(domain: int, duration_s: float, short_s: float = 2.0,
                     root: Path = ROOT) -> dict[str, Any]:
    """The first ``duration_s`` of ``mission.yaml`` (default arena, seed 0) under ``ros2`` in
    lockstep at full speed, and the same slice in one process: CPU seconds per simulated
    second, per process and in all. Each is also run for ``short_s``: the difference
    between the two runs is the slice without the start-up (imports, nodes, discovery).
    ``root``: the source tree that runs (another commit's checkout, to compare)."""
    launch = [sys.executable, "-m", "quadmission.cli", "launch", "config/launch/mission.yaml"]
    ros2 = [*launch, "--transport", "ros2", "--domain-id", str(domain), "--rtf", "1000"]
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=root,
                            capture_output=True, text=True).stdout.strip()
    result: dict[str, Any] = {"slice_s": duration_s, "short_s": short_s,
                              "commit": commit or None}
    for kind, argv in (("ros2", ros2), ("in_process", launch)):
        runs = {}
        for seconds in (short_s, duration_s):
            wall0 = time.monotonic()
            per, total, err, code = _launch_cpu([*argv, "--duration", f"{seconds:g}"], root)
            sim_s = _simulated_s(err) if kind == "ros2" else seconds
            runs[seconds] = (per, total, sim_s, time.monotonic() - wall0, code, err)
        (per0, total0, sim0, _, _, _), (per1, total1, sim1, wall, code, err) = (
            runs[short_s], runs[duration_s])
        span_s = sim1 - sim0
        rtf = re.findall(r"real-time factor ([\d.]+)\)", err)
        result[kind] = {
            "exit_code": code, "simulated_s": round(sim1, 3), "wall_s": round(wall, 1),
            "rtf": float(rtf[-1]) if rtf else round(sim1 / wall, 2),
            "cpu_s": {name: round(cpu, 2) for name, cpu in sorted(per1.items())},
            "cpu_s_total": round(total1, 2),
            "startup_cpu_s_total": round(total0, 2),
            "cpu_per_sim_s": {name: round((cpu - per0.get(name, 0.0)) / span_s, 3)
                              for name, cpu in sorted(per1.items())},
            "cpu_per_sim_s_total": round((total1 - total0) / span_s, 3),
        }
    result["ratio_ros2_to_in_process"] = round(
        result["ros2"]["cpu_per_sim_s_total"] / result["in_process"]["cpu_per_sim_s_total"], 2)
    result["load_avg_1min"] = load_1min(1)
    return result


# -- driver ----------------------------------------------------------------------------------
def _run_pair(kind: str, domain: int, duration_s: float) -> dict[str, Any]:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    echo = subprocess.Popen([sys.executable, __file__, "--role", f"{kind}-echo",
                             "--domain", str(domain)], stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, text=True, env=env)
    assert echo.stdout is not None and echo.stdout.readline().strip() == "ready"
    try:
        ping = subprocess.run([sys.executable, __file__, "--role", f"{kind}-ping", "--domain",
                               str(domain), "--duration", str(duration_s)],
                              capture_output=True, text=True, env=env, timeout=120)
        if ping.returncode != 0:
            raise RuntimeError(f"{kind} pinger failed: {ping.stderr}")
        return dict(json.loads(ping.stdout.strip().splitlines()[-1]))
    finally:
        echo.terminate()
        echo.wait(10)


def main() -> int:
    parser = bench_parser(__doc__, OPTIONAL)
    parser.add_argument("--duration", type=float, default=10.0, help="seconds per stream")
    parser.add_argument("--rounds", type=int, default=3, help="alternating rounds")
    # a domain outside the tests' range (100..229: tests/runtime/processes/conftest.py)
    parser.add_argument("--domain", type=int, default=60 + os.getpid() % 30)
    parser.add_argument("--no-square", action="store_true", help="latency only")
    parser.add_argument("--lockstep-only", action="store_true",
                        help="only the lockstep mission's CPU (ros2 beside in process)")
    parser.add_argument("--slice", type=float, default=60.0,
                        help="lockstep mission: simulated seconds of the mission measured")
    parser.add_argument("--compare-tree", type=Path, default=None,
                        help="lockstep mission: also measure this checkout (another commit), "
                             "as 'lockstep_mission_before'")
    parser.add_argument("--role", default=None, help=argparse.SUPPRESS)
    args = parser.parse_args()
    roles = {"ours-echo": lambda: ours_echo(args.domain),
             "bare-echo": lambda: bare_echo(args.domain)}
    if args.role in roles:
        roles[args.role]()
        return 0
    if args.role in ("ours-ping", "bare-ping"):
        ping = ours_ping if args.role == "ours-ping" else bare_ping
        print(json.dumps(ping(args.domain, args.duration)))
        return 0
    if args.lockstep_only:
        found = {"lockstep_mission": lockstep_mission(args.domain, args.slice)}
        if args.compare_tree is not None:
            found["lockstep_mission_before"] = lockstep_mission(
                args.domain, args.slice, root=args.compare_tree.resolve())
        print(write_result(args.out, found), end="")
        return 0
    rounds = []
    for _ in range(args.rounds):  # alternating, so load changes hit both alike
        rounds.append({"bare": _run_pair("bare", args.domain, args.duration),
                       "ours": _run_pair("ours", args.domain, args.duration)})

    def median(kind: str, key: str) -> float:
        return round(float(np.median([r[kind][key] for r in rounds])), 1)

    p50, p99 = median("ours", "p50_us"), median("ours", "p99_us")
    bare_p50, bare_p99 = median("bare", "p50_us"), median("bare", "p99_us")
    result: dict[str, Any] = {
        "message": {"type": TYPE, "cdr_bytes": len(interfaces.serialize(_message(0), TYPE)),
                    "rate_hz": RATE_HZ, "qos": "reliable, volatile, keep last 10"},
        "method": "ping-pong between two processes, one-way = round trip / 2, "
                  "localhost-only Fast DDS; medians over alternating rounds",
        "p50_us": p50, "p99_us": p99, "bare_p50_us": bare_p50, "bare_p99_us": bare_p99,
        "p50_ratio": round(p50 / bare_p50, 2), "p99_ratio": round(p99 / bare_p99, 2),
        "p50_ratio_range": [round(min(r["ours"]["p50_us"] / r["bare"]["p50_us"]
                                      for r in rounds), 2),
                            round(max(r["ours"]["p50_us"] / r["bare"]["p50_us"]
                                      for r in rounds), 2)],
        "p99_ratio_range": [round(min(r["ours"]["p99_us"] / r["bare"]["p99_us"]
                                      for r in rounds), 2),
                            round(max(r["ours"]["p99_us"] / r["bare"]["p99_us"]
                                      for r in rounds), 2)],
        "targets": {"p50_ratio": 1.2, "p99_ratio": 1.5},
        "rounds": rounds,
        "conversion": conversion(),
        "load_avg_1min": load_1min(1),
    }
    if not args.no_square:
        result |= square_rtf(args.domain) | square_beside_busy_loops(args.domain)
        result["lockstep_mission"] = lockstep_mission(args.domain, args.slice)
    print(write_result(args.out, result), end="")
    return 0


if __name__ == "__main__":
    sys.exit(main())
