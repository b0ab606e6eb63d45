"""Simulated FCU <-> companion one-way latency against seed 000 Table 3 (the baseline).

    python benchmarks/bench_link.py --out benchmarks/results/link.json

Sends ``--samples`` messages of ``--size-bytes`` (default 115, the seed's size) in each
direction at ``--period-us`` (default 5000 us: the seed's 200 Hz) through
``sim.fcu.link.Link`` with the parameters of ``--config`` (default ``config/fcu_link.yaml``),
and reports the one-way latency of the delivered ones [us]: mean, sd, p50, p99, max, next
to Table 3's mean +/- sd (MicroXRCE-DDS - ROS 2), with the ratios mean_sim / mean_paper
and sd_sim / sd_paper. Also: lost and spiked counts, the model's analytic mean and sd, and
the host time per ``send``. This is the link alone on an idle line: it is fitted so that the
latency *experiment*, where the streams also queue behind the time-sync messages on the FIFO
line, reproduces Table 3 (``benchmarks/bench_latency.py``), so its own ratios sit a little
under 1.0 (mean about -1 % to -3 %).
"""

from __future__ import annotations

import time
from dataclasses import asdict, replace
from pathlib import Path

import numpy as np
from _harness import bench_parser, write_result

from interfaces.px4.seed000 import (
    TABLE3_MESSAGE_SIZE_BYTES,
    TABLE3_TO_COMPANION,
    TABLE3_TO_FCU,
    LatencyFigure,
)
from runtime.parameters import config_path, load_parameters
from sim.fcu.link import (
    LINK_NODE_NAME,
    Link,
    LinkDirection,
    LinkParams,
)

PAPER: dict[LinkDirection, LatencyFigure] = {
    LinkDirection.TO_FCU: TABLE3_TO_FCU,
    LinkDirection.TO_COMPANION: TABLE3_TO_COMPANION,
}
START_NS = 1_000_000_000


def measure(
    params: LinkParams, direction: LinkDirection, samples: int, size_bytes: int, period_ns: int
) -> dict[str, object]:
    """One direction: simulated latency statistics, the paper's figures and their ratios."""
    link = Link(params)
    latencies_ns = np.empty(samples, dtype=np.int64)
    delivered = 0
    t0 = time.perf_counter()
    for i in range(samples):
        send_ns = START_NS + i * period_ns
        delivery_ns = link.send(direction, send_ns, size_bytes)
        if delivery_ns is not None:
            latencies_ns[delivered] = delivery_ns - send_ns
            delivered += 1
    host_us_per_send = (time.perf_counter() - t0) / samples * 1e6
    lat_us = latencies_ns[:delivered] / 1000.0
    counters = link.counters(direction)
    paper = PAPER[direction]
    model = params.direction(direction)
    mean_us, sd_us = float(lat_us.mean()), float(lat_us.std(ddof=1))
    return {
        "simulated_us": {
            "mean": round(mean_us, 1),
            "sd": round(sd_us, 1),
            "p50": round(float(np.percentile(lat_us, 50)), 1),
            "p99": round(float(np.percentile(lat_us, 99)), 1),
            "max": round(float(lat_us.max()), 1),
        },
        "paper_us": {"mean": paper.mean_us, "sd": paper.sd_us},
        "ratio_mean_sim_over_paper": round(mean_us / paper.mean_us, 4),
        "ratio_sd_sim_over_paper": round(sd_us / paper.sd_us, 4),
        "model_us": {
            "mean": round(model.mean_latency_us(size_bytes), 1),
            "sd": round(model.latency_sd_us(), 1),
            "wire_time": model.wire_time_ns(size_bytes) / 1000.0,
        },
        "counters": {"sent": counters.sent, "lost": counters.lost, "spikes": counters.spikes},
        "host_us_per_send": round(host_us_per_send, 2),
        "parameters": asdict(model),
    }


def run(params: LinkParams, samples: int, size_bytes: int, period_ns: int) -> dict[str, object]:
    return {
        "baseline": "seed 000 Table 3, MicroXRCE-DDS - ROS 2 (mean +/- sd, us)",
        "size_bytes": size_bytes,
        "samples": samples,
        "period_us": period_ns / 1000,
        "seed": params.seed,
        "directions": {
            d.value: measure(params, d, samples, size_bytes, period_ns) for d in LinkDirection
        },
    }


def format_table(report: dict[str, object]) -> str:
    head = (
        f"{'direction':13s} {'mean':>7s} {'sd':>6s} {'p50':>7s} {'p99':>7s} {'max':>7s}   "
        f"{'paper':>12s}   {'mean ratio':>10s} {'sd ratio':>8s} {'lost':>5s} {'spikes':>6s}"
    )
    lines = [
        f"one-way latency [us], {report['samples']} x {report['size_bytes']} B "
        f"every {report['period_us']} us, seed {report['seed']}",
        head,
        "-" * len(head),
    ]
    directions = report["directions"]
    assert isinstance(directions, dict)
    for name, r in directions.items():
        s, p, c = r["simulated_us"], r["paper_us"], r["counters"]
        paper = f"{p['mean']:.0f} +/- {p['sd']:.0f}"
        lines.append(
            f"{name:13s} {s['mean']:7.1f} {s['sd']:6.1f} {s['p50']:7.1f} {s['p99']:7.1f} "
            f"{s['max']:7.1f}   {paper:>12s}   {r['ratio_mean_sim_over_paper']:10.4f} "
            f"{r['ratio_sd_sim_over_paper']:8.4f} {c['lost']:5d} {c['spikes']:6d}"
        )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = bench_parser(__doc__, "link")
    parser.add_argument("--config", type=Path, default=config_path(f"{LINK_NODE_NAME}.yaml"))
    parser.add_argument("--samples", type=int, default=20_000)
    parser.add_argument("--size-bytes", type=int, default=TABLE3_MESSAGE_SIZE_BYTES)
    parser.add_argument("--period-us", type=int, default=5_000)
    parser.add_argument("--seed", type=int, default=None, help="override the YAML's seed")
    args = parser.parse_args(argv)
    if args.samples < 2:
        parser.error("--samples must be >= 2")
    if args.size_bytes < 0 or args.period_us < 1:
        parser.error("--size-bytes must be >= 0 and --period-us >= 1")
    params = load_parameters(LinkParams, LINK_NODE_NAME, args.config)
    if args.seed is not None:
        params = replace(params, seed=args.seed)
    report = run(params, args.samples, args.size_bytes, args.period_us * 1000)
    write_result(args.out, report)
    print(format_table(report))
    print(f"\nwrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
