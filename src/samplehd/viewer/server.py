"""HTTP plumbing of the viewer: a standard-library ``ThreadingHTTPServer`` answering GET/HEAD with
:class:`~samplehd.viewer.app.ViewerApp`. Every other method is refused; nothing is written."""

from __future__ import annotations

import ipaddress
import socket
import sys
import threading
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import Any
from urllib.parse import parse_qsl, urlsplit

from samplehd.render.image_spec import PRESET_NAMES, ImageSpec
from samplehd.viewer.app import SECURITY_HEADERS, Response, ViewerApp
from samplehd.viewer.episodes import open_episode_store
from samplehd.viewer.index import DatasetIndex
from samplehd.viewer.state_render import StateRenderer

__all__ = ["ViewerServer", "make_server", "open_dataset"]


_LOOPBACK_NAMES = {"localhost", "127.0.0.1", "::1"}


def _is_loopback(host: str) -> bool:
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return host.lower() == "localhost"


class _Handler(BaseHTTPRequestHandler):
    """Routes GET/HEAD to the app; 405 for everything else."""

    server: ViewerServer
    protocol_version = "HTTP/1.1"

    def _host_allowed(self) -> bool:
        """On a loopback address, only requests naming a loopback host (no DNS rebinding)."""
        if not self.server.loopback_only:
            return True
        host = (self.headers.get("Host") or "").strip().lower()
        name = host.rsplit("]", 1)[0].lstrip("[") if host.startswith("[") else host.split(":", 1)[0]
        return name in _LOOPBACK_NAMES

    def _answer(self, send_body: bool) -> None:
        if not self._host_allowed():
            response = Response.error(403, "Host header is not a loopback name; the viewer serves only "
                                           "http://127.0.0.1 or http://localhost unless started with --host")
            response.headers = dict(SECURITY_HEADERS)
            self._send(response, send_body)
            return
        split = urlsplit(self.path)
        query = dict(parse_qsl(split.query, keep_blank_values=True))
        response = self.server.app.handle(split.path, query)
        self._send(response, send_body)

    def _send(self, response: Response, send_body: bool) -> None:
        self.send_response(response.status)
        self.send_header("Content-Type", response.content_type)
        self.send_header("Content-Length", str(len(response.body)))
        for key, value in response.headers.items():
            self.send_header(key, value)
        self.end_headers()
        if send_body:
            try:
                self.wfile.write(response.body)
            except (BrokenPipeError, ConnectionResetError):
                pass

    def do_GET(self) -> None:  # noqa: N802 - http.server's naming
        self._answer(send_body=True)

    def do_HEAD(self) -> None:  # noqa: N802
        self._answer(send_body=False)

    def _refuse(self) -> None:
        response = Response.error(405, "the viewer is read-only: only GET and HEAD are allowed")
        response.headers = {**SECURITY_HEADERS, "Allow": "GET, HEAD"}
        self._send(response, send_body=True)

    do_POST = do_PUT = do_DELETE = do_PATCH = _refuse  # noqa: N815

    def log_message(self, format: str, *args: Any) -> None:  # noqa: A002 - signature of the base class
        if self.server.verbose:
            sys.stderr.write(f"{self.address_string()} - {format % args}\n")


class ViewerServer(ThreadingHTTPServer):
    """A threading HTTP server bound to one :class:`ViewerApp`.

    Args:
        address: (host, port); port 0 picks a free port.
        app: the routes.
        verbose: log every request to stderr.
    """

    daemon_threads = True
    allow_reuse_address = True

    def __init__(self, address: tuple[str, int], app: ViewerApp, verbose: bool = False) -> None:
        self.app = app
        self.verbose = verbose
        self.loopback_only = _is_loopback(address[0])
        if ":" in address[0]:
            self.address_family = socket.AF_INET6
        super().__init__(address, _Handler)

    @property
    def url(self) -> str:
        """Base URL of the page."""
        host, port = self.server_address[:2]
        host = str(host)
        shown = f"[{host}]" if ":" in host else host
        return f"http://{shown}:{port}/"

    def server_close(self) -> None:
        """Close the socket and stop the frame renderer, if any."""
        super().server_close()
        renderer = getattr(self.app.index.episodes, "renderer", None)
        if renderer is not None:
            renderer.close()

    def start_in_thread(self) -> threading.Thread:
        """Serve from a daemon thread (for tests and notebooks); stop with ``shutdown()``."""
        thread = threading.Thread(target=self.serve_forever, name="samplehd-viewer", daemon=True)
        thread.start()
        return thread


def open_dataset(root: Path, render: bool = True) -> DatasetIndex:
    """Index a dataset folder, with its episodes when the folder has any.

    Args:
        root: the dataset folder.
        render: render frames of episodes stored without images from their recorded states (at the
            dataset's configured image size, 320×180 if none).

    Raises:
        DatasetError: not a folder, or not a dataset.
    """

    index = DatasetIndex(root)
    renderer = None
    if render:
        info, _ = index.info()
        config = info.get("config") if isinstance(info.get("config"), dict) else {}
        size = config.get("render") if isinstance(config.get("render"), dict) else {}
        width, height = int(size.get("width") or 320), int(size.get("height") or 180)
        mode = size.get("mode")
        renderer = StateRenderer(ImageSpec(width, height, mode if mode in PRESET_NAMES else "fast"))
    index.episodes = open_episode_store(index.root, index.instructions, index.scene, renderer)
    return index


def make_server(root: Path, host: str = "127.0.0.1", port: int = 8000, verbose: bool = False,
                render: bool = True) -> ViewerServer:
    """A viewer server for the dataset at ``root`` (not yet serving; call ``serve_forever``).

    Raises:
        DatasetError: ``root`` is not a dataset.
        OSError: the address is in use or cannot be bound.
    """
    return ViewerServer((host, port), ViewerApp(open_dataset(root, render)), verbose=verbose)
