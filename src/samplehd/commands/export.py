"""Export a dataset: `export lerobot DIR --out DIR2` (LeRobot v3.0 layout: parquet + AV1 videos of RGB;
depth [mm] and segmentation ids as opt-in uint16 arrays), `export rerun EPISODE --out FILE.rrd` (one
episode as a Rerun recording) or
`export sample-hd DIR --out DIR2` (the files SAMPLE-HD's own Python code reads; its four families only)."""

from __future__ import annotations

import argparse
import re
from pathlib import Path
from typing import Any

from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

from samplehd.commands._options import DefaultsHelpFormatter, check_int, split_names
from samplehd.dataset.outputs import check_outputs
from samplehd.errors import ConfigError, require_extra
from samplehd.export.lerobot import export_lerobot
from samplehd.export.rerun_recording import episode_location, export_rerun
from samplehd.export.sample_hd import export_samplehd
from samplehd.workers import Backend, default_workers

HELP = "export a dataset to LeRobot v3.0 or SAMPLE-HD's layout, or an episode to a Rerun recording"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="format", metavar="FORMAT", required=True)
    lr = sub.add_parser("lerobot", help="LeRobot v3.0 (meta/, data/, videos/)",
                        formatter_class=DefaultsHelpFormatter)
    lr.add_argument("dir", type=Path, help="samplehd dataset")
    lr.add_argument("--out", type=Path, required=True, help="new LeRobot dataset folder")
    lr.add_argument("--repo-id", default="samplehd/dataset", help="repo id recorded for LeRobotDataset(repo_id, root=)")
    lr.add_argument("--codec", help="video encoder (default: libsvtav1 as LeRobot, else libx264)")
    lr.add_argument("--cameras", nargs="+", help="cameras to export (default: all stored)")
    lr.add_argument("--modalities", nargs="+",
                    help="rgb (video), depth (uint16 mm array), segmentation (uint16 id array); default: rgb")
    lr.add_argument("--depth-video", action="store_true",
                    help="depth as LeRobot's native depth video observation.images.<camera>_depth (lossless 12-bit "
                         "log codes, HEVC; LeRobot >= 0.6 decodes it) instead of the uint16 mm array")
    lr.add_argument("--frames-per-file", type=int, default=200_000, help="frames per data/video file")
    rr = sub.add_parser("rerun", help="one episode as a Rerun recording (.rrd): 3-D scene, cameras, series, subtasks",
                        formatter_class=DefaultsHelpFormatter)
    rr.add_argument("episode", type=Path, help="episode file (DIR/episodes/<stem>.h5) or dataset folder with --episode")
    rr.add_argument("--episode", dest="index", type=int, help="episode index when EPISODE is a dataset folder (0)")
    rr.add_argument("--out", type=Path, required=True, help="the .rrd file (open it with: rerun FILE.rrd)")
    sh = sub.add_parser("sample-hd", help="the files SAMPLE-HD's own code reads (images/, scenes/, instructions/, "
                        "sequences/); its four families only", formatter_class=DefaultsHelpFormatter)
    sh.add_argument("dir", type=Path, help="samplehd dataset")
    sh.add_argument("--out", type=Path, required=True, help="new folder")
    sh.add_argument("--previews", action="store_true", help="write preview.mp4 per sequence")
    sh.add_argument("--no-images", action="store_true", help="write data.json/effector.json only, no per-frame images")
    sh.add_argument("--camera", help="stored camera whose images become the sequence images (default: scene)")
    sh.add_argument("--workers", type=int, default=default_workers(), help="worker processes")


def summary_line(summary: dict[str, Any]) -> str:
    """An exporter's summary as words for the terminal ("episodes 8; frames 2124; videos observation.images.scene"):
    counts and names, not Python reprs; nested tables (the left-out reasons) are printed on their own lines."""
    parts = []
    for key, value in summary.items():
        if isinstance(value, dict):
            continue
        if isinstance(value, (list, tuple)):
            value = ", ".join(str(v) for v in value) if value else "none"
        parts.append(f"{key.replace('_', ' ')} {value}")
    return "; ".join(parts)


def run(args: argparse.Namespace) -> int:
    check_int("--frames-per-file", getattr(args, "frames_per_file", None), 1)
    check_int("--workers", getattr(args, "workers", None), 1)
    if getattr(args, "previews", False) and args.no_images:
        raise ConfigError("--previews with --no-images: the previews are made from the sequence images; "
                          "leave out one of them")
    source = args.episode if args.format == "rerun" else args.dir
    check_outputs({"--out": args.out}, {"EPISODE" if args.format == "rerun" else "DIR": source})
    if args.format == "rerun":
        require_extra("rerun", "rerun", "samplehd export rerun")
        require_extra("trimesh", "rerun", "samplehd export rerun")
        root, index = episode_location(args.episode, args.index)
        res = export_rerun(root, index, args.out)
        print(f"exported episode {index} of {root} to {args.out}: {summary_line(res)}; open it with: rerun {args.out}")
        return 0
    if args.format == "lerobot":
        require_extra("pyarrow", "lerobot", "samplehd export lerobot")
        if not re.fullmatch(r"[\w.-]+/[\w.-]+", args.repo_id):
            raise ConfigError(f"--repo-id {args.repo_id!r}: must be OWNER/NAME (letters, digits, '_', '-', '.')")
    with Progress(TextColumn(f"export {args.format}"), BarColumn(), MofNCompleteColumn(),
                  TimeRemainingColumn()) as bar:
        task = bar.add_task("episodes", total=None)

        def tick(done: int, total: int) -> None:
            bar.update(task, completed=done, total=total)

        if args.format == "lerobot":
            res = export_lerobot(args.dir, args.out, args.repo_id, args.codec, args.frames_per_file,
                                 list(split_names(args.cameras, "--cameras")) or None, progress=tick,
                                 modalities=list(split_names(args.modalities, "--modalities")) or None,
                                 depth_video=args.depth_video)
        else:
            res = export_samplehd(args.dir, args.out, images=not args.no_images, previews=args.previews,
                                  camera=args.camera, backend=Backend("local", args.workers), progress=tick)
            for reason, n in res["left_out"].items():
                print(f"left out {n} instruction(s): {reason}")
            if res["pick_order_differs"]:
                print(f"{res['pick_order_differs']} sequence(s) pick their objects in another order than SAMPLE-HD's "
                      f"preprocessing assumes (nearest the effector first; this dataset: paths.planner.order "
                      f"{res['pick_order']}); generate with paths.planner.order nearest, as the sample-hd preset does")
    print(f"exported to {args.out}: {summary_line(res)}")
    return 0
