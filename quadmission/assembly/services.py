"""What can run beside any scenario: real-time pacing, a bag recording, the Foxglove
bridge and the operator page (``quadmission sim --rtf X --record --foxglove --gcs``).

The app layer is where the arena (simulator data) becomes the page's
:class:`~ground_station.layout.FieldLayout`; the ground station itself never sees the
simulator. A scenario calls :meth:`RunServices.attach` around its world run; the CLI
keeps the page up after the run when asked to.
"""

from __future__ import annotations

import json
import shutil
from collections.abc import Callable, Iterator
from contextlib import ExitStack, contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ground_station.bag import METADATA_NAME
from ground_station.layout import Box, FieldLayout, PadInfo
from quadmission.assembly.pacing import RealTimePacer
from quadmission.errors import OptionsError
from runtime import DeterministicExecutor

if TYPE_CHECKING:
    from ground_station.foxglove_bridge_node import FoxgloveBridgeNode
    from ground_station.gcs_node import GroundStationNode
    from ground_station.recorder_node import BagRecorderNode
    from ground_station.server import GroundStationServer
    from runtime.launch import NodeSpec
    from sim.arena import ArenaSpec
    from sim.world import Part, Scene

BAG_DIR = "bag"  # the run's recording: OUT/bag/bag_0.mcap + metadata.yaml
COMMAND_LOG = "gcs_commands.jsonl"
FIELD_JSON = "field.json"  # the run's FieldLayout, for GroundStationServerNode's layout_file
PROCESS_GROUP = "ground_station"  # where process_nodes() run in a launch over processes


def field_layout(arena: ArenaSpec) -> FieldLayout:
    """The page's view of ``arena``: what the organisers hand the team."""
    from sim.arena import PAD_SIZE

    return FieldLayout(
        name=arena.name, size=tuple(float(v) for v in arena.field.size),  # type: ignore[arg-type]
        obstacles=tuple(Box(f"obstacle_{i}", (float(o.center[0]), float(o.center[1])),
                            (float(o.size[0]), float(o.size[1])), float(o.size[2]))
                        for i, o in enumerate(arena.obstacles)),
        pads=tuple(PadInfo(p.id, (float(p.center[0]), float(p.center[1])), PAD_SIZE)
                   for p in arena.pads),
        start_pad=arena.start_pad,
        points=tuple((r.marker_id, tuple(r.points)) for r in arena.robots))


@dataclass(frozen=True)
class GcsOptions:
    """Where the page is served; None: the node's parameters (config/ground_station.yaml)."""

    host: str | None = None
    port: int | None = None
    token: str = ""


@dataclass
class RunServices:
    """Options and, once attached, the running pieces."""

    rtf: float | None = None
    record: bool = False
    foxglove: bool = False
    foxglove_host: str = "127.0.0.1"
    foxglove_port: int = 8765
    gcs: GcsOptions | None = None
    origin_host_s: float | None = None  # host monotonic time of simulated time 0
    say: Callable[[str], None] = field(default=lambda _line: None, repr=False)
    recorder: BagRecorderNode | None = None
    bridge: FoxgloveBridgeNode | None = None
    station: GroundStationNode | None = None
    server: GroundStationServer | None = None

    def __post_init__(self) -> None:
        if self.rtf is not None and not self.rtf > 0:
            raise OptionsError(f"--rtf must be > 0, got {self.rtf}")
        if self.gcs is not None and self.rtf is None:
            self.rtf = 1.0  # a person watches: real time

    @contextmanager
    def attach(self, executor: DeterministicExecutor, parts: list[Part], out: Path,
               arena: ArenaSpec | None = None,
               camera_scene: Scene | None = None) -> Iterator[RunServices]:
        """Start what was asked for in ``executor`` (pacer into ``parts``); on exit, seal
        the bag and stop the bridge. The page's server stays up (:meth:`close` stops it).
        ``camera_scene``: a scenario without cameras of its own gets the down camera for
        the page (rendered only while someone subscribes)."""
        stack = ExitStack()
        try:  # a piece that fails to start (a taken port) still closes the ones before it
            self._start(executor, parts, out, arena, camera_scene, stack)
            yield self
        finally:
            stack.close()
            if self.recorder is not None:
                self.recorder.close()
                self.say(f"  bag: {self.recorder.bag.message_count} messages in "
                         f"{self.recorder.bag.path}")
            if self.bridge is not None:
                self.bridge.close()

    def _start(self, executor: DeterministicExecutor, parts: list[Part], out: Path,
               arena: ArenaSpec | None, camera_scene: Scene | None, stack: ExitStack) -> None:
        context = executor.context
        if camera_scene is not None and self.gcs is not None:
            from sim.render import SceneRenderer
            from sim.sensors import DownCamera, SimSensorsNode, sensor_parts

            sensors = SimSensorsNode(context=context)
            executor.add_node(sensors)
            renderer = stack.enter_context(SceneRenderer(camera_scene.model))
            parts.extend(p for p in sensor_parts(sensors, renderer, camera_scene)
                         if isinstance(p, DownCamera))
        if self.rtf is not None:
            parts.append(RealTimePacer(self.rtf, origin_host_s=self.origin_host_s))
        if self.record:
            from ground_station.recorder_node import BagRecorderNode

            folder = out / BAG_DIR
            _clear_old_bag(folder)
            self.recorder = BagRecorderNode(folder, context=context)
            executor.add_node(self.recorder)
            self.say(f"  recording to {self.recorder.bag.path}")
        if self.foxglove:
            from ground_station.foxglove_bridge_node import FoxgloveBridgeNode

            self.bridge = FoxgloveBridgeNode(context=context, parameter_overrides={
                "host": self.foxglove_host, "port": self.foxglove_port})
            executor.add_node(self.bridge)
            self.say(f"  Foxglove: open connection {self.bridge.url}")
        if self.gcs is not None:
            self._start_gcs(executor, out, arena)

    def _start_gcs(self, executor: DeterministicExecutor, out: Path,
                   arena: ArenaSpec | None) -> None:
        from ground_station.gcs_node import GroundStationNode
        from ground_station.server import GroundStationServer, ServerConfig, resolve_token

        assert self.gcs is not None
        layout = field_layout(arena) if arena else None
        self.station = GroundStationNode(layout, context=executor.context)
        executor.add_node(self.station)
        out.mkdir(parents=True, exist_ok=True)
        if layout is not None:  # for a ground station started elsewhere (layout_file)
            (out / FIELD_JSON).write_text(json.dumps(layout.to_json(), indent=1))
        params = self.station.params
        config = ServerConfig(host=params.host if self.gcs.host is None else self.gcs.host,
                              port=params.port if self.gcs.port is None else self.gcs.port,
                              token=self.gcs.token or resolve_token(),
                              command_log=out / COMMAND_LOG)
        self.server = GroundStationServer(self.station.view, self.station.submit,
                                          config).start()
        self.say(f"  ground station: {self.server.operator_url()}")
        self.say(f"  command token: {config.token}")

    def process_nodes(self, out: Path) -> tuple[NodeSpec, ...]:
        """The recorder, the Foxglove bridge and the page as launch-file nodes, in a
        process group of their own (:data:`PROCESS_GROUP`), for a launch over processes:
        there they discover the graph's topics like any other node. The bag goes to
        ``out/bag``; the page's command token comes from ``$QUADMISSION_GCS_TOKEN`` (the
        caller sets it to ``gcs.token``)."""
        from runtime.launch import NodeSpec

        nodes = []
        if self.record:
            folder = out / BAG_DIR
            _clear_old_bag(folder)
            nodes.append(NodeSpec("ground_station.recorder_node:BagRecorderNode",
                                  process=PROCESS_GROUP,
                                  parameters={"folder": str(folder.resolve())}))
        if self.foxglove:
            nodes.append(NodeSpec("ground_station.foxglove_bridge_node:FoxgloveBridgeNode",
                                  process=PROCESS_GROUP, parameters={
                                      "host": self.foxglove_host, "port": self.foxglove_port}))
        if self.gcs is not None:
            where = {k: v for k, v in (("host", self.gcs.host), ("port", self.gcs.port))
                     if v is not None}
            nodes.append(NodeSpec("ground_station.gcs_server_node:GroundStationServerNode",
                                  process=PROCESS_GROUP, parameters=where))
        return tuple(nodes)

    def close(self) -> None:
        if self.server is not None:
            self.server.stop()
            self.server = None


def _clear_old_bag(folder: Path) -> None:
    """A rerun into the same --out replaces the run's previous recording."""
    if not folder.exists():
        return
    leftovers = [p for p in folder.iterdir()
                 if p.suffix != ".mcap" and p.name != METADATA_NAME
                 and not p.name.endswith((".mcap.repair", ".tmp"))]
    if leftovers:
        raise OptionsError(f"{folder} holds files that are not a bag ({leftovers[0].name}); "
                           f"move them or choose another --out")
    shutil.rmtree(folder)


def attach_services(options: Any, executor: DeterministicExecutor, parts: list[Part],
                    arena: ArenaSpec | None = None, camera_scene: Scene | None = None) -> Any:
    """``options.services.attach(...)`` when the run asked for any, else a no-op context."""
    services: RunServices | None = getattr(options, "services", None)
    if services is None:
        return _nothing()
    return services.attach(executor, parts, options.out, arena, camera_scene)


@contextmanager
def _nothing() -> Iterator[None]:
    yield None


__all__ = ["BAG_DIR", "COMMAND_LOG", "FIELD_JSON", "PROCESS_GROUP", "GcsOptions", "RunServices",
           "attach_services", "field_layout"]
