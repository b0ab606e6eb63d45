"""The ``square`` scenario: the companion flies a square fitted to the arena; its pilot,
its launch factories and its status node."""


__all__: list[str] = []
