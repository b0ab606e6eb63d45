"""MuJoCo arena, quadrotor, sensors and simulated flight controller: the only MuJoCo user."""

__all__: list[str] = []
