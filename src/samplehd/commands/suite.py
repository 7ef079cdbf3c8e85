"""Build, list and describe benchmark suites: frozen episode lists, each episode proven solvable by the
closed-loop oracle, that `samplehd evaluate --suite` runs without drawing anything.

  samplehd suite build NAME [--config FILE] [--axes AXIS ...] [--out FILE] [--workers N]
      (a shipped suite's NAME, e.g. core or plus, builds from its shipped specification unless --config is
      given; plus derives from core's built episodes, and --axes builds only those axes of it)
  samplehd suite list
  samplehd suite show NAME|FILE
"""

from __future__ import annotations

import argparse
import json
import time
from dataclasses import fields
from pathlib import Path

from samplehd.benchmark.axes import AXES
from samplehd.benchmark.suite import SELECTION, Candidate, SuiteBuildConfig, build_suite, read_base
from samplehd.commands._options import check_out_file, config_from_options, split_names
from samplehd.dataset.outputs import check_outputs
from samplehd.envs.suite_file import SUITE_DIR, SUITE_SPEC_DIR, Suite, read_suite, shipped_suites
from samplehd.errors import ConfigError
from samplehd.fileio import read_json
from samplehd.workers import BACKENDS, Backend

HELP = "build a benchmark suite of oracle-proven episodes, list the shipped suites, or show one"
SHOWN_SHORT = 5  # short cells or variants a summary names; the manifest lists them all


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("action", choices=("build", "list", "show"), help="what to do")
    parser.add_argument("name", nargs="?", help="build: the suite's name; show: a shipped suite's name or a file")
    parser.add_argument("--config", type=Path, help="build: JSON of the build options (seed, families, levels, "
                                                    "catalogues, episodes_per_cell, max_candidates_per_cell, "
                                                    "max_scenes_per_candidate, instruction_rounds, env, family_scene, "
                                                    "family_max_scenes, axes, strengths, "
                                                    "max_attempts_per_variant, base, base_per_cell, base_skip, "
                                                    "base_catalogues, "
                                                    "base_families, base_levels); default for a "
                                                    "shipped suite's name: its shipped specification")
    parser.add_argument("--episodes-per-cell", type=int, help="build: episodes per catalogue × family × level")
    parser.add_argument("--families", nargs="+", help="build: task families (with --base: only the base's cells "
                                                      "of these)")
    parser.add_argument("--levels", nargs="+", help="build: generalisation levels (L1 L2 L3 L4; with --base: only "
                                                    "the base's cells of these)")
    parser.add_argument("--catalogues", nargs="+", help="build: procedural and/or shop-vrb (with --base: only the "
                                                        "base's cells of these)")
    parser.add_argument("--seed", type=int, help="build: seed of the candidates")
    parser.add_argument("--axes", nargs="+", help=f"build: robustness axes ({', '.join(AXES)}); each clean "
                                                  "episode gets a variant per axis and strength")
    parser.add_argument("--strengths", type=int, nargs="+", help="build: the strengths (1–5) of each axis")
    parser.add_argument("--base", help="build: a built suite (shipped name or file) whose clean episodes this "
                                       "suite takes as they are, making only the axes' variants")
    parser.add_argument("--base-per-cell", type=int, help="build: with --base, the first N clean episodes of each "
                                                          "of its catalogue × family × level cells (default: all)")
    parser.add_argument("--base-skip", type=int, help="build: with --base, pass over the first N clean episodes of "
                                                      "each cell before taking --base-per-cell (default 0)")
    parser.add_argument("--out", type=Path, help="build: the suite file to write (default NAME.json)")
    parser.add_argument("--workers", type=int, default=1, help="build: worker processes (local backend)")
    parser.add_argument("--backend", choices=BACKENDS, default="local", help="build: where candidates run")
    parser.add_argument("--ray-address", help="build: Ray cluster address (default: start a local Ray)")
    parser.add_argument("--quiet", action="store_true", help="build: no line per candidate")


def resolve_config(args: argparse.Namespace) -> SuiteBuildConfig:
    """The --config file's options, then the flags (a bad value's message names its flag)."""
    options: dict = {}
    shipped = SUITE_SPEC_DIR / f"{args.name}.json"
    if args.config is None and shipped.is_file():
        args.config = shipped
    if args.config is not None:
        options = read_json(args.config, ConfigError, f"--config {args.config}", field="config")
        if not isinstance(options, dict):
            raise ConfigError(f"--config {args.config}: expected a JSON object of build options", field="config")
    config = SuiteBuildConfig.from_dict(options, where=f"--config {args.config}" if args.config else None)
    flags = {"episodes_per_cell": args.episodes_per_cell, "seed": args.seed,
             "base": getattr(args, "base", None), "base_per_cell": getattr(args, "base_per_cell", None),
             "base_skip": getattr(args, "base_skip", None),
             "strengths": getattr(args, "strengths", None)}
    # beside a base, --catalogues, --families and --levels select the base's cells
    from_base = flags["base"] is not None or config.base is not None
    for key in ("families", "levels", "catalogues", "axes"):
        value = getattr(args, key)
        if value is not None:
            flags[f"base_{key}" if from_base and f"base_{key}" in SELECTION else key] = split_names(value, f"--{key}")
    given = {k: v for k, v in flags.items() if v is not None}
    try:
        return config_from_options(SuiteBuildConfig, **{**{f.name: getattr(config, f.name) for f in fields(config)},
                                                        **given})
    except ConfigError as exc:  # a selection of the base's cells came from its flag (--families ...)
        if exc.field in given and exc.field in SELECTION:
            flag = exc.field.removeprefix("base_")
            raise ConfigError(str(exc).replace(exc.field, flag, 1), field=flag) from None
        raise


def describe(suite: Suite) -> str:
    """A few lines on a suite: name, hash, counts, candidates and rejection reasons."""
    m = suite.manifest
    lines = [f"suite {suite.name}: {len(suite.episodes)} episodes, {suite.content_hash}",
             f"  file {suite.path}", f"  built by samplehd {suite.package_version}, seed {suite.build.get('seed')}"]
    for key in ("family", "level", "catalogue", "axis", "strength"):
        counts = m.get(f"by_{key}", {})
        lines.append(f"  by {key:<9} " + ", ".join(f"{k} {v}" for k, v in counts.items()))
    spare = f", solved beyond their cell's episodes {m['spare']}" if m.get("spare") else ""
    lines.append(f"  candidates {m.get('candidates')}, rejected {sum(m.get('rejected', {}).values())}{spare}")
    if m.get("base"):
        taken = _taken(suite.build.get("base_per_cell"), suite.build.get("base_skip", 0))
        lines.append(f"  from base {m['base']['name']} ({m['base']['content_hash']}): "
                     f"{taken}{_selection(suite.build)}, "
                     f"{len(m['base']['episodes'])} in all; "
                     f"axes {', '.join(m.get('axes', [])) or 'none'}")
    for reason, n in m.get("rejected", {}).items():
        lines.append(f"    {n:>5}  {reason}")
    for key, groups in m.get("candidates_solved", {}).items():  # solved of drawn (the oracle's record), of tried
        lines.append(f"  solved {key[3:].replace('_', ' × ')}: " + ", ".join(
            f"{v} {g['solved']}/{g.get('drawn', g['tried'])}/{g['tried']}" for v, g in groups.items()))
    for key in ("short_cells", "short_variants"):
        short = m.get(key) or []
        if short:  # a few, then how many more the file's manifest lists (a plus axis can leave hundreds)
            more = f", and {len(short) - SHOWN_SHORT} more in the manifest" if len(short) > SHOWN_SHORT else ""
            lines.append(f"  {key.replace('_', ' ')} ({len(short)}): "
                         f"{', '.join(json.dumps(x) for x in short[:SHOWN_SHORT])}{more}")
    return "\n".join(lines)


def _selection(build: dict) -> str:
    """The base's cells a suite selected (``base_catalogues``, ``base_families``, ``base_levels``), in words."""
    chosen = [" ".join(build[name]) for name in SELECTION if build.get(name)]
    return f" of {' × '.join(chosen)}" if chosen else ""


def _taken(per_cell: int | None, skip: int = 0) -> str:
    """What a suite built from a base takes of it, in words."""
    if not skip:
        return "all its clean episodes" if per_cell is None else f"its first {per_cell} clean episodes per cell"
    return (f"its clean episodes after the first {skip} per cell" if per_cell is None
            else f"{per_cell} clean episodes per cell after the first {skip}")


def run(args: argparse.Namespace) -> int:
    if args.action == "list":
        if args.name is not None:
            raise ConfigError(f"suite list: takes no name (got {args.name!r})")
        names = shipped_suites()
        if not names:
            print(f"no shipped suites (in {SUITE_DIR})")
        for name in names:
            suite = read_suite(name)
            print(f"{name:<12} {len(suite.episodes):>6} episodes  {suite.content_hash}")
        return 0
    if args.name is None:
        raise ConfigError(f"suite {args.action}: needs a NAME" + (" or FILE" if args.action == "show" else ""))
    if args.action == "show":
        print(describe(read_suite(args.name)))
        return 0
    if "/" in args.name or not args.name.replace("-", "").replace("_", "").isalnum():
        raise ConfigError(f"suite build {args.name!r}: a suite name is letters, digits, - and _ (the file is --out)")
    out = args.out or Path(f"{args.name}.json")
    check_out_file("--out", out, (".json",))
    check_outputs({"--out": out}, {"--config": args.config})
    config = resolve_config(args)
    base = read_base(config) if config.base is not None else None  # a bad base is refused before any work
    backend = Backend(args.backend, args.workers, args.ray_address)
    backend.connect()
    if base is not None:
        taken = _taken(config.base_per_cell, config.base_skip)
        print(f"building suite {args.name} from {base.name} ({base.content_hash}): {taken} "
              f"× axes {' '.join(config.axes) or 'none'} × strengths {' '.join(map(str, config.strengths))} "
              f"({backend.describe()})", flush=True)
    else:
        print(f"building suite {args.name}: {len(config.cells())} cells × {config.episodes_per_cell} episodes "
              f"({backend.describe()})", flush=True)
    t0 = time.perf_counter()
    runs = 0

    def show(c: Candidate) -> None:
        nonlocal runs
        runs += 1
        if args.quiet:
            return
        mark = "ok  " if c.solved else "fail"
        if c.variant:
            axis, strength, twin = c.variant.split()
            print(f"  {mark} {axis} strength {strength} of episode {twin} #{c.k} steps={c.steps:<5} {c.reason}",
                  flush=True)
            return
        catalogue, family, level = config.cells()[c.cell]
        print(f"  {mark} {catalogue:<10} {family:<15} {level} #{c.k:<3} steps={c.steps:<5} {c.reason}", flush=True)

    suite = build_suite(args.name, config, backend, progress=show)
    suite.write(out)
    wall = time.perf_counter() - t0
    print(describe(read_suite(out)))
    if base is not None:  # only the physical variants' attempts ran the oracle
        each = f", {wall / runs:.1f} s each" if runs else ""
        print(f"wrote {out} ({wall:.0f} s, {runs} physical variant attempts{each})")
    else:
        print(f"wrote {out} ({wall:.0f} s, {wall / max(1, suite.manifest['candidates']):.1f} s per candidate)")
    return 0
