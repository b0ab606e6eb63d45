"""ground_station/server.py's error paths: a taken port is named, a server that never
started stops, and a malformed request gets an answer instead of a dropped connection."""

from __future__ import annotations

import http.client
import json
import socket
import threading

import pytest

from ground_station.errors import GroundStationError
from ground_station.server import GroundStationServer, ServerConfig
from ground_station.view import OperatorView

TOKEN = "test-token"


def _server(port: int = 0) -> GroundStationServer:
    return GroundStationServer(OperatorView(), lambda _command: None,
                               ServerConfig(host="127.0.0.1", port=port, token=TOKEN))


def test_a_taken_port_is_named() -> None:
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        port = busy.getsockname()[1]
        with pytest.raises(GroundStationError, match=rf"127\.0\.0\.1:{port}"):
            _server(port)


def test_a_server_that_never_started_stops() -> None:
    server = _server()
    stopper = threading.Thread(target=server.stop, daemon=True)
    stopper.start()
    stopper.join(timeout=10.0)  # a hang detector, not a timing: stop() returns or hangs
    assert not stopper.is_alive(), "stop() hangs when start() was never called"


def test_a_bad_content_length_is_answered_with_400() -> None:
    server = _server().start()
    try:
        conn = http.client.HTTPConnection(server.host, server.port, timeout=10.0)
        conn.putrequest("POST", "/api/command")
        conn.putheader("Authorization", f"Bearer {TOKEN}")
        conn.putheader("Content-Length", "twelve")
        conn.endheaders()
        reply = conn.getresponse()
        assert reply.status == 400
        assert "Content-Length" in json.loads(reply.read())["error"]
        conn.close()
    finally:
        server.stop()


@pytest.mark.parametrize("error", [BrokenPipeError, ConnectionResetError, KeyError])
def test_a_failed_request_is_logged_not_printed(
        error: type[Exception], capsys: pytest.CaptureFixture[str],
        caplog: pytest.LogCaptureFixture) -> None:
    # what the stdlib server calls when a handler raises: a page that hung up mid-answer
    # is routine (debug), anything else an error with its traceback; never bare stderr
    server = _server()
    try:
        caplog.set_level("DEBUG", logger="quadmission.gcs")
        try:
            raise error("boom")
        except error:
            server.httpd.handle_error(None, ("127.0.0.1", 4242))
    finally:
        server.stop()
    assert capsys.readouterr().err == ""
    (record,) = [r for r in caplog.records if "127.0.0.1" in r.getMessage()]
    routine = error is not KeyError
    assert record.levelname == ("DEBUG" if routine else "ERROR")
    assert (record.exc_info is None) == routine
