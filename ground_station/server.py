"""The operator page's web server: static page, live state, camera, authenticated commands.

Routes: ``GET /`` (the page, ``web/``), ``GET /api/state`` (the view's snapshot, JSON),
``GET /api/diagram`` (the mission machine's states and transitions),
``GET /api/camera.jpg``, ``GET /api/robot/<id>.jpg``, ``POST /api/command`` (JSON, see
:mod:`ground_station.commands`). Reading is open; every command must carry the token
(``Authorization: Bearer <token>``), compared in constant time. Each command, accepted
or refused, is logged (logger ``quadmission.gcs``, and one JSON line in ``command_log``
when given) and shown on the page. It binds to loopback unless told otherwise.

The server runs in its own thread (stdlib ``ThreadingHTTPServer``); it reads the view
under its lock and hands commands to the node's queue, never touching the executor.
"""

from __future__ import annotations

import hmac
import json
import logging
import os
import secrets
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from http import HTTPStatus
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import Any

from ground_station.commands import OperatorCommand, parse_command
from ground_station.diagram import diagram
from ground_station.errors import CommandError, GroundStationError
from ground_station.view import OperatorView

TOKEN_ENV = "QUADMISSION_GCS_TOKEN"
DEFAULT_HOST = "127.0.0.1"
DEFAULT_PORT = 8080
MAX_BODY_BYTES = 16 * 1024
WEB_DIR = Path(__file__).parent / "web"
_STATIC = {"/": ("index.html", "text/html; charset=utf-8"),
           "/index.html": ("index.html", "text/html; charset=utf-8"),
           "/app.js": ("app.js", "text/javascript; charset=utf-8"),
           "/style.css": ("style.css", "text/css; charset=utf-8")}
_log = logging.getLogger("quadmission.gcs")


def resolve_token(env: dict[str, str] | None = None) -> str:
    """The command token: ``$QUADMISSION_GCS_TOKEN`` when set, else a fresh random one."""
    value = (os.environ if env is None else env).get(TOKEN_ENV, "")
    return value or secrets.token_urlsafe(18)


@dataclass(frozen=True)
class ServerConfig:
    host: str = DEFAULT_HOST
    port: int = DEFAULT_PORT  # 0: a free port
    token: str = ""
    command_log: Path | None = None  # JSON lines, one per command received


class _Server(ThreadingHTTPServer):
    """The stdlib server, its request errors logged instead of printed to stderr: a page
    that closes its connection mid-answer is routine, anything else a logged error."""

    def handle_error(self, request: Any, client_address: Any) -> None:
        error = sys.exc_info()[1]
        if isinstance(error, (BrokenPipeError, ConnectionResetError, TimeoutError)):
            _log.debug("ground station: %s from %s", type(error).__name__, client_address)
        else:
            _log.exception("ground station: a request from %s failed", client_address)


class GroundStationServer:
    """Serves ``view`` and passes commands to ``submit`` (the node's queue)."""

    def __init__(self, view: OperatorView, submit: Callable[[OperatorCommand], None],
                 config: ServerConfig) -> None:
        if not config.token:
            raise ValueError("the ground station needs a command token")
        self.view = view
        self.submit = submit
        self.config = config
        self._log_lock = threading.Lock()
        handler = type("Handler", (_Handler,), {"station": self})
        try:
            self.httpd = _Server((config.host, config.port), handler)
        except OSError as exc:
            raise GroundStationError(f"the ground station cannot serve on "
                                     f"{config.host}:{config.port}: {exc.strerror or exc}; "
                                     "choose another --port (0: any free one)") from None
        self.httpd.daemon_threads = True
        host, port = self.httpd.server_address[:2]
        self.host = host.decode() if isinstance(host, bytes) else str(host)
        self.port = int(port)
        self._thread = threading.Thread(target=self.httpd.serve_forever, name="gcs-http",
                                        daemon=True)

    @property
    def url(self) -> str:
        return f"http://{self.host}:{self.port}/"

    def operator_url(self) -> str:
        """The page's address with the token in the fragment (never sent to the server)."""
        return f"{self.url}#token={self.config.token}"

    def start(self) -> GroundStationServer:
        self._thread.start()
        return self

    def stop(self) -> None:
        """Stop serving and close the socket (also when :meth:`start` was never called:
        ``shutdown()`` would then wait forever)."""
        if self._thread.is_alive():
            self.httpd.shutdown()
            self._thread.join()
        self.httpd.server_close()

    def authorised(self, header: str | None) -> bool:
        if not header or not header.startswith("Bearer "):
            return False
        return hmac.compare_digest(header[len("Bearer "):].encode(),
                                   self.config.token.encode())

    def record(self, entry: dict[str, Any]) -> None:
        """Log one command (accepted or refused) everywhere it is kept."""
        entry = {"wall_time": round(time.time(), 3), "t_s": self.view.t_s} | entry
        level = logging.INFO if entry.get("accepted") else logging.WARNING
        _log.log(level, "command %s from %s: %s", entry.get("command"), entry.get("client"),
                 "accepted" if entry.get("accepted") else f"refused ({entry.get('reason')})")
        self.view.on_command(entry)
        if self.config.command_log is not None:
            with self._log_lock, self.config.command_log.open("a") as f:
                f.write(json.dumps(entry) + "\n")


class _Handler(BaseHTTPRequestHandler):
    station: GroundStationServer
    server_version = "quadmission-gcs"

    def log_message(self, format: str, *args: Any) -> None:
        _log.debug("%s " + format, self.client_address[0], *args)

    def _send(self, status: int, body: bytes, content_type: str) -> None:
        self.send_response(status)
        self.send_header("Content-Type", content_type)
        self.send_header("Content-Length", str(len(body)))
        self.send_header("Cache-Control", "no-store")
        self.end_headers()
        self.wfile.write(body)

    def _json(self, status: int, data: Any) -> None:
        self._send(status, json.dumps(data, allow_nan=False).encode(), "application/json")

    def do_GET(self) -> None:
        path = self.path.split("?", 1)[0]
        if path in _STATIC:
            name, ctype = _STATIC[path]
            self._send(HTTPStatus.OK, (WEB_DIR / name).read_bytes(), ctype)
        elif path == "/api/state":
            self._json(HTTPStatus.OK, self.station.view.snapshot())
        elif path == "/api/diagram":
            self._json(HTTPStatus.OK, diagram())
        elif path == "/api/camera.jpg":
            self._image(self.station.view.camera())
        elif path.startswith("/api/robot/") and path.endswith(".jpg"):
            try:
                marker = int(path[len("/api/robot/"):-len(".jpg")])
            except ValueError:
                self._json(HTTPStatus.NOT_FOUND, {"error": "no such robot"})
                return
            self._image(self.station.view.robot_jpeg(marker))
        else:
            self._json(HTTPStatus.NOT_FOUND, {"error": f"no page {path}"})

    def _image(self, data: bytes | None) -> None:
        if data is None:
            self._json(HTTPStatus.NOT_FOUND, {"error": "no picture yet"})
        else:
            self._send(HTTPStatus.OK, data, "image/jpeg")

    def do_POST(self) -> None:
        if self.path.split("?", 1)[0] != "/api/command":
            self._json(HTTPStatus.NOT_FOUND, {"error": f"no endpoint {self.path}"})
            return
        client = self.client_address[0]
        try:
            length = int(self.headers.get("Content-Length") or 0)
        except ValueError:
            length = -1
        if length < 0:
            self._json(HTTPStatus.BAD_REQUEST,
                       {"ok": False, "error": "Content-Length is not a byte count"})
            return
        body = self.rfile.read(min(length, MAX_BODY_BYTES + 1))
        try:
            payload = json.loads(body or b"null")
        except ValueError:
            payload = None
        name = payload.get("command") if isinstance(payload, dict) else None
        if not self.station.authorised(self.headers.get("Authorization")):
            self.station.record({"client": client, "command": name, "accepted": False,
                                 "reason": "missing or wrong token"})
            self._json(HTTPStatus.UNAUTHORIZED,
                       {"ok": False, "error": "refused: missing or wrong token"})
            return
        if length > MAX_BODY_BYTES:
            self._json(HTTPStatus.REQUEST_ENTITY_TOO_LARGE, {"ok": False, "error": "too big"})
            return
        layout = self.station.view.layout
        try:
            command = parse_command(payload, layout.pad_ids if layout else ())
        except CommandError as exc:
            self.station.record({"client": client, "command": name, "accepted": False,
                                 "reason": str(exc)})
            self._json(HTTPStatus.BAD_REQUEST, {"ok": False, "error": str(exc)})
            return
        self.station.submit(command)
        self.station.record({"client": client, "command": command.verb.value,
                             "sequence": list(command.sequence), "accepted": True,
                             "reason": command.reason})
        self._json(HTTPStatus.OK, {"ok": True, "command": command.verb.value,
                                   "sequence": list(command.sequence)})


__all__ = ["DEFAULT_HOST", "DEFAULT_PORT", "TOKEN_ENV", "GroundStationServer", "ServerConfig",
           "resolve_token"]
