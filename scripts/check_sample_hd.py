#!/usr/bin/env python3
"""Run SAMPLE-HD's own Python code, unchanged, on a ``samplehd export sample-hd`` folder and check what it makes.

Usage::

    python scripts/check_sample_hd.py EXPORT_DIR SAMPLE_HD_CHECKOUT [--work DIR]

SAMPLE_HD_CHECKOUT is a checkout of the public SAMPLE-HD repository (sample-hd/SAMPLE_HD_temp); its
code is not part of samplehd. Run this with a Python that has what that code imports: numpy, pillow,
tqdm, h5py, pycocotools (and torch + torchvision for ``datasets/SAMPLE.py``; skipped without them).
The export is copied to a work folder first, because SAMPLE-HD's preprocessing writes beside its inputs.

What runs, each exactly as committed there:
1. ``model/executor.py`` ``Executor.parse_unity`` on every exported program, compared with the exported
   ground truth by ``check_same`` of ``tools/exec.py`` (``tools/exec.py`` itself reads fixed paths of
   its author's machine and only instructions 7912..10000, so its loop is repeated here over all).
   ``model/executor.py`` is loaded as a file: ``model/__init__.py`` imports modules that do not exist.
2. ``utils/robot.py`` ``UR5e.effector_end`` on every frame's ``robot_state``, against ``effector.json``.
3. ``preprocessing/*.py`` with their own command-line arguments, in the order their inputs need:
   sequence_data_preprocessing, subtask_collapse, effector_preproc, effector_h5, annotation_preprocessing,
   filter_instructions, instructions_preprocessing_seq, instructions_preprocessing_ans. Their subtask
   masks are compared with the exported segmentation, their pick orders with the recorded targets
   (equal only for a dataset made with ``paths.planner.order: nearest``, the sample-hd preset's).
4. ``datasets/SAMPLE.py``: every dataset class built on those outputs and indexed.
Prints one summary line per check and exits 1 when any check fails.
"""

from __future__ import annotations

import argparse
import ast
import importlib.util
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Any


def _load_file(path: Path, name: str) -> Any:
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)  # type: ignore[union-attr]
    return module


def _function_from(path: Path, name: str) -> Any:
    """One top-level function of a script, compiled from its own source (the script runs on import)."""
    tree = ast.parse(path.read_text())
    node = next(n for n in tree.body if isinstance(n, ast.FunctionDef) and n.name == name)
    scope: dict[str, Any] = {}
    exec(compile(ast.Module(body=[node], type_ignores=[]), str(path), "exec"), scope)  # noqa: S102
    return scope[name]


def check_executor(code: Path, out: Path) -> tuple[int, int]:
    executor = _load_file(code / "model" / "executor.py", "sample_hd_executor")
    check_same = _function_from(code / "tools" / "exec.py", "check_same")
    instrs = json.loads((out / "instructions" / "instructions_program.json").read_text())["instructions"]
    gt = json.loads((out / "instructions" / "instructions_unityGT_filtered.json").read_text())["instructions"]
    ex = executor.Executor()
    matched = 0
    for ins, ins_u in zip(instrs, gt, strict=True):
        scene = json.loads((out / "scenes" / f"SAMPLE_HD_train_{ins['image_index']:06d}.json").read_text())
        ui = ex.parse_unity(ins["program_sequence"], scene, ins["instruction_idx"])
        if ui is not None and check_same(ui, ins_u):
            matched += 1
        else:
            print(f"  executor mismatch: instruction {ins['instruction_idx']}: {ui} != {ins_u}")
    return matched, len(instrs)


def check_fk(code: Path, out: Path) -> tuple[int, float]:
    import numpy as np

    robot = _load_file(code / "utils" / "robot.py", "sample_hd_robot")
    worst, frames = 0.0, 0
    for seq in sorted((out / "sequences").iterdir()):
        data = json.loads((seq / "data.json").read_text())["sequence"]
        eff = json.loads((seq / "effector.json").read_text())["data"]
        for frame in data:
            fk = np.asarray(robot.UR5e.effector_end(frame["robot_state"][0:6]))
            rec = np.asarray(list(eff[frame["frame_number"]]["position"].values()))
            worst = max(worst, float(np.linalg.norm(fk - rec)))
            frames += 1
    return frames, worst * 1000.0


def run_script(code: Path, script: str, *args: str) -> None:
    cmd = [sys.executable, script, *args]
    done = subprocess.run(cmd, cwd=code / "preprocessing", capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"{script} failed ({done.returncode}):\n{done.stdout[-2000:]}\n{done.stderr[-4000:]}")
    print(f"  ran preprocessing/{script} {' '.join(args)}")


def check_masks_and_orders(out: Path) -> tuple[int, int, int, int, int]:
    """Masks of sequence_data_preprocessing against the exported segmentation; its pick order against the
    recorded target objects. Returns (masks equal, masks, empty masks, orders equal, sequences)."""
    import numpy as np
    from PIL import Image
    from pycocotools import mask as mask_utils

    masks_ok = masks = empty = orders_ok = seqs = 0
    for seq in sorted((out / "sequences").iterdir()):
        new = json.loads((seq / "data_new.json").read_text())["sequence"]
        scene = json.loads((out / "scenes" / json.loads((seq / "data.json").read_text())["scene_json"]).read_text())
        starts = [t for t, f in enumerate(new) if "subtask_name" in f and f["subtask_start"] == t]
        picked = [new[t]["subtask_object"] for t in starts if new[t]["subtask_name"] == "GripperMoveAvoid"]
        recorded = [new[t]["target_object"] for t in starts if new[t]["subtask_name"] == "GripperMoveAvoid"]
        seqs += 1
        if picked == recorded:
            orders_ok += 1
        else:
            print(f"  pick order {seq.name}: preprocessing {picked}, recorded {recorded}")
        for t in starts:
            f = new[t]
            if f["subtask_name"] not in ("GripperMoveAvoid", "ObjectMove"):
                continue
            got = mask_utils.decode({"size": f["subtask_target_mask"]["size"],
                                     "counts": f["subtask_target_mask"]["counts"].encode()})
            frame = t
            if f["subtask_name"] == "ObjectMove":  # its mask is taken where the object is released
                frame = next(s for s in starts if s > t and new[s]["subtask_name"] == "OpenGripper")
            colour = scene["objects"][f["subtask_object"]]["segmentation_colour"]
            seg = np.asarray(Image.open(seq / "segmentation" / f"sequence_img_{frame:05d}.png"))
            want = np.all(seg == [colour["r"], colour["g"], colour["b"]], axis=2)
            masks += 1
            if np.array_equal(got.astype(bool), want):
                masks_ok += 1
                empty += int(not want.any())  # the object is hidden (by the arm) in that frame
            else:
                print(f"  mask {seq.name} frame {t} {f['subtask_name']}: {int(got.sum())} px vs {int(want.sum())} px")
    return masks_ok, masks, empty, orders_ok, seqs


def check_datasets(code: Path, out: Path) -> list[str]:
    try:
        import torch  # noqa: F401
        import torchvision  # noqa: F401
    except ImportError as exc:
        return [f"skipped (no {exc.name})"]
    sys.path.insert(0, str(code))
    from datasets import SAMPLE  # noqa: PLC0415  (SAMPLE-HD's package)

    h5 = out / "h5"
    results = []
    ds = SAMPLE.SAMPLE_Instructions(str(out), str(h5 / "instructions_ans.h5"), str(h5 / "vocab_ans.json"),
                                    str(out / "images"), "SAMPLE_HD_train_")
    results.append(f"SAMPLE_Instructions {len(ds)} items, item 0 image {tuple(ds[0][6].shape)}")
    for i in range(len(ds)):
        ds[i]
    ds = SAMPLE.SAMPLE_sequence_reference(str(out), str(h5 / "vocab_ans.json"))
    results.append(f"SAMPLE_sequence_reference {len(ds)} frames")
    ds = SAMPLE.SAMPLE_effector_pos(str(out))
    results.append(f"SAMPLE_effector_pos {len(ds)} items, item 0 {tuple(ds[0][0].shape)} {ds[0][1].tolist()}")
    ds = SAMPLE.SAMPLE_effector_pos(str(out), str(out / "effector.h5"))
    results.append(f"SAMPLE_effector_pos(h5) {len(ds)} items")
    ds[len(ds) - 1]
    ds = SAMPLE.SAMPLE_instruction_program(str(h5 / "instructions_seq.h5"), str(h5 / "vocab_seq.json"))
    results.append(f"SAMPLE_instruction_program {len(ds)} items, program 0 length {int(ds[0][3])}")
    ds = SAMPLE.SAMPLE_attributes(str(out / "annotations.json"), str(out))
    for i in range(len(ds)):
        ds[i]
    results.append(f"SAMPLE_attributes {len(ds)} objects, item 0 image {tuple(ds[0][0].shape)}")
    return results


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("export", type=Path)
    p.add_argument("code", type=Path, help="checkout of sample-hd/SAMPLE_HD_temp")
    p.add_argument("--work", type=Path, help="work copy of the export (default: EXPORT.checked)")
    a = p.parse_args(argv)
    code, out = a.code.resolve(), (a.work or a.export.with_name(a.export.name + ".checked")).resolve()
    shutil.rmtree(out, ignore_errors=True)
    shutil.copytree(a.export, out)
    ok = True
    matched, total = check_executor(code, out)
    ok &= matched == total
    print(f"executor: {matched}/{total} programs parse to the exported ground truth (tools/exec.py check_same)")
    frames, worst = check_fk(code, out)
    ok &= worst < 1.0
    print(f"utils/robot.py FK: {frames} frames, largest distance to effector.json {worst:.4f} mm")
    seqs, scenes = str(out / "sequences"), str(out / "scenes")
    program = str(out / "instructions" / "instructions_program.json")
    run_script(code, "sequence_data_preprocessing.py", "-i", seqs, "-s", scenes, "-ins", program)
    masks_ok, masks, empty, orders_ok, n = check_masks_and_orders(out)
    ok &= masks_ok == masks and orders_ok == n
    print(f"sequence_data_preprocessing: masks {masks_ok}/{masks} equal the segmentation ({empty} empty: object "
          f"hidden in that frame); pick orders {orders_ok}/{n} equal the recorded ones (the script gives each "
          "approach the remaining object nearest the effector at its first frame: a dataset made with "
          "paths.planner.order nearest, as the sample-hd preset)")
    run_script(code, "subtask_collapse.py", "-i", seqs)
    run_script(code, "effector_preproc.py", "-i", seqs, "-o", "data_effector.json")
    run_script(code, "effector_h5.py", "-i", seqs, "-j", "data_effector.json", "-o", str(out / "effector.h5"))
    # -ei: its default (-1) selects no scene at all.
    run_script(code, "annotation_preprocessing.py", "-i", str(out), "-ei", "999999",
               "-o", str(out / "annotations.json"))
    anns = json.loads((out / "annotations.json").read_text())
    print(f"annotation_preprocessing: {len(anns)} objects, {sum(1 for x in anns if x['mask']['counts'])} with masks")
    run_script(code, "filter_instructions.py", "-i", seqs, "-ins", program)
    h5 = out / "h5"
    run_script(code, "instructions_preprocessing_seq.py", "-i", program, "--output_h5_file",
               str(h5 / "instructions_seq.h5"), "--output_vocab_json", str(h5 / "vocab_seq.json"))
    # -s: its default (None) fails the comparison orig_idx < None.
    run_script(code, "instructions_preprocessing_ans.py", "--input_instructions_json", program, "--input_seq_dir",
               seqs, "-s", "0", "--output_h5_file", str(h5 / "instructions_ans.h5"),
               "--output_vocab_json", str(h5 / "vocab_ans.json"))
    for line in check_datasets(code, out):
        print(f"datasets/SAMPLE.py: {line}")
    print("OK" if ok else "FAILED")
    return 0 if ok else 1


if __name__ == "__main__":
    os.environ.setdefault("PYTHONHASHSEED", "0")
    sys.exit(main())
