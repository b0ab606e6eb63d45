"""Mission speed: the default contest mission's real-time factor, where its CPU goes, and
the bare world's real-time factor measured beside it (issue 21).

    python benchmarks/bench_mission_speed.py --out benchmarks/results/mission_speed.json
    python benchmarks/bench_mission_speed.py --runs 3 --out ...   # the median of 3 processes
    python benchmarks/bench_mission_speed.py --runs 3 --make-sim-runs 3 --out ...

Flies ``quadmission sim`` (default arena, seed 0, every node, the cameras with their
configured rates and latency) once in this process and reports:

- ``rtf_mission``: simulated seconds per wall second; ``wall_s``, ``cpu_s`` (this
  process, every thread but the sampler's), ``cpu_per_sim_s`` and ``sim_s``;
- ``cpu_share``: the share of the busy samples of every Python thread in each part
  (scanner, down camera, depth camera, mapping, FCU, other), from py-spy reading every
  thread's stack from outside ``--sample-hz`` times a second (:class:`ExternalProfile`;
  a thread waiting on a lock or a queue is not busy; ``cpu_share_method`` says which
  profiler gave it); ``cpu_share_in_process_sampler``: the same from a sampler thread in
  the process, kept beside it to show that one's GIL bias (the fallback without py-spy);
  ``thread_cpu_per_sim_s``: each thread's CPU time (the kernel's count) per simulated
  second, Mesa's rasterizer threads included;
- the mission's result: completed, score, landings inside, touchdown RMSE;
- with ``--make-sim-runs N``, ``make_sim``: ``make sim`` itself timed N times (the mission
  with its bag, from the command to the report and its pictures; one after each mission
  run, the rest after the last), its median wall time against the 2-minute target;
- ``rtf_bare_world``: the world loop without companion or cameras (hover actuation,
  robots, crash detector, executor in lockstep; ``bench_sim.bench_physics``), measured
  right after on the same host, so the ratio ``rtf_mission / rtf_bare_world`` compares
  across hosts and loads better than either figure.
"""

from __future__ import annotations

import json
import os
import resource
import signal
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from collections import Counter
from pathlib import Path
from types import CodeType, FrameType
from typing import Any

os.environ.setdefault("MUJOCO_GL", "egl")
sys.path.insert(0, str(Path(__file__).parent))

from _harness import bench_parser, progress, write_result

PARTS = ("scanner", "down_camera", "depth_camera", "mapping", "fcu", "other")

# (part, path fragment, function name or "" for any): a stack's innermost frame that
# matches a rule names its part (the world loop and the SITL runner hold every stack, so
# they are "other" only when nothing inside them matches)
_RULES: tuple[tuple[str, str, str], ...] = (
    ("scanner", "perception/", ""),
    ("depth_camera", "sim/sensors.py", "DepthCamera.update"),
    ("depth_camera", "sim/sensors.py", "DepthCamera._deliver"),
    ("depth_camera", "sim/render.py", "DepthPointCloud."),
    ("down_camera", "sim/sensors.py", "DownCamera."),
    ("down_camera", "sim/camera_model.py", ""),
    ("down_camera", "sim/render.py", "SceneRenderer."),
    ("mapping", "navigation/mapping", ""),
    ("fcu", "sim/fcu/", ""),
)
_OUTER = ("sim/fcu/sitl.py", "sim/world.py")  # loops that run every part
# innermost frames of a thread that is waiting, not working
_IDLE = ("threading.py", "queue.py", "selectors.py")
_POOL = "concurrent/futures/thread.py"  # a pool thread's loop: idle when innermost


def _rule_part(filename: str, qualname: str) -> str | None:
    """The part one frame's code names by :data:`_RULES`, None when no rule matches it
    (or it is one of the :data:`_OUTER` loops)."""
    if filename.endswith(_OUTER):
        return None
    for part, path, function in _RULES:
        if path in filename and qualname.startswith(function):
            return part
    return None


_PART_OF_CODE: dict[int, tuple[CodeType, str | None]] = {}
""":func:`_rule_part` of each code object met (the same answer for every frame of it), by
its ``id`` (code objects of two files can compare equal); the entry keeps the code alive,
so its ``id`` is never another's."""


def _idle(filename: str, name: str) -> bool:
    """Whether a thread whose innermost frame is ``name`` in ``filename`` waits."""
    return filename.endswith(_IDLE) or (filename.endswith(_POOL) and name == "_worker")


def classify(frame: FrameType | None) -> str | None:
    """The part a thread's stack is in, or None when the thread is idle."""
    if frame is None or _idle(frame.f_code.co_filename, frame.f_code.co_name):
        return None
    parts = _PART_OF_CODE
    while frame is not None:
        code = frame.f_code
        known = parts.get(id(code))
        if known is None:
            known = parts[id(code)] = (code, _rule_part(code.co_filename, code.co_qualname))
        part = known[1]
        if part is not None:
            return part
        frame = frame.f_back
    return "other"


_THREADS_EVERY = 50  # stack samples between two reads of the threads' CPU times


class ThreadCpu:
    """CPU seconds per thread of this process, read from ``/proc/self/task`` (Linux; empty
    elsewhere): unlike the stack samples, they do not count a thread that waits for a
    core or for the GIL. Threads are grouped by name without its number (``llvmpipe-0``
    and ``llvmpipe-1`` are ``llvmpipe``; threads Python did not start are named by the
    OS). A thread that ended keeps its last reading."""

    def __init__(self, exclude: tuple[str, ...] = ()) -> None:
        self._last: dict[int, tuple[str, float]] = {}
        self._exclude = exclude
        self._tick = os.sysconf("SC_CLK_TCK") if hasattr(os, "sysconf") else 100

    def read(self) -> None:
        names = {t.native_id: t.name for t in threading.enumerate()}
        try:
            tids = os.listdir("/proc/self/task")
        except OSError:
            return
        for tid in tids:
            try:
                with open(f"/proc/self/task/{tid}/stat") as f:
                    fields = f.read().rsplit(")", 1)[1].split()
                with open(f"/proc/self/task/{tid}/comm") as f:
                    comm = f.read().strip()
            except OSError:
                continue  # ended meanwhile
            name = names.get(int(tid), comm)
            self._last[int(tid)] = (name, (int(fields[11]) + int(fields[12])) / self._tick)

    def per_group(self) -> dict[str, float]:
        """CPU seconds per thread group, largest first."""
        groups: Counter[str] = Counter()
        for name, cpu in self._last.values():
            group = name.rstrip("0123456789").rstrip("_-") or name
            if not group.startswith(self._exclude):
                groups[group] += cpu
        return dict(groups.most_common())


class Sampler:
    """Reads every other thread's stack ``hz`` times a second (see :func:`classify`)."""

    def __init__(self, hz: float) -> None:
        self.period = 1.0 / hz
        self.counts: Counter[str] = Counter()
        self.cpu_s = 0.0
        """The sampler's own CPU time (its thread): not the mission's."""
        self.threads = ThreadCpu(exclude=("sampler",))
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="sampler", daemon=True)

    def _run(self) -> None:
        me = threading.get_ident()
        start = time.thread_time()
        tick = 0
        while not self._stop.wait(self.period):
            for ident, frame in sys._current_frames().items():
                if ident != me and (part := classify(frame)) is not None:
                    self.counts[part] += 1
            tick += 1
            if tick % _THREADS_EVERY == 0:
                self.threads.read()
        self.threads.read()
        self.cpu_s = time.thread_time() - start

    def __enter__(self) -> Sampler:
        self._thread.start()
        return self

    def __exit__(self, *_: object) -> None:
        self._stop.set()
        self._thread.join()

    def shares(self) -> dict[str, float]:
        total = sum(self.counts.values()) or 1
        return {part: round(self.counts[part] / total, 3) for part in PARTS}


class ExternalProfile:
    """py-spy attached to this process, reading every thread's stack from outside
    (``--nonblocking``: the process is never paused). The in-process :class:`Sampler`
    needs the GIL to read a stack, so it mostly gets it where another thread lets it go:
    the main thread's ``mj_step``, numpy calls and waits; pure-Python work such as the FCU
    firmware is then hardly ever seen (0.8 % of the samples against 20 % by py-spy over the
    same mission). py-spy has no such bias; it counts a sample only for a thread that is
    not idle (by the OS thread state). A camera's render thread counts for its camera.
    Threads that run no Python (Mesa's llvmpipe rasterizers) are not sampled: their CPU
    is in ``thread_cpu_per_sim_s``. Unavailable (not installed, no permission to attach):
    ``shares`` is None."""

    def __init__(self, hz: float, out: Path) -> None:
        self.hz, self.out = hz, out
        self.error: str | None = None
        self._proc: subprocess.Popen[str] | None = None
        exe = Path(sys.executable).parent / "py-spy"
        self._exe = exe if exe.exists() else None

    def __enter__(self) -> ExternalProfile:
        if self._exe is None:
            self.error = "py-spy is not installed (pip install py-spy)"
            return self
        self._proc = subprocess.Popen(
            [str(self._exe), "record", "--pid", str(os.getpid()), "--rate", str(int(self.hz)),
             "--format", "raw", "--threads", "--nonblocking", "--output", str(self.out)],
            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        time.sleep(1.0)  # attached before the mission starts
        if self._proc.poll() is not None:
            self.error = f"py-spy could not attach: {self._proc.communicate()[1].strip()}"
            self._proc = None
        return self

    def __exit__(self, *_: object) -> None:
        if self._proc is None:
            return
        self._proc.send_signal(signal.SIGINT)  # py-spy writes its samples and exits
        try:
            self._proc.communicate(timeout=120)
        except subprocess.TimeoutExpired:
            self._proc.kill()
            self._proc.communicate()
        if not self.out.exists():
            self.error = "py-spy wrote no samples"

    def shares(self) -> tuple[dict[str, float], int] | None:
        """The share of busy samples per part (:data:`PARTS`), and the sample count."""
        if self.error is not None or not self.out.exists():
            return None
        counts: Counter[str] = Counter()
        for line in self.out.read_text().splitlines():
            stack, _, n = line.rpartition(" ")
            thread, *frames = stack.split(";")
            if thread.endswith(": sampler"):  # the in-process sampler's own work
                continue
            if (part := classify_stack(frames)) is not None:
                # a render thread works for its camera (its frames name only the renderer)
                camera = thread.rpartition(": scene_renderer_")[2].rstrip("0123456789_")
                part = camera if camera in ("down_camera", "depth_camera") else part
                counts[part] += int(n)
        total = sum(counts.values()) or 1
        return {part: round(counts[part] / total, 3) for part in PARTS}, sum(counts.values())


def classify_stack(frames: list[str]) -> str | None:
    """:func:`classify` for a py-spy stack, outermost first, each ``func (file:line)``."""
    parsed = []
    for frame in frames:
        name, _, where = frame.rpartition(" (")
        parsed.append((name, where.rsplit(":", 1)[0]))
    if not parsed or _idle(parsed[-1][1], parsed[-1][0]):
        return None
    for name, filename in reversed(parsed):
        if (part := _rule_part(filename, name)) is not None:
            return part
    return "other"


def _cpu_s() -> float:
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def fly(out: Path, sample_hz: float) -> dict[str, Any]:
    from quadmission.scenarios import ScenarioOptions
    from quadmission.scenarios.mission.scenario import fly_mission

    profile = ExternalProfile(sample_hz, out.parent / "py-spy.txt")
    with profile:
        cpu0, wall0 = _cpu_s(), time.perf_counter()
        with Sampler(sample_hz) as sampler:
            report = fly_mission(ScenarioOptions(out=out, seed=0))
        wall, cpu = time.perf_counter() - wall0, _cpu_s() - cpu0 - sampler.cpu_s
    external = profile.shares()
    sim_s = float(report["sim_time_s"])
    landings = report["landings"]
    return {"sim_s": round(sim_s, 3), "wall_s": round(wall, 1), "cpu_s": round(cpu, 1),
            "rtf_mission": round(sim_s / wall, 2), "rtf_mission_cpu": round(sim_s / cpu, 2),
            "cpu_per_sim_s": round(cpu / sim_s, 3),
            "cpu_share": external[0] if external else sampler.shares(),
            "cpu_share_method": ("py-spy, every thread from outside" if external else
                                 "in-process sampler thread, biased towards where the "
                                 f"GIL is let go ({profile.error})"),
            "samples": external[1] if external else sum(sampler.counts.values()),
            "cpu_share_in_process_sampler": sampler.shares(),
            "sampler_cpu_s": round(sampler.cpu_s, 1),
            "thread_cpu_per_sim_s": {name: round(cpu / sim_s, 4)
                                     for name, cpu in sampler.threads.per_group().items()},
            "result": report["result"], "ok": report["ok"],
            "score": report["score"], "max_score": report["max_score"],
            "landings_inside": sum(1 for x in landings if x["inside_pad"]),
            "landings": len(landings),
            "touchdown_rmse_m": report["touchdown_rmse_m"],
            "touchdown_max_m": report["touchdown_max_m"]}


def one_run(sample_hz: float, bare_seconds: float) -> dict[str, Any]:
    """One mission in this process, then the bare world loop."""
    from bench_sim import bench_physics

    with tempfile.TemporaryDirectory() as tmp:
        run: dict[str, Any] = {"benchmark": "mission_speed", "arena": "default", "seed": 0,
                               "cores": os.cpu_count(),
                               "load_before": round(os.getloadavg()[0], 2)}
        run |= fly(Path(tmp) / "mission", sample_hz)
    bare = bench_physics(bare_seconds)
    run["rtf_bare_world"] = bare["real_time_factor_no_camera"]
    run["ratio_mission_over_bare_world"] = round(run["rtf_mission"] / run["rtf_bare_world"], 3)
    run["load_after"] = round(os.getloadavg()[0], 2)
    return run


MAKE_SIM = "make sim OUT=<tmp>"
MAKE_SIM_TARGET_S = 120.0  # issue 21: `make sim` in under 2 minutes
MAKE_SIM_TIMEOUT_S = 10 * MAKE_SIM_TARGET_S  # a hung run is stopped and counted as failed
_STDERR_TAIL = 20  # lines of a failed run's stderr kept in the result
_ROOT = Path(__file__).resolve().parent.parent


def time_make_sim() -> dict[str, Any]:
    """``make sim`` as a user types it (the mission with its bag, the report and its
    pictures), into a temporary folder: its wall time from the command to its exit. A run
    that fails (or is stopped after :data:`MAKE_SIM_TIMEOUT_S`, exit code -1) keeps the
    end of its stderr."""
    from ground_station.bag import bag_info
    from ground_station.errors import BagError

    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "run"
        wall0 = time.perf_counter()
        # its own process group: a hung run is stopped with make's children
        proc = subprocess.Popen(["make", "-s", "sim", f"OUT={out}"], cwd=_ROOT,
                                stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                                text=True, start_new_session=True)
        try:
            stderr = proc.communicate(timeout=MAKE_SIM_TIMEOUT_S)[1]
            code = proc.returncode
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            stderr = proc.communicate()[1] + f"\nstopped after {MAKE_SIM_TIMEOUT_S:.0f} s"
            code = -1
        wall = time.perf_counter() - wall0
        try:
            messages = bag_info(out / "bag").message_count
        except BagError:  # no bag: the run failed early (its exit code says so)
            messages = 0
    run: dict[str, Any] = {"wall_s": round(wall, 1), "exit_code": code,
                           "bag_messages": messages}
    if code != 0:
        run["stderr_tail"] = stderr.splitlines()[-_STDERR_TAIL:]
    return run


def main() -> None:
    parser = bench_parser(__doc__, "mission_speed")
    parser.add_argument("--sample-hz", type=float, default=100.0,
                        help="stack samples per second (default 100)")
    parser.add_argument("--bare-seconds", type=float, default=10.0,
                        help="simulated seconds of the bare world (default 10)")
    parser.add_argument("--make-sim-runs", type=int, default=0,
                        help="also time `make sim` (the mission with its bag, from the "
                             "command line to the report) this many times: one after each "
                             "mission run, the rest after the last (default 0)")
    parser.add_argument("--runs", type=int, default=1,
                        help="fly the mission this many times, one after the other, each "
                             "in a fresh process with its bare world after it; the run of "
                             "median RTF is reported, with every run's RTF (default 1)")
    args = parser.parse_args()
    if args.runs < 1:
        parser.error(f"--runs: {args.runs} < 1")
    if args.make_sim_runs < 0:
        parser.error(f"--make-sim-runs: {args.make_sim_runs} < 0")

    runs: list[dict[str, Any]] = []
    make_sims: list[dict[str, Any]] = []

    def time_one_make_sim() -> None:
        make_sims.append(time_make_sim())
        progress(f"make sim {len(make_sims)}/{args.make_sim_runs}: {make_sims[-1]['wall_s']} s, "
                 f"exit {make_sims[-1]['exit_code']}")

    for i in range(args.runs):
        if args.runs == 1:
            runs.append(one_run(args.sample_hz, args.bare_seconds))
        else:  # each run in a fresh process, as `make sim` flies it
            with tempfile.TemporaryDirectory() as tmp:
                part = Path(tmp) / "run.json"
                subprocess.run([sys.executable, __file__, "--out", str(part), "--sample-hz",
                                str(args.sample_hz), "--bare-seconds", str(args.bare_seconds)],
                               check=True, stdout=subprocess.DEVNULL)
                runs.append(json.loads(part.read_text()))
        run = runs[-1]
        progress(f"run {i + 1}/{args.runs}: RTF {run['rtf_mission']} ({run['wall_s']} s), "
                 f"{run['result']}, score {run['score']}")
        if i < args.make_sim_runs:
            time_one_make_sim()
    while len(make_sims) < args.make_sim_runs:  # the runs beyond --runs, after the last
        time_one_make_sim()
    result = sorted(runs, key=lambda r: r["rtf_mission"])[(len(runs) - 1) // 2]
    if len(runs) > 1:
        result["rtf_runs"] = [r["rtf_mission"] for r in runs]
        result["wall_s_runs"] = [r["wall_s"] for r in runs]
        result["same_flight_every_run"] = len({(r["sim_s"], r["touchdown_rmse_m"])
                                               for r in runs}) == 1
    if make_sims:
        failures = [m for m in make_sims if m["exit_code"] != 0]
        result["make_sim"] = {
            "command": MAKE_SIM,
            "wall_s": round(statistics.median(m["wall_s"] for m in make_sims), 1),
            "wall_s_runs": [m["wall_s"] for m in make_sims],
            "exit_codes": [m["exit_code"] for m in make_sims],
            "bag_messages": [m["bag_messages"] for m in make_sims],
            "target_s": MAKE_SIM_TARGET_S,
            "every_run_under_target": all(
                m["wall_s"] < MAKE_SIM_TARGET_S and m["exit_code"] == 0
                and m["bag_messages"] > 0 for m in make_sims),
            **({"failures": failures} if failures else {})}
    print(write_result(args.out, result), end="")


if __name__ == "__main__":
    main()
