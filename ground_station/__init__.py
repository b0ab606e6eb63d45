"""Ground station: MCAP recording, the Foxglove bridge and the operator's web page."""

__all__: list[str] = []
