"""A Ray address is checked before any work starts: a closed port, a listener that is not Ray, and a
silent one are one-line refusals within the timeout; a real cluster's address passes."""

from __future__ import annotations

import socket
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager

import pytest

from samplehd.errors import ConfigError
from samplehd.workers import check_ray_address


@contextmanager
def _listener(reply: bytes) -> Iterator[int]:
    """A TCP listener on 127.0.0.1 that reads what it is sent and answers ``reply`` (nothing: silent)."""
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(1)

    def run() -> None:
        try:
            conn, _ = server.accept()
        except OSError:
            return
        with conn:
            conn.recv(100)
            if reply:
                conn.sendall(reply)
            time.sleep(2.0)

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    try:
        yield server.getsockname()[1]
    finally:
        server.close()


@pytest.mark.parametrize("reply", [b"HTTP/1.1 400 Bad Request\r\n\r\n", b"SSH-2.0-OpenSSH_9.2\r\n", b""],
                         ids=["http1", "ssh", "silent"])
def test_a_listener_that_is_not_ray_is_refused_in_one_line(reply: bytes) -> None:
    with _listener(reply) as port:
        with pytest.raises(ConfigError, match="not a Ray cluster") as info:
            check_ray_address(f"127.0.0.1:{port}", timeout=1.0)
    assert "\n" not in str(info.value) and f"127.0.0.1:{port}" in str(info.value)


def test_a_closed_port_is_refused() -> None:
    with pytest.raises(ConfigError, match="nothing answers"):
        check_ray_address("127.0.0.1:1", timeout=1.0)


def test_a_real_ray_cluster_address_passes() -> None:
    ray = pytest.importorskip("ray")
    ray.init(num_cpus=1, include_dashboard=False, log_to_driver=False)
    try:
        check_ray_address(ray.get_runtime_context().gcs_address)
    finally:
        ray.shutdown()
