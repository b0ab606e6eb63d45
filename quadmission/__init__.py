"""quadmission: an autonomous quadcopter mission stack for indoor drone contests."""

__all__: list[str] = []
__version__ = "0.1.0"
