"""The results page's sections for `benchmarks/bench_sitl.py`, now and before the speed work."""

from __future__ import annotations

from . import Json, Results, Row, Section
from ._markdown import host_line, ratio, span, table


def _rtf_rows(d: Json) -> list[list[object]]:
    rounds = d.get("rounds", [])

    def over_rounds(key: str) -> str:
        values = [r[key] for r in rounds if key in r]
        return f" (rounds {span(values)})" if len(values) > 1 else ""

    rows: list[list[object]] = [
        ["real-time factor, no camera", f"{d['rtf_no_camera']}{over_rounds('rtf_no_camera')}",
         f"bare world loop {d['rtf_bare_world']}{over_rounds('rtf_bare_world')}",
         ratio(d["ratio_no_camera_over_bare"], 3)],
        ["real-time factor, 640x480 down camera at 12 Hz",
         f"{d['rtf_down_camera']}{over_rounds('rtf_down_camera')}",
         "bare world loop", ratio(d["ratio_down_camera_over_bare"], 3)],
    ]
    if "rtf_down_camera_threaded" in d:
        rows.append([f"real-time factor, the camera on its render thread "
                     f"({d['down_camera_threaded_latency_s'] * 1000:.0f} ms latency)",
                     f"{d['rtf_down_camera_threaded']}{over_rounds('rtf_down_camera_threaded')}",
                     "in-line camera", ratio(d["rtf_down_camera_threaded"] / d["rtf_down_camera"])])
    if "rtf_cpu_no_camera" in d:
        rows.append(["real-time factor on CPU time, no camera / camera",
                     f"{d['rtf_cpu_no_camera']} / {d['rtf_cpu_down_camera']}",
                     f"bare world loop {d['rtf_cpu_bare_world']}", "-"])
    rows += [
        ["FCU main-loop tick, mean (wall)", f"{d['fcu_tick_mean_us']} us",
         f"budget {d['fcu_tick_budget_us']:.0f} us at 500 Hz",
         ratio(d["fcu_tick_mean_us"] / d["fcu_tick_budget_us"], 3)],
        ["FCU overruns", d["fcu_overruns"], "0", "-"],
        ["messages per simulated second / us per message (publish -> callback)",
         f"{d['messages_per_sim_s']} / {d['us_per_message']}", "-", "-"],
        ["square tracking RMSE (xy) against " + d.get("tracking_reference", "the setpoints")
         + ", no camera / camera",
         f"{d['tracking_rmse_m']} / {d['tracking_rmse_m_down_camera']} m", "-", "-"],
    ]
    if "scheduler_metering_over_tick" in d:
        shares = d.get("scheduler_metering_over_tick_rounds", [d["scheduler_metering_over_tick"]])
        rows.append(["scheduler metering per tick (duty and rate meters)",
                     f"{d['scheduler_metering_us_per_tick']} us, "
                     f"{span([s * 100 for s in shares], 1)} % of the tick",
                     f"bare dispatch {d['scheduler_bare_dispatch_us_per_tick']} us", "-"])
    return rows


def _sitl(d: Json) -> list[str]:
    lines = [f"{d['scenario']}; physics at {d['physics_hz']} Hz, {d['sim_seconds']:.1f} s "
             "simulated.", ""]
    if "interpreter" in d:
        i = d["interpreter"]
        lines += [f"Interpreter: `{i['executable']}` {i['version']} (shared libpython: "
                  f"{'yes' if i['libpython_shared'] else 'no'}).", ""]
    lines += table(["figure", "value", "baseline", "ratio"], _rtf_rows(d))
    lines += table(["physics rate", "tracking RMSE xy", "RTF", "vs 3 kHz: max / RMS deviation"],
                   [[f"{p['physics_hz']} Hz", f"{p['tracking_rmse_m']} m", p["rtf"],
                     f"{p['vs_3000_hz']['max_m'] * 1000:.2f} / "
                     f"{p['vs_3000_hz']['rms_m'] * 1000:.2f} mm"] for p in d["physics_rate"]])
    if "camera" in d:
        lines += table(["frame", "render + publish + deliver", "bare `mujoco.Renderer`", "ratio"],
                       [[c["size"], f"{c['render_publish_deliver_ms']} ms",
                         f"{c['bare_render_ms']} ms", ratio(c["ratio_ours_over_bare"])]
                        for c in d["camera"]])
    if "antialiasing" in d:
        lines += table(["frame", "anti-aliasing samples", "pads decoded", "frame"],
                       [[a["size"], a["multisamples"], a["pads_decoded"], f"{a['frame_ms']} ms"]
                        for a in d["antialiasing"]])
    if "profile_percent" in d:
        lines += table(["area", "share of the profile"],
                       [[area, f"{share} %"] for area, share in d["profile_percent"].items()])
    return [*lines, *host_line(None, d.get("load_average_1min"))]


def _sitl_before(d: Json) -> list[str]:
    lines = [f"The same benchmark before the speed work: {d['scenario']}; physics at "
             f"{d['physics_hz']} Hz.", ""]
    rows = [r for r in _rtf_rows(d) if not str(r[0]).startswith("scheduler")]
    lines += table(["figure", "value", "baseline", "ratio"], rows)
    return [*lines, *host_line(None, d.get("load_average_1min"))]


def _headline(r: Results) -> list[Row]:
    sitl = r["sitl"]
    rounds = sitl["rounds"]
    return [
        ["square through the whole stack, real-time factor: no camera / 640x480 camera",
         f"{span([x['rtf_no_camera'] for x in rounds], 1)} / "
         f"{span([x['rtf_down_camera'] for x in rounds], 1)} (rounds)",
         f"bare world loop {span([x['rtf_bare_world'] for x in rounds], 0)}"],
        ["simulated FCU main-loop tick, mean (wall clock)",
         f"{sitl['fcu_tick_mean_us']:.0f} us at 1-min load {sitl['load_average_1min']:.1f}",
         f"budget {sitl['fcu_tick_budget_us']:.0f} us"],
    ]


SECTIONS = {
    "sitl": Section(
        "Simulation speed: the square through the whole stack",
        "Real-time factors of the square flown through FCU, link, bridge, flight-control node "
        "and pilot, against the bare world loop in the same run (wall and CPU time; the "
        "range over interleaved rounds shows how much the host's load moves them), FCU tick, "
        "message cost, physics rate, frame cost and a profile by area.",
        body=_sitl, headline=_headline),
    "sitl_before": Section(
        "Simulation speed before the speed work",
        "Kept as the baseline the speed work is measured against.",
        body=_sitl_before, source="`benchmarks/bench_sitl.py` at an early commit"),
}
