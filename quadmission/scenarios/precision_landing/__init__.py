"""The ``precision-landing`` scenario: one precision landing per pad, judged from truth."""

__all__: list[str] = []
