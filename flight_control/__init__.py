"""quadmission flight_control layer (see DESIGN.md, Layers)."""

__all__: list[str] = []
