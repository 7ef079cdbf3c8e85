"""Browse a dataset in a web page: scenes with RGB/depth/segmentation and per-object annotations,
instructions with their programs drawn as trees and their targets outlined, and episodes played
back with the subtask timeline and joint, gripper and steering plots.

The server is read-only, binds to 127.0.0.1 unless told otherwise, serves only files inside the
dataset folder, and works offline (every asset ships with the package). A dataset that is still
being written can be browsed: missing files are shown as such and appear when written.
"""

from __future__ import annotations

import argparse
import ipaddress
import json
from pathlib import Path

from samplehd.dataset.layout import FORMAT_VERSION, INFO_FILE
from samplehd.errors import ConfigError, DatasetError
from samplehd.viewer.server import make_server

HELP = "browse a dataset in a web page (scenes, instructions, programs, episodes)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("dataset", type=Path, metavar="DIR", help="dataset folder (or a `samplehd scenes` folder)")
    parser.add_argument("--host", default="127.0.0.1",
                        help="address to bind: a loopback address, or (with --allow-remote) one the network reaches")
    parser.add_argument("--allow-remote", action="store_true",
                        help="allow a --host that is not a loopback address (0.0.0.0 serves the dataset to the "
                             "network, with no authentication)")
    parser.add_argument("--port", type=int, default=8000, help="port (0 picks a free one)")
    parser.add_argument("--no-render", action="store_true",
                        help="do not render frames of episodes stored without images (--render none datasets) "
                             "from their recorded states; show their top view only")
    parser.add_argument("--verbose", action="store_true", help="log every request")


def run(args: argparse.Namespace) -> int:
    if not 0 <= args.port <= 65535:
        raise ConfigError(f"--port {args.port}: must be in 0..65535")
    _check_host(args.host, args.allow_remote)
    _check_folder(args.dataset)
    try:
        server = make_server(args.dataset, args.host, args.port, verbose=args.verbose, render=not args.no_render)
    except OSError as exc:
        raise ConfigError(f"--host {args.host} --port {args.port}: cannot listen ({exc.strerror or exc}); "
                          f"pick another --port") from exc
    status = server.app.index.status()
    counts = status["counts"]
    print(f"samplehd view: {status['root']} — {counts['scenes']} scenes, {counts['instructions']} instructions, "
          f"{counts['episodes']} episodes")
    print(f"serving on {server.url} (Ctrl-C to stop)", flush=True)
    # SIGTERM stops the server as Ctrl-C does (cli.main: sigterm_as_interrupt); a server started in the
    # background of a script gets SIGINT ignored by the shell, so `kill` is how it is stopped there.
    try:
        server.serve_forever()
    except KeyboardInterrupt:
        print("stopped")
    finally:
        server.server_close()
    return 0


def _check_host(host: str, allow_remote: bool) -> None:
    """A loopback address unless the user asked to serve to the network (an empty host binds every
    interface)."""
    if allow_remote or host == "localhost":
        return
    try:
        loopback = ipaddress.ip_address(host).is_loopback
    except ValueError:
        loopback = False
    if not loopback:
        raise ConfigError(f"--host {host!r}: not a loopback address (127.0.0.1, ::1, localhost); serving the "
                          f"dataset to other machines needs --allow-remote")


def _check_folder(root: Path) -> None:
    """A dataset or scenes folder, of a format this samplehd reads (the viewer shows one being written)."""
    if not root.is_dir():
        return  # the viewer names a missing folder or a file itself
    try:
        info = json.loads((root / INFO_FILE).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return  # no or partial info.json: a scenes folder, or a dataset being started
    version = info.get("format_version") if isinstance(info, dict) else None
    if version != FORMAT_VERSION:
        raise DatasetError(f"{root / INFO_FILE}: format_version {version!r} is not one this samplehd reads "
                           f"(valid: {FORMAT_VERSION!r})")
