"""Run a finished dataset's episode units again in this process: their CPU time, and whether the bytes hold.

Reads DATASET's resolved config, scenes and instruction candidates, rebuilds the episode unit of every
candidate (``samplehd.dataset.work.run_episode_unit``, disturbances off) in the dataset's own order, and
runs them into OUT: first one unit untimed (imports, the compiled kernels), then all of them
``--repeats`` times. It prints the units' frames and CPU seconds (each repeat; the least is the
figure least moved by other jobs on the machine) and compares each written episode file's sha256 with
the one in DATASET's journal: an optimisation must leave every one equal.

The scene stage (sampling, settling, scene images) and the instruction stage do not run: the figure is
the per-episode work alone (compiling the unit's model, planning, IK, execution, the checker, the
recording and the file), which ``scripts/generate_stages.py`` splits by stage.

Usage::

    samplehd generate --preset sample-hd --scenes 4 --render none --seed 0 --workers 1 --out DS
    python scripts/rerun_episode_units.py DS OUT [--limit N] [--repeats R]
"""

from __future__ import annotations

import argparse
import shutil
import sys
import time
from pathlib import Path

from samplehd.dataset.config import GenerateConfig
from samplehd.dataset.generate import candidate_order
from samplehd.dataset.journal import read_journal
from samplehd.dataset.layout import EPISODE_DIR
from samplehd.dataset.work import EpisodeUnit, run_episode_unit
from samplehd.fileio import file_sha256, read_json
from samplehd.scene.spec import SceneSpec
from samplehd.tasks.task import parse_task


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("dataset", type=Path, help="a finished dataset (generate --render none)")
    parser.add_argument("out", type=Path, help="scratch directory (emptied first)")
    parser.add_argument("--limit", type=int, default=0, help="only the first N units of the order (0: all)")
    parser.add_argument("--repeats", type=int, default=1, help="timed passes over the units")
    args = parser.parse_args(argv)
    src = args.dataset
    config = GenerateConfig.from_dict(read_json(src / "info.json")["config"])
    scenes = {int(s["image_index"]): s for s in read_json(src / "scenes.json")["scenes"]}
    by_key = {(int(c["image_index"]), int(c["slot"])): c for c in read_json(src / "candidates.json")["instructions"]}
    recorded = {(int(r["scene_index"]), int(r["slot"])): r for r in read_journal(src)}
    order = [k for k in candidate_order(list(by_key)) if k in recorded]
    if args.limit:
        order = order[:args.limit]

    def unit(key: tuple[int, int]) -> EpisodeUnit:
        c, s = by_key[key], scenes[key[0]]
        return EpisodeUnit(out=str(args.out), file=Path(c["file"]).name, scene_index=key[0], slot=key[1],
                           seed=int(c["seed"]), family=str(c["family"]),
                           task=parse_task(c["task"], family=str(c["family"])), instruction=str(c["instruction"]),
                           split=str(c["split"]), scene=SceneSpec.from_dict(s["spec"]), directions=s["directions"],
                           paths=config.paths, render=config.render, disturbances=None)

    shutil.rmtree(args.out, ignore_errors=True)
    (args.out / EPISODE_DIR).mkdir(parents=True)
    run_episode_unit(unit(order[0]))  # untimed: imports, the compiled kernels
    cpus, frames, differ = [], 0, []
    for _ in range(args.repeats):
        c0, frames = time.process_time(), 0
        for key in order:
            result = run_episode_unit(unit(key))
            frames += result.num_frames or 0
            if result.sha256 != recorded[key].get("sha256"):
                differ.append(key)
        cpus.append(time.process_time() - c0)
    least = min(cpus)
    print(f"{len(order)} units, {frames} frames, CPU s per pass: {', '.join(f'{c:.2f}' for c in cpus)}; "
          f"least {least:.2f} s, {frames / least:.0f} frames per CPU-s")
    for key in sorted(set(differ)):
        file = args.out / EPISODE_DIR / Path(by_key[key]["file"]).name
        got = file_sha256(file) if file.exists() else "none"
        print(f"scene {key[0]} slot {key[1]}: sha256 {got[:12]} differs from the journal's "
              f"{str(recorded[key].get('sha256'))[:12]}")
    print("every episode file equal to the dataset's" if not differ else f"{len(set(differ))} episode files differ")
    return 1 if differ else 0


if __name__ == "__main__":
    sys.exit(main())
