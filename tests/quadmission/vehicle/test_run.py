"""The vehicle's options: what ``fly-realtime`` hands ``quadmission vehicle`` is what the
user gave, and a fault the vehicle cannot play is refused before anything starts."""

from __future__ import annotations

from pathlib import Path

import pytest

from quadmission.cli import _vehicle_options, build_parser
from quadmission.errors import OptionsError
from quadmission.vehicle.run import VehicleOptions, _tick_hz
from sim.arena import Lighting
from sim.fault_spec import parse_faults

#: a domain that never reaches a graph: these options only cross the command line and back
#: (test_domains' check of hard-coded domains looks for processes started on one)
ROUND_TRIP_DOMAIN = 91


@pytest.mark.parametrize("options", [
    VehicleOptions(out=Path("o")),
    VehicleOptions(out=Path("/x/v"), seed=7, arena=Path("a.yaml"), lighting=Lighting.DARK,
                   faults=tuple(parse_faults(["vio_stop@30:2", "wind_gust@5:1,force=3"])),
                   rtf=0.5, domain_id=ROUND_TRIP_DOMAIN, loopback_only=False, duration_s=120.0,
                   config_dir=Path("/c")),
    VehicleOptions(out=Path("o"), random_arena=True, seed=3),
])
def test_its_command_line_gives_back_the_same_options(options: VehicleOptions) -> None:
    args = build_parser().parse_args(["vehicle", *options.argv()])
    again = _vehicle_options(args, args.out)
    assert again == options


def test_a_companions_fault_is_refused_naming_the_vehicles_kinds() -> None:
    with pytest.raises(OptionsError, match=r"node_stop: not a fault of the vehicle.*vio_stop"):
        VehicleOptions(out=Path("o"), faults=tuple(parse_faults(["node_stop@5,name=x"])))


@pytest.mark.parametrize(("physics_hz", "tick_hz"), [(1000, 1000.0), (2000, 1000.0),
                                                     (500, 500.0), (1500, 750.0)])
def test_the_pacing_rate_divides_the_physics_rate_up_to_1_khz(physics_hz: int,
                                                              tick_hz: float) -> None:
    assert _tick_hz(physics_hz) == tick_hz
