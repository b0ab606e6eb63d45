"""Experiments that reproduce a paper's measurement in our SITL (seed 000's latency test)."""

__all__: list[str] = []
