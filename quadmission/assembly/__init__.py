"""The simulator and the companion put together: the companion on a SITL, the services
beside a run (pacing, recording, Foxglove, the operator page), the offboard harness."""


__all__: list[str] = []
