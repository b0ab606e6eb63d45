"""The operator page in a real browser (Debian's headless chromium, driven by Playwright)
during a real flight: the square over the SITL through the companion stack, paced to real
time, with the ground station attached as ``quadmission sim --gcs`` attaches it.

The mission state machine (issue 12) is not built yet: the square's status node publishes
``/mission/state`` from the pilot's step and the square as ``/navigation/path``, and a
small node the optimiser's proposal on ``/mission/sequence_proposal``, as the FSM will.
``/mission/command`` is heard by a plain listener. Screenshots stay in
``runs/test_output/ground_station/`` for a person to look at.
"""

from __future__ import annotations

import json
import shutil
import threading
import time
import urllib.error
import urllib.request
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest

import interfaces
from quadmission.assembly.companion import start_companion
from quadmission.assembly.services import COMMAND_LOG, GcsOptions, RunServices
from quadmission.scenarios.square.fit import fit_square
from quadmission.scenarios.square.flight import LAND_SPEED, SQUARE_SPEED
from quadmission.scenarios.square.pilot import SquarePilot
from quadmission.scenarios.square.status import SquareStatusNode
from runtime import Node, qos_profile_default
from sim.arena import default_arena
from sim.fcu.sitl import build_sitl
from sim.world import StopWhen

CHROMIUM = Path("/usr/bin/chromium")
ROOT = Path(__file__).resolve().parents[2]
OUTPUT = ROOT / "runs" / "test_output" / "ground_station"
TOKEN = "test-token-not-secret"
PROPOSAL = [3, 7, 2]
WAIT_MS = 120_000  # the flight runs at real time at best; under load it is slower

playwright_api = pytest.importorskip("playwright.sync_api",
                                     reason="playwright missing: pip install -e '.[test]'")
if not CHROMIUM.is_file():
    pytest.skip("Debian's chromium package is missing: apt-get install chromium "
                "(make system-deps installs it)", allow_module_level=True)

class _Proposal(Node):
    """The optimiser's proposed landing sequence, as the FSM (issue 12) will publish it."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("proposal", **kwargs)
        self.pub = self.create_publisher("quadmission_interfaces/msg/LandingSequence",
                                         "/mission/sequence_proposal", qos_profile_default)
        self.create_timer(0.5, lambda: self.pub.publish(interfaces.new(
            "quadmission_interfaces/msg/LandingSequence", pad_ids=PROPOSAL)))


class _CommandListener(Node):
    def __init__(self, **kwargs: Any) -> None:
        super().__init__("command_listener", **kwargs)
        self.heard: list[Any] = []
        self.create_subscription("quadmission_interfaces/msg/MissionCommand",
                                 "/mission/command", self.heard.append, qos_profile_default)


@dataclass
class Flight:
    services: RunServices
    listener: _CommandListener
    url: str
    out: Path

    def commands(self) -> list[tuple[int, list[int]]]:
        return [(int(m.command), [int(p) for p in m.sequence.pad_ids])
                for m in list(self.listener.heard)]

    def wait_for_command(self, count: int, timeout_s: float = 30.0) -> None:
        deadline = time.monotonic() + timeout_s
        while len(self.listener.heard) < count and time.monotonic() < deadline:
            time.sleep(0.05)


@pytest.fixture(scope="module")
def flight(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Flight]:
    out = tmp_path_factory.mktemp("gcs_run")
    arena = default_arena()
    plan = fit_square(arena)
    sitl = build_sitl(arena)
    start_companion(sitl)
    context = sitl.executor.context
    pilot = SquarePilot(plan.corners(), altitude=plan.altitude, speed=SQUARE_SPEED,
                        land_speed=LAND_SPEED, context=context)
    listener = _CommandListener(context=context)
    status = SquareStatusNode(pilot, plan.outline(), context=context)
    for node in (pilot, status, _Proposal(context=context), listener):
        sitl.executor.add_node(node)
    services = RunServices(gcs=GcsOptions(port=0, token=TOKEN))
    ready, stop = threading.Event(), threading.Event()
    errors: list[BaseException] = []

    def fly() -> None:  # rendering (EGL) and the executor live in this one thread
        try:
            with services.attach(sitl.executor, sitl.extra_parts, out, arena, sitl.scene):
                ready.set()
                sitl.run(240.0, stop=StopWhen(lambda: stop.is_set() or pilot.done))
        except BaseException as exc:  # reported by the fixture, not lost in the thread
            errors.append(exc)
        finally:
            ready.set()

    thread = threading.Thread(target=fly, name="flight", daemon=True)
    thread.start()
    ready.wait(timeout=120)
    assert not errors and services.server is not None, errors
    yield Flight(services, listener, services.server.operator_url(), out)
    stop.set()
    thread.join(timeout=120)
    services.close()
    assert not errors, errors


@pytest.fixture(scope="module")
def browser() -> Iterator[Any]:
    if OUTPUT.exists():
        shutil.rmtree(OUTPUT)
    OUTPUT.mkdir(parents=True)
    with playwright_api.sync_playwright() as p:
        chromium = p.chromium.launch(executable_path=str(CHROMIUM), headless=True,
                                     args=["--no-sandbox"])
        yield chromium
        chromium.close()


@pytest.fixture(scope="module")
def page(browser: Any, flight: Flight) -> Iterator[Any]:
    page = browser.new_page(viewport={"width": 1600, "height": 1000})
    errors: list[str] = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    page.goto(flight.url)
    yield page
    page.close()
    assert not errors, f"the page's script failed {len(errors)} times: {errors[:3]}"


def _command(name: str) -> int:
    msg = interfaces.get_message("quadmission_interfaces/msg/MissionCommand")
    return int(getattr(msg, f"COMMAND_{name}"))


def test_page_loads_and_shows_the_live_state_changing(page: Any, flight: Flight) -> None:
    page.wait_for_function("document.getElementById('pose').textContent.startsWith('x ')",
                           timeout=WAIT_MS)
    first_t = float(page.text_content("#t_s"))
    first_revision = int(page.text_content("#revision"))
    page.wait_for_function(f"parseFloat(document.getElementById('t_s').textContent) > "
                           f"{first_t + 1.0}", timeout=WAIT_MS)
    assert int(page.text_content("#revision")) > first_revision
    page.wait_for_function("document.getElementById('live').textContent === 'live'",
                           timeout=WAIT_MS)
    # the mission machine's diagram lights the state /mission/state names, and its parents
    page.wait_for_function("document.getElementById('phase').textContent !== "
                           "'no /mission/state yet'", timeout=WAIT_MS)
    state_name = page.text_content("#phase")
    lit = page.eval_on_selector_all("#fsm g.active", "gs => gs.map(g => g.dataset.state)")
    parts = state_name.split(".")
    assert lit == [".".join(parts[: i + 1]) for i in range(len(parts))]
    # FCU health from /fcu/status, time sync from the bridge
    page.wait_for_function("document.getElementById('link').textContent === 'yes'",
                           timeout=WAIT_MS)
    page.wait_for_function("document.getElementById('timesync').textContent !== '-'",
                           timeout=WAIT_MS)
    # a down-camera JPEG arrived and decoded in the browser
    page.wait_for_function("document.getElementById('camera').naturalWidth > 0",
                           timeout=WAIT_MS)
    # the map has the field's pads (the layout reached the page as data)
    state = json.loads(page.evaluate("fetch('api/state').then(r => r.text())"))
    assert [p["id"] for p in state["layout"]["pads"]] == [p.id for p in default_arena().pads]
    square = fit_square(default_arena()).outline()  # the planned path, from /navigation/path
    assert state["planned"] == [[pytest.approx(x), pytest.approx(y)] for x, y in square]
    page.screenshot(path=str(OUTPUT / "live_state.png"))


def test_a_typed_sequence_reaches_mission_command(page: Any, flight: Flight) -> None:
    # prefilled with the optimiser's proposal
    page.wait_for_function(f"document.getElementById('sequence').value === "
                           f"'{', '.join(map(str, PROPOSAL))}'", timeout=WAIT_MS)
    before = len(flight.listener.heard)
    page.fill("#sequence", "5, 2, 9")
    page.click("#send-sequence")
    page.wait_for_function("document.getElementById('command-status').textContent === "
                           "'sequence sent'", timeout=WAIT_MS)
    flight.wait_for_command(before + 1)
    assert flight.commands()[before:] == [(_command("SEQUENCE"), [5, 2, 9])]
    page.screenshot(path=str(OUTPUT / "sequence_sent.png"))


def test_the_buttons_send_start_pause_resume_abort_in_order(page: Any, flight: Flight) -> None:
    before = len(flight.listener.heard)
    for name in ("start", "pause", "resume", "abort"):
        page.click(f"#btn-{name}")
        page.wait_for_function(f"document.getElementById('command-status').textContent === "
                               f"'{name} sent'", timeout=WAIT_MS)
    flight.wait_for_command(before + 4)
    assert [c for c, _ in flight.commands()[before:]] == [
        _command(n) for n in ("START", "PAUSE", "RESUME", "ABORT")]


def test_a_command_without_the_token_is_refused(browser: Any, flight: Flight) -> None:
    before = len(flight.listener.heard)
    page = browser.new_page(viewport={"width": 1600, "height": 1000})
    try:
        page.goto(flight.url.split("#", 1)[0])  # no token in the address
        page.click("#btn-abort")
        page.wait_for_function("document.getElementById('command-status').textContent"
                               ".startsWith('refused')", timeout=WAIT_MS)
        page.fill("#token", "wrong-token")
        page.click("#btn-abort")
        page.wait_for_function("document.getElementById('commands').textContent"
                               ".includes('refused (missing or wrong token)')", timeout=WAIT_MS)
        page.screenshot(path=str(OUTPUT / "refused.png"))
    finally:
        page.close()
    request = urllib.request.Request(flight.url.split("#", 1)[0] + "api/command",
                                     data=b'{"command": "abort"}', method="POST",
                                     headers={"Content-Type": "application/json"})
    with pytest.raises(urllib.error.HTTPError) as refused:
        urllib.request.urlopen(request, timeout=10)
    assert refused.value.code == 401
    time.sleep(0.5)  # a command tick or more: nothing may arrive
    assert len(flight.listener.heard) == before
    log = [json.loads(line) for line in (flight.out / COMMAND_LOG).read_text().splitlines()]
    refusals = [e for e in log if not e["accepted"]]
    assert len(refusals) >= 3 and all(e["reason"] == "missing or wrong token" for e in refusals)


# Everything the operator needs, by selector: the right column's controls above all (the
# Resume button and the sequence's label were cut off at 1400 px wide by a fixed-width grid).
OPERATOR_CONTROLS = ("#btn-start", "#btn-pause", "#btn-resume", "#btn-abort",
                     "label:has(#sequence)", "#sequence", "#send-sequence", "#token",
                     "#map", "#fsm", "#camera")


@pytest.mark.parametrize("width", [1280, 1400])
def test_the_page_fits_a_laptop_screen(browser: Any, flight: Flight, width: int) -> None:
    page = browser.new_page(viewport={"width": width, "height": 800})
    try:
        page.goto(flight.url)
        # live content in every column: the pose under the map, the proposal beside its box
        page.wait_for_function("document.getElementById('pose').textContent.startsWith('x ')",
                               timeout=WAIT_MS)
        page.wait_for_function("document.getElementById('proposal-note').textContent !== ''",
                               timeout=WAIT_MS)
        page.screenshot(path=str(OUTPUT / f"width_{width}.png"), full_page=True)
        scroll_width = page.evaluate("document.documentElement.scrollWidth")
        assert scroll_width <= width, f"the page scrolls sideways: {scroll_width} px wide"
        for selector in OPERATOR_CONTROLS:
            box = page.locator(selector).bounding_box()
            assert page.locator(selector).is_visible() and box is not None, selector
            assert box["x"] >= 0 and box["x"] + box["width"] <= width, (
                f"{selector} spans x {box['x']:.0f}..{box['x'] + box['width']:.0f} px, "
                f"outside the {width} px window")
        cut = page.evaluate("""() => [...document.querySelectorAll('main *')]
            .filter(e => { const r = e.getBoundingClientRect();
                           return r.width > 0 && (r.left < -0.5 || r.right > innerWidth + 0.5); })
            .map(e => e.id || e.tagName)""")
        assert cut == [], f"cut off at the window's edge: {cut}"
    finally:
        page.close()
