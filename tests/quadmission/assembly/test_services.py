"""quadmission/assembly/services.py: a service that fails to start leaves nothing open."""

from __future__ import annotations

import socket
from pathlib import Path

import pytest

from ground_station.bag import METADATA_NAME
from ground_station.errors import GroundStationError
from quadmission.assembly.services import BAG_DIR, GcsOptions, RunServices
from runtime import DeterministicExecutor


def test_a_page_that_cannot_bind_still_seals_the_bag(tmp_path: Path) -> None:
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        port = busy.getsockname()[1]
        services = RunServices(record=True, gcs=GcsOptions(port=port, token="t"))
        with (pytest.raises(GroundStationError, match=str(port)),
              services.attach(DeterministicExecutor(), [], tmp_path)):
            pytest.fail("attach should not have yielded")
    assert services.recorder is not None
    assert services.recorder.bag.closed, "the bag was left open"
    assert (tmp_path / BAG_DIR / METADATA_NAME).is_file()
