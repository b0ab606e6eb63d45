"""Flights judged against ground truth: tracking, touchdowns, the contest score (app only)."""


__all__: list[str] = []
