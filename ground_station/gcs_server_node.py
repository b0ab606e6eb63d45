"""The ground station as one launch-file node: the node and its web server together.

For a launch over any transport (``quadmission launch FILE [--transport ros2]``): add

    - factory: ground_station.gcs_server_node:GroundStationServerNode
      parameters: {layout_file: runs/x/field.json}

The page is served at ``host:port`` from ``config/ground_station.yaml``; the command token
is ``$QUADMISSION_GCS_TOKEN`` or drawn at start, and the page's address with it is logged.
Commands are logged to the node's logger (``quadmission sim --gcs`` also keeps
``OUT/gcs_commands.jsonl``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from ground_station.gcs_node import GroundStationNode
from ground_station.layout import load_layout
from ground_station.server import GroundStationServer, ServerConfig, resolve_token


class GroundStationServerNode(GroundStationNode):
    def __init__(self, **kwargs: Any) -> None:
        super().__init__(None, **kwargs)
        if self.params.layout_file:
            self.view.layout = load_layout(Path(self.params.layout_file))
        self.server = GroundStationServer(
            self.view, self.submit,
            ServerConfig(host=self.params.host, port=self.params.port,
                         token=resolve_token())).start()
        self.get_logger().info("ground station: %s", self.server.operator_url())

    def destroy_node(self) -> None:
        self.server.stop()
        super().destroy_node()


__all__ = ["GroundStationServerNode"]
