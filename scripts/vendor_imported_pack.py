"""Write the shipped pack of imported classes, ``samplehd/catalogue/data/imported_pack``, from robosuite.

Run once by a maintainer (needs the ``mesh`` extra: trimesh, CoACD); the package only reads the files
this writes. The pack's classes are shapes from outside both built-in catalogues, made exactly as a user
makes one: each mesh goes through ``samplehd assets import`` (the real importer: cleaning, scaling,
CoACD decomposition, grasp metadata) into a temporary registry and decomposition cache, and the class
folder it writes (``class.json``, ``geometry.npz``, ``geometry.json``) is copied into the pack. Only
``geometry.json``'s ``source`` changes: the temporary path becomes the file's path in the wheel. The
wheel's LICENSE goes beside the classes and ``files.md`` records the wheel, each source file's sha256,
the command that imported it and the sha256 of every file written.

Usage::

    pip download robosuite==1.5.1 --no-deps -d /tmp/rs
    python scripts/vendor_imported_pack.py /tmp/rs/robosuite-1.5.1-py3-none-any.whl
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import shlex
import shutil
import tempfile
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "src" / "samplehd" / "catalogue" / "data" / "imported_pack"
MESHES = "robosuite/models/assets/objects/meshes"

# class -> (source mesh in the wheel, `samplehd assets import` options). Sizes: real-world ones the 85 mm
# gripper holds across the narrow way at every size class of the menu (a 0.5 l bottle, a small loaf, a
# lemon); robosuite's own files are smaller or larger than that.
CLASSES: dict[str, tuple[str, list[str]]] = {
    "bottle": ("bottle.stl", ["--size", "0.18", "--material", "plastic", "--colour", "blue", "green", "white",
                              "cyan", "--sizes", "small", "medium", "--description", "a bottle"]),
    "bread": ("bread.stl", ["--size", "0.09", "--material", "plastic", "--colour", "brown", "yellow",
                            "--sizes", "small", "medium", "--description", "a small loaf of bread"]),
    "lemon": ("lemon.stl", ["--size", "0.07", "--material", "plastic", "--colour", "yellow", "green",
                            "--description", "a lemon"]),
}


def _sha256(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("wheel", type=Path, help="robosuite's wheel (robosuite-<version>-py3-none-any.whl)")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="samplehd-pack-") as tmp:
        work = Path(tmp)
        # A private registry and cache: nothing of the user's takes part, every decomposition is made here.
        os.environ["SAMPLEHD_REGISTRY_DIR"] = str(work / "registry")
        os.environ["SAMPLEHD_CACHE_DIR"] = str(work / "cache")
        from samplehd.cli import main as samplehd

        with zipfile.ZipFile(args.wheel) as wheel:
            names = wheel.namelist()
            dist_info = next(n.split("/")[0] for n in names if n.split("/")[0].endswith(".dist-info"))
            version = dist_info.removeprefix("robosuite-").removesuffix(".dist-info")
            licence = wheel.read(f"{dist_info}/LICENSE")
            sources = {cls: wheel.read(f"{MESHES}/{file}") for cls, (file, _) in CLASSES.items()}
        # The pack's names are reserved: the old pack steps aside while its classes are imported again.
        old = work / "old_pack"
        if OUT.exists():
            shutil.move(OUT, old)
        try:
            rows = []
            for cls, (file, options) in CLASSES.items():
                src = work / "meshes" / file
                src.parent.mkdir(parents=True, exist_ok=True)
                src.write_bytes(sources[cls])
                argv = ["assets", "import", str(src), "--name", cls, *options]
                if samplehd(argv) != 0:
                    raise SystemExit(f"importing {file} as {cls} failed")
                meta_path = work / "registry" / cls / "geometry.json"
                meta = json.loads(meta_path.read_text())
                meta["source"] = f"{args.wheel.name}:{MESHES}/{file}"
                meta_path.write_text(json.dumps(meta, indent=1) + "\n")
                rows.append((cls, file, _sha256(sources[cls]), shlex.join(["samplehd", *argv[:2], file, *argv[3:]])))
            OUT.mkdir(parents=True)
            for cls in CLASSES:
                shutil.copytree(work / "registry" / cls, OUT / cls)
            (OUT / "LICENSE").write_bytes(licence)
            (OUT / "files.md").write_text(_provenance(args.wheel.name, version, rows))
        except BaseException:
            shutil.rmtree(OUT, ignore_errors=True)
            if old.exists():
                shutil.move(old, OUT)
            raise
    total = sum(p.stat().st_size for p in OUT.rglob("*") if p.is_file())
    print(f"wrote {len(CLASSES)} classes to {OUT} ({total / 1024:.0f} KB)")


def _provenance(wheel: str, version: str, rows: list[tuple[str, str, str, str]]) -> str:
    lines = [
        "# Shipped imported classes: provenance",
        "",
        f"Source: robosuite {version} (https://github.com/ARISE-Initiative/robosuite), the wheel `{wheel}`,",
        f"`{MESHES}/`; MIT licence (LICENSE, beside this file). Only the meshes' geometry is used, with",
        "samplehd's own colours and materials.",
        "",
        "Written by `scripts/vendor_imported_pack.py`: each mesh was imported with the command below (the",
        "importer behind `samplehd assets import`: vertices merged, degenerate and duplicate faces dropped,",
        "scaled to the largest extent `--size` [m], footprint centred, bottom on z = 0, CoACD convex pieces",
        "with threshold 0.05, at most 16 pieces, seed 0) into an empty registry, and the class folder copied",
        "here; `geometry.json`'s `source` names the file in the wheel.",
        "",
        "| class | source file | source sha256 | command |",
        "|---|---|---|---|",
    ]
    lines += [f"| {cls} | {MESHES}/{file} | {digest} | `{command}` |" for cls, file, digest, command in rows]
    lines += ["", "| file | sha256 |", "|---|---|"]
    for cls, *_ in rows:
        for path in sorted((OUT / cls).iterdir()):
            lines.append(f"| {cls}/{path.name} | {_sha256(path.read_bytes())} |")
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    main()
