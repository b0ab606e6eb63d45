"""The ``mission`` scenario: the whole contest through the real nodes, in one process or
launched as processes."""


__all__: list[str] = []
