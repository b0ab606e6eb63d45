"""A run's outputs for a person: report.json and the pictures (matplotlib, Agg)."""

__all__: list[str] = []
