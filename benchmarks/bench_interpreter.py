"""The same SITL flight under two CPython builds, side by side.

    python benchmarks/bench_interpreter.py --baseline ~/.pyenv-venv/bin/python \
        --out benchmarks/results/interpreter.json

The square of ``bench_sitl.py`` (no camera) is flown in a subprocess of each interpreter
in turn, ``--rounds`` times, interleaved so both see the same minutes of the machine;
each flight reports its real-time factor by wall and by CPU time and the sha256 of its
true trajectory (the two builds must fly the same trajectory, bit for bit). Each
interpreter needs the project's dependencies installed (a venv made from it).

The candidate defaults to this interpreter. The ratio is the best candidate flight over
the best baseline flight, and the median of the rounds' own ratios.
"""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
from pathlib import Path
from typing import Any

from _harness import bench_parser, progress, write_result

ROOT = Path(__file__).resolve().parents[1]

# what a subprocess runs: one warm-up flight (numba's cache, imports), then the measured
# one, printed as JSON on the last line
FLIGHT = """
import hashlib, json, sys
sys.path.insert(0, "benchmarks")
import bench_sitl
bench_sitl.fly()
f = bench_sitl.fly()
print(json.dumps({"rtf": f.rtf, "rtf_cpu": round(f.rtf_cpu, 2),
                  "trace_sha256": hashlib.sha256(repr(f.trace).encode()).hexdigest(),
                  "interpreter": bench_sitl.interpreter()}))
"""


def flight(python: str) -> dict[str, Any]:
    """One measured flight under ``python``."""
    done = subprocess.run([python, "-c", FLIGHT], cwd=ROOT, capture_output=True, text=True,
                          env=os.environ | {"MUJOCO_GL": "egl", "PYTHONPATH": str(ROOT)},
                          check=False)
    if done.returncode != 0:
        raise SystemExit(f"{python}: the flight failed:\n{done.stderr[-2000:]}")
    result: dict[str, Any] = json.loads(done.stdout.strip().splitlines()[-1])
    return result


def main(argv: list[str] | None = None) -> int:
    parser = bench_parser(__doc__, "interpreter")
    parser.add_argument("--baseline", help="the other interpreter (a venv's python); without "
                        "it the benchmark is skipped (as under `make bench`)")
    parser.add_argument("--candidate", default=sys.executable, help="default: this one")
    parser.add_argument("--rounds", type=int, default=4)
    args = parser.parse_args(argv)
    if args.rounds < 1:
        parser.error(f"--rounds: {args.rounds} must be >= 1")
    if args.baseline is None:
        progress("bench_interpreter: skipped (no --baseline: it needs a second interpreter's "
                 f"venv with the project's dependencies); {args.out} left as it is")
        return 0
    rounds = []
    for r in range(args.rounds):
        progress(f"round {r + 1}/{args.rounds}")
        rounds.append({"baseline": flight(args.baseline), "candidate": flight(args.candidate)})
    traces = {f["trace_sha256"] for r in rounds for f in r.values()}
    if len(traces) != 1:
        raise SystemExit(f"the interpreters flew different trajectories: {sorted(traces)}")

    def best(who: str, key: str) -> float:
        return max(float(r[who][key]) for r in rounds)

    report = {
        "scenario": "square (bench_sitl.fly, no camera), one warm-up then one measured flight "
                    "per subprocess",
        "baseline": rounds[0]["baseline"]["interpreter"],
        "candidate": rounds[0]["candidate"]["interpreter"],
        "same_trajectory": True,
        "rtf_baseline": best("baseline", "rtf"),
        "rtf_candidate": best("candidate", "rtf"),
        "ratio_best": round(best("candidate", "rtf") / best("baseline", "rtf"), 3),
        "ratio_median_of_rounds": round(statistics.median(
            r["candidate"]["rtf"] / r["baseline"]["rtf"] for r in rounds), 3),
        "ratio_cpu_best": round(best("candidate", "rtf_cpu") / best("baseline", "rtf_cpu"), 3),
        "rounds": [{who: {k: f[k] for k in ("rtf", "rtf_cpu")} for who, f in r.items()}
                   for r in rounds],
    }
    print(write_result(args.out, report), end="")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
