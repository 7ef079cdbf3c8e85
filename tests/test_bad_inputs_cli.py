"""Every bad input to every command is a clean refusal.

A clean refusal: exit status 2, exactly one line on stderr that names the option, field or file at
fault (and the bad value), no traceback, and nothing created or changed on disk. Each case runs the
real command (``samplehd.cli.main``) in a workspace holding a real states-only dataset, damaged copies
of it, bad config files and existing files and folders; the workspace's bytes are compared before and
after every case.
"""

from __future__ import annotations

import hashlib
import json
import shutil
from pathlib import Path
from typing import Any

import pytest

import samplehd  # noqa: F401  (sets MUJOCO_GL before mujoco is imported)
from samplehd.cli import main

# A states-only dataset made in-process: 2 scenes x 2 candidates of the tiny preset.
MICRO: dict[str, Any] = {
    "num_scenes": 2,
    "seed": 0,
    "test_every": 2,
    "scene": {"min_objects": 3, "max_objects": 3},
    "instructions": {"per_scene": 2},
    "render": {"mode": "none"},
}

CUBE_OBJ = "\n".join(
    [f"v {x} {y} {z}" for x in (0, 1) for y in (0, 1) for z in (0, 1)]
    + ["f 1 3 4 2", "f 5 6 8 7", "f 1 2 6 5", "f 3 7 8 4", "f 1 5 7 3", "f 2 4 8 6"]
) + "\n"

# ---- bad config files: (name, JSON text) written into the workspace once --------------------------------
CONFIG_FILES: dict[str, str] = {
    "bad_json.json": "{\"num_scenes\": 2,",
    "list.json": "[1, 2]",
    "empty.json": "",
    "nan.json": "{\"num_scenes\": NaN}",
}


def _config_cases() -> list[tuple[str, dict[str, Any], tuple[str, ...]]]:
    """Bad `generate --config` documents: (id, document, fragments the message must hold)."""
    c: list[tuple[str, dict[str, Any], tuple[str, ...]]] = []

    def add(cid: str, doc: dict[str, Any], *frags: str) -> None:
        c.append((cid, doc, frags))

    # top level
    add("unknown-top", {"num_scene": 3}, "num_scene")
    for k in ("num_scenes", "seed", "target_episodes", "test_every"):
        add(f"{k}-str", {k: "3"}, k)
        add(f"{k}-float", {k: 2.5}, k)
        add(f"{k}-bool", {k: True}, k)
        add(f"{k}-null", {k: None}, k)
        add(f"{k}-neg", {k: -1}, k)
        add(f"{k}-list", {k: [1]}, k)
    add("num_scenes-zero", {"num_scenes": 0}, "num_scenes")
    add("num_scenes-huge", {"num_scenes": 10**12}, "num_scenes")
    for sec in ("scene", "instructions", "paths", "render"):
        add(f"{sec}-list", {sec: [1]}, sec)
        add(f"{sec}-str", {sec: "x"}, sec)
        add(f"{sec}-unknown", {sec: {"bogus_key": 1}}, "bogus_key")
    add("paths-planner-list", {"paths": {"planner": []}}, "planner")
    add("paths-checker-str", {"paths": {"checker": "x"}}, "checker")
    add("paths-planner-unknown", {"paths": {"planner": {"bogus_key": 1}}}, "bogus_key")
    add("paths-checker-unknown", {"paths": {"checker": {"bogus_key": 1}}}, "bogus_key")
    # instructions
    add("per_scene-zero", {"instructions": {"per_scene": 0}}, "per_scene")
    add("per_scene-str", {"instructions": {"per_scene": "2"}}, "per_scene")
    add("balance-bogus", {"instructions": {"balance": "bogus"}}, "bogus")
    add("families-str", {"instructions": {"families": "place"}}, "families")
    add("families-unknown", {"instructions": {"families": ["bogus"]}}, "bogus")
    add("families-empty", {"instructions": {"families": []}}, "families")
    add("families-int", {"instructions": {"families": [1]}}, "families")
    # render
    add("render-mode", {"render": {"mode": "bogus"}}, "bogus")
    add("render-cameras-str", {"render": {"cameras": "scene"}}, "cameras")
    add("render-cameras-unknown", {"render": {"cameras": ["bogus"]}}, "bogus")
    add("render-cameras-empty", {"render": {"cameras": []}}, "cameras")
    add("render-cameras-dup", {"render": {"cameras": ["scene", "scene"]}}, "cameras")
    add("render-modalities-str", {"render": {"modalities": "rgb"}}, "modalities")
    add("render-modalities-unknown", {"render": {"modalities": ["bogus"]}}, "bogus")
    add("render-modalities-dup", {"render": {"modalities": ["rgb", "rgb"]}}, "modalities")
    for k in ("width", "height"):
        add(f"render-{k}-zero", {"render": {k: 0}}, k)
        add(f"render-{k}-str", {"render": {k: "64"}}, k)
        add(f"render-{k}-float", {"render": {k: 64.5}}, k)
        add(f"render-{k}-huge", {"render": {k: 10**6}}, k)
    # scene
    scene_numbers = {
        "min_objects": (0, 31, "3"), "max_objects": (0, 31, "3"), "placement_margin": (-0.1, 5.0, "x"),
        "placement_tries": (0, None, "x"), "object_tries": (0, None, "x"), "scene_attempts": (0, None, "x"),
        "camera_yaw_deg": (-1.0, 90.0, "x"), "camera_pitch_deg": (-1.0, 45.0, "x"),
        "camera_distance_jitter": (-0.1, 0.9, "x"), "camera_target_jitter": (-0.1, 1.0, "x"),
        "min_visible_pixels": (-1, None, "x"), "min_visible_fraction": (-0.1, 1.5, "x"),
        "settle_time": (0.0, 100.0, "x"), "max_settle_shift": (-1.0, None, "x"),
        "max_settle_tilt_deg": (-1.0, 200.0, "x"), "max_rest_speed": (-1.0, None, "x"),
    }
    for k, (low, high, wrong) in scene_numbers.items():
        add(f"scene-{k}-low", {"scene": {k: low}}, k)
        if high is not None:
            add(f"scene-{k}-high", {"scene": {k: high}}, k)
        add(f"scene-{k}-type", {"scene": {k: wrong}}, k)
        add(f"scene-{k}-null", {"scene": {k: None}}, k)
    add("scene-min-gt-max", {"scene": {"min_objects": 5, "max_objects": 3}}, "max_objects")
    add("scene-classes-str", {"scene": {"classes": "mug"}}, "classes")
    add("scene-classes-unknown", {"scene": {"classes": ["bogus"]}}, "bogus")
    add("scene-classes-int", {"scene": {"classes": [3]}}, "classes")
    add("scene-occlusion-str", {"scene": {"occlusion_resolution": "320x180"}}, "occlusion_resolution")
    add("scene-occlusion-three", {"scene": {"occlusion_resolution": [320, 180, 1]}}, "occlusion_resolution")
    add("scene-occlusion-small", {"scene": {"occlusion_resolution": [4, 4]}}, "occlusion_resolution")
    add("scene-menu-list", {"scene": {"menu_overrides": ["mug"]}}, "menu_overrides")
    add("scene-menu-class", {"scene": {"menu_overrides": {"bogus": {"colour": ["red"]}}}}, "bogus")
    add("scene-menu-colour", {"scene": {"menu_overrides": {"mug": {"colour": ["bogus"]}}}}, "bogus")
    add("scene-menu-colour-notdrawn", {"scene": {"classes": ["bowl"],
                                                  "menu_overrides": {"mug": {"colour": ["bogus"]}}}}, "bogus")
    add("scene-menu-key", {"scene": {"menu_overrides": {"mug": {"flavour": ["red"]}}}}, "flavour")
    add("scene-menu-str", {"scene": {"menu_overrides": {"mug": {"colour": "red"}}}}, "colour")
    # paths
    add("paths-control_hz-zero", {"paths": {"control_hz": 0}}, "control_hz")
    add("paths-control_hz-str", {"paths": {"control_hz": "20"}}, "control_hz")
    add("paths-physics_hz-neg", {"paths": {"physics_hz": -500}}, "physics_hz")
    add("paths-physics-not-multiple", {"paths": {"physics_hz": 510, "control_hz": 20}}, "physics_hz")
    add("paths-max_attempts-zero", {"paths": {"max_attempts": 0}}, "max_attempts")
    add("paths-max_attempts-str", {"paths": {"max_attempts": "3"}}, "max_attempts")
    add("paths-max_attempts-float", {"paths": {"max_attempts": 2.5}}, "max_attempts")
    add("paths-grasp_assist-str", {"paths": {"grasp_assist": "yes"}}, "grasp_assist")
    add("paths-reject_fallen-int", {"paths": {"reject_fallen": 1}}, "reject_fallen")
    for k in ("joint_speed", "approach_speed", "lift_speed", "max_tcp_speed", "close_time", "open_time"):
        add(f"planner-{k}-zero", {"paths": {"planner": {k: 0}}}, k)
        add(f"planner-{k}-neg", {"paths": {"planner": {k: -1.0}}}, k)
        add(f"planner-{k}-str", {"paths": {"planner": {k: "1"}}}, k)
    for k in ("grasp_candidates", "spot_samples", "rrt_iterations"):
        add(f"planner-{k}-zero", {"paths": {"planner": {k: 0}}}, k)
        add(f"planner-{k}-float", {"paths": {"planner": {k: 1.5}}}, k)
    for k in ("approach_distance", "min_lift", "spot_margin"):
        add(f"planner-{k}-neg", {"paths": {"planner": {k: -0.1}}}, k)
    add("planner-order-bogus", {"paths": {"planner": {"order": "closest"}}}, "order", "closest", "nearest")
    add("planner-order-int", {"paths": {"planner": {"order": 1}}}, "order")
    add("checker-neg", {"paths": {"checker": {"lift_height": -1}}}, "lift_height")
    add("checker-str", {"paths": {"checker": {"lift_height": "x"}}}, "lift_height")
    return c


CONFIG_CASES = _config_cases()

# ---- command-line cases: (id, argv, fragments the message must hold) ---------------------------------------
# Placeholders: {ws} workspace; {ds} the dataset; {new} a path that does not exist; {file} an existing
# file; {dir} an existing folder that is no dataset; {ds_version}, {ds_truncated}, {ds_missing},
# {ds_badinfo}, {ds_noinfo} damaged datasets; {scenes}/{instructions} the dataset's JSON files;
# {episode} one of its episode files; {mesh} a valid OBJ; {cfg:NAME} a config file.
G = ["generate", "--quiet", "--out"]
CLI_CASES: list[tuple[str, list[str], tuple[str, ...]]] = [
    # generate
    ("generate-out-file", G + ["{file}"], ("--out", "{file}")),
    ("generate-out-dir-not-dataset", G + ["{dir}"], ("--out", "{dir}")),
    ("generate-out-existing-dataset", G + ["{ds}"], ("--resume",)),
    ("generate-resume-missing", G + ["{new}", "--resume"], ("--resume", "{new}")),
    ("generate-resume-file", G + ["{file}", "--resume"], ("{file}",)),
    ("generate-resume-not-dataset", G + ["{dir}", "--resume"], ("{dir}",)),
    ("generate-seed-neg", G + ["{new}", "--seed", "-1"], ("--seed", "-1")),
    ("generate-seed-str", G + ["{new}", "--seed", "x"], ("--seed", "'x'")),
    ("generate-scenes-zero", G + ["{new}", "--scenes", "0"], ("--scenes", "0")),
    ("generate-scenes-neg", G + ["{new}", "--scenes", "-3"], ("--scenes", "-3")),
    ("generate-target-neg", G + ["{new}", "--target", "-1"], ("--target", "-1")),
    ("generate-width-zero", G + ["{new}", "--width", "0"], ("--width", "0")),
    ("generate-height-huge", G + ["{new}", "--height", "100000"], ("--height", "100000")),
    ("generate-workers-zero", G + ["{new}", "--workers", "0"], ("--workers", "0")),
    ("generate-workers-neg", G + ["{new}", "--workers", "-2"], ("--workers", "-2")),
    ("generate-cameras-bogus", G + ["{new}", "--cameras", "bogus"], ("bogus",)),
    ("generate-cameras-empty", G + ["{new}", "--cameras", ","], ("--cameras",)),
    ("generate-modalities-bogus", G + ["{new}", "--modalities", "bogus"], ("bogus",)),
    ("generate-preset-bogus", G + ["{new}", "--preset", "bogus"], ("--preset", "bogus")),
    ("generate-render-bogus", G + ["{new}", "--render", "bogus"], ("--render", "bogus")),
    ("generate-backend-bogus", G + ["{new}", "--backend", "bogus"], ("--backend", "bogus")),
    ("generate-config-missing", G + ["{new}", "--config", "{new}.json"], ("--config", "{new}.json")),
    ("generate-config-dir", G + ["{new}", "--config", "{dir}"], ("--config", "{dir}")),
    ("generate-config-badjson", G + ["{new}", "--config", "{cfg:bad_json.json}"], ("bad_json.json",)),
    ("generate-config-list", G + ["{new}", "--config", "{cfg:list.json}"], ("list.json",)),
    ("generate-config-empty", G + ["{new}", "--config", "{cfg:empty.json}"], ("empty.json",)),
    ("generate-config-nan", G + ["{new}", "--config", "{cfg:nan.json}"], ("num_scenes",)),
    ("generate-no-out", ["generate"], ("--out",)),
    # rerender
    ("rerender-missing", ["rerender", "--quiet", "{new}"], ("{new}",)),
    ("rerender-file", ["rerender", "--quiet", "{file}"], ("{file}",)),
    ("rerender-not-dataset", ["rerender", "--quiet", "{dir}"], ("{dir}",)),
    ("rerender-cameras-bogus", ["rerender", "--quiet", "{ds}", "--cameras", "bogus"], ("bogus",)),
    ("rerender-cameras-empty", ["rerender", "--quiet", "{ds}", "--cameras", ","], ("cameras",)),
    ("rerender-modalities-bogus", ["rerender", "--quiet", "{ds}", "--modalities", "bogus"], ("bogus",)),
    ("rerender-width-zero", ["rerender", "--quiet", "{ds}", "--width", "0"], ("width", "0")),
    ("rerender-height-neg", ["rerender", "--quiet", "{ds}", "--height", "-5"], ("height", "-5")),
    ("rerender-workers-zero", ["rerender", "--quiet", "{ds}", "--workers", "0"], ("--workers", "0")),
    ("rerender-preset-bogus", ["rerender", "--quiet", "{ds}", "--preset", "bogus"], ("'bogus'",)),
    # export
    ("export-lerobot-missing", ["export", "lerobot", "{new}", "--out", "{new}2"], ("{new}",)),
    ("export-lerobot-out-file", ["export", "lerobot", "{ds}", "--out", "{file}"], ("--out", "{file}")),
    ("export-lerobot-out-dir", ["export", "lerobot", "{ds}", "--out", "{dir}"], ("--out", "{dir}")),
    ("export-lerobot-out-self", ["export", "lerobot", "{ds}", "--out", "{ds}"], ("--out", "{ds}")),
    ("export-lerobot-codec", ["export", "lerobot", "{ds}", "--out", "{new}", "--codec", "bogus"], ("bogus",)),
    ("export-lerobot-fpf", ["export", "lerobot", "{ds}", "--out", "{new}", "--frames-per-file", "0"],
     ("--frames-per-file", "0")),
    ("export-lerobot-cameras", ["export", "lerobot", "{ds}", "--out", "{new}", "--cameras", "bogus"], ("bogus",)),
    ("export-lerobot-modalities", ["export", "lerobot", "{ds}", "--out", "{new}", "--modalities", "bogus"],
     ("bogus",)),
    ("export-lerobot-states-only", ["export", "lerobot", "{ds}", "--out", "{new}", "--cameras", "scene"],
     ("scene",)),
    ("export-lerobot-repo-id", ["export", "lerobot", "{ds}", "--out", "{new}", "--repo-id", "a b/c d"],
     ("--repo-id",)),
    ("export-samplehd-missing", ["export", "sample-hd", "{new}", "--out", "{new}2"], ("{new}",)),
    ("export-samplehd-out-file", ["export", "sample-hd", "{ds}", "--out", "{file}"], ("--out", "{file}")),
    ("export-samplehd-out-dir", ["export", "sample-hd", "{ds}", "--out", "{dir}"], ("--out", "{dir}")),
    ("export-samplehd-workers", ["export", "sample-hd", "{ds}", "--out", "{new}", "--workers", "0"],
     ("--workers", "0")),
    ("export-format-bogus", ["export", "bogus", "{ds}", "--out", "{new}"], ("bogus",)),
    # stats
    ("stats-missing", ["stats", "{new}"], ("{new}",)),
    ("stats-file", ["stats", "{file}"], ("{file}",)),
    ("stats-not-dataset", ["stats", "{dir}"], ("{dir}",)),
    ("stats-out-file", ["stats", "{ds}", "--out", "{file}"], ("--out", "{file}")),
    # validate
    ("validate-missing", ["validate", "{new}"], ("{new}",)),
    ("validate-file", ["validate", "{file}"], ("{file}",)),
    ("validate-not-dataset", ["validate", "{dir}"], ("{dir}",)),
    ("validate-version", ["validate", "{ds_version}"], ("format_version", "9.9")),
    ("validate-max-problems-neg", ["validate", "{ds}", "--max-problems", "-1"], ("--max-problems", "-1")),
    ("validate-replay-missing", ["validate", "{new}", "--replay"], ("{new}",)),
    ("validate-replay-version", ["validate", "{ds_version}", "--replay"], ("format_version", "9.9")),
    ("validate-replay-episodes-zero", ["validate", "{ds}", "--replay", "--episodes", "0"], ("--episodes", "0")),
    ("validate-replay-episodes-str", ["validate", "{ds}", "--replay", "--episodes", "x"], ("--episodes", "'x'")),
    ("validate-episodes-alone", ["validate", "{ds}", "--episodes", "2"], ("--episodes", "--replay")),
    # view
    ("view-missing", ["view", "{new}"], ("{new}",)),
    ("view-file", ["view", "{file}"], ("{file}",)),
    ("view-port-neg", ["view", "{ds}", "--port", "-1"], ("--port", "-1")),
    ("view-port-huge", ["view", "{ds}", "--port", "70000"], ("--port", "70000")),
    ("view-port-str", ["view", "{ds}", "--port", "x"], ("--port", "'x'")),
    ("view-version", ["view", "{ds_version}", "--port", "0"], ("format_version", "9.9")),
    # scenes
    ("scenes-num-zero", ["scenes", "--num", "0", "--out", "{new}"], ("--num", "0")),
    ("scenes-num-neg", ["scenes", "--num", "-1", "--out", "{new}"], ("--num", "-1")),
    ("scenes-num-huge", ["scenes", "--num", "1000000000", "--out", "{new}"], ("--num", "1000000000")),
    ("scenes-seed-neg", ["scenes", "--num", "1", "--out", "{new}", "--seed", "-1"], ("--seed", "-1")),
    ("scenes-workers-zero", ["scenes", "--num", "1", "--out", "{new}", "--workers", "0"], ("--workers", "0")),
    ("scenes-width-small", ["scenes", "--num", "1", "--out", "{new}", "--width", "4"], ("width", "4")),
    ("scenes-height-zero", ["scenes", "--num", "1", "--out", "{new}", "--height", "0"], ("height", "0")),
    ("scenes-out-file", ["scenes", "--num", "1", "--out", "{file}"], ("--out", "{file}")),
    ("scenes-out-dataset", ["scenes", "--num", "1", "--out", "{ds}"], ("--out", "{ds}")),
    ("scenes-sheet-dir", ["scenes", "--num", "1", "--out", "{new}", "--sheet", "{dir}"], ("--sheet", "{dir}")),
    ("scenes-sheet-suffix", ["scenes", "--num", "1", "--out", "{new}", "--sheet", "{new}.txt"], ("--sheet",)),
    ("scenes-config-missing", ["scenes", "--num", "1", "--out", "{new}", "--config", "{new}.json"], ("--config",)),
    ("scenes-config-badjson", ["scenes", "--num", "1", "--out", "{new}", "--config", "{cfg:bad_json.json}"],
     ("bad_json.json",)),
    ("scenes-config-list", ["scenes", "--num", "1", "--out", "{new}", "--config", "{cfg:list.json}"],
     ("list.json",)),
    ("scenes-config-section", ["scenes", "--num", "1", "--out", "{new}", "--config", "{cfg:scene_bogus.json}"],
     ("bogus",)),
    ("scenes-config-field", ["scenes", "--num", "1", "--out", "{new}", "--config", "{cfg:scene_field.json}"],
     ("min_objects",)),
    ("scenes-config-classes-str", ["scenes", "--num", "1", "--out", "{new}", "--config", "{cfg:scene_classes.json}"],
     ("classes",)),
    ("scenes-preset-bogus", ["scenes", "--num", "1", "--out", "{new}", "--preset", "bogus"], ("'bogus'",)),
    # instructions
    ("instructions-scenes-missing", ["instructions", "--scenes", "{new}", "--out", "{new}.json"], ("{new}",)),
    ("instructions-scenes-badjson", ["instructions", "--scenes", "{cfg:bad_json.json}", "--out", "{new}.json"],
     ("bad_json.json",)),
    ("instructions-scenes-list", ["instructions", "--scenes", "{cfg:list.json}", "--out", "{new}.json"],
     ("list.json",)),
    ("instructions-scenes-dir", ["instructions", "--scenes", "{dir}", "--out", "{new}.json"], ("{dir}",)),
    ("instructions-out-dir", ["instructions", "--scenes", "{scenes}", "--out", "{dir}"], ("--out", "{dir}")),
    ("instructions-per-scene-zero", ["instructions", "--scenes", "{scenes}", "--out", "{new}.json",
                                     "--per-scene", "0"], ("--per-scene", "0")),
    ("instructions-per-scene-neg", ["instructions", "--scenes", "{scenes}", "--out", "{new}.json",
                                    "--per-scene", "-2"], ("--per-scene", "-2")),
    ("instructions-families", ["instructions", "--scenes", "{scenes}", "--out", "{new}.json",
                               "--families", "bogus"], ("bogus",)),
    ("instructions-templates-missing", ["instructions", "--scenes", "{scenes}", "--out", "{new}.json",
                                        "--templates", "{new}.json"], ("{new}.json",)),
    ("instructions-templates-badjson", ["instructions", "--scenes", "{scenes}", "--out", "{new}.json",
                                        "--templates", "{cfg:bad_json.json}"], ("bad_json.json",)),
    ("instructions-templates-list", ["instructions", "--scenes", "{scenes}", "--out", "{new}.json",
                                     "--templates", "{cfg:list.json}"], ("list.json",)),
    ("instructions-seed-neg", ["instructions", "--scenes", "{scenes}", "--out", "{new}.json", "--seed", "-1"],
     ("--seed", "-1")),
    ("instructions-split-bogus", ["instructions", "--scenes", "{scenes}", "--out", "{new}.json",
                                  "--split-ratio", "bogus"], ("--split-ratio",)),
    ("instructions-split-range", ["instructions", "--scenes", "{scenes}", "--out", "{new}.json",
                                  "--split-ratio", "train=nan"], ("--split-ratio",)),
    ("instructions-no-default", ["instructions", "--scenes", "{scenes}", "--out", "{new}.json",
                                 "--no-default-templates"], ("--templates",)),
    ("instructions-reach", ["instructions", "--scenes", "{scenes}", "--out", "{new}.json", "--reach", "bogus"],
     ("--reach",)),
    # paths
    ("paths-scenes-missing", ["paths", "--scenes", "{new}", "--instructions", "{instructions}", "--out", "{new}2"],
     ("{new}",)),
    ("paths-instructions-missing", ["paths", "--scenes", "{ds}", "--instructions", "{new}.json", "--out", "{new}"],
     ("{new}.json",)),
    ("paths-instructions-badjson", ["paths", "--scenes", "{ds}", "--instructions", "{cfg:bad_json.json}",
                                    "--out", "{new}"], ("bad_json.json",)),
    ("paths-instructions-list", ["paths", "--scenes", "{ds}", "--instructions", "{cfg:list.json}",
                                 "--out", "{new}"], ("list.json",)),
    ("paths-scenes-badjson", ["paths", "--scenes", "{cfg:bad_json.json}", "--instructions", "{instructions}",
                              "--out", "{new}"], ("bad_json.json",)),
    ("paths-out-file", ["paths", "--scenes", "{ds}", "--instructions", "{instructions}", "--out", "{file}"],
     ("--out", "{file}")),
    ("paths-cameras", ["paths", "--scenes", "{ds}", "--instructions", "{instructions}", "--out", "{new}",
                       "--cameras", "bogus"], ("bogus",)),
    ("paths-modalities", ["paths", "--scenes", "{ds}", "--instructions", "{instructions}", "--out", "{new}",
                          "--cameras", "scene", "--modalities", "bogus"], ("bogus",)),
    ("paths-width", ["paths", "--scenes", "{ds}", "--instructions", "{instructions}", "--out", "{new}",
                     "--width", "0"], ("--width", "0")),
    ("paths-workers", ["paths", "--scenes", "{ds}", "--instructions", "{instructions}", "--out", "{new}",
                       "--workers", "0"], ("--workers", "0")),
    ("paths-seed", ["paths", "--scenes", "{ds}", "--instructions", "{instructions}", "--out", "{new}",
                    "--seed", "-1"], ("--seed", "-1")),
    ("paths-limit", ["paths", "--scenes", "{ds}", "--instructions", "{instructions}", "--out", "{new}",
                     "--limit", "-1"], ("--limit", "-1")),
    ("paths-max-attempts", ["paths", "--scenes", "{ds}", "--instructions", "{instructions}", "--out", "{new}",
                            "--max-attempts", "0"], ("--max-attempts", "0")),
    ("paths-preset", ["paths", "--scenes", "{ds}", "--instructions", "{instructions}", "--out", "{new}",
                      "--preset", "bogus"], ("'bogus'",)),
    # render
    ("render-camera", ["render", "--camera", "bogus", "--out", "{new}.png"], ("bogus",)),
    ("render-width-zero", ["render", "--width", "0", "--out", "{new}.png"], ("--width", "0")),
    ("render-height-neg", ["render", "--height", "-1", "--out", "{new}.png"], ("--height", "-1")),
    ("render-width-huge", ["render", "--width", "100000", "--out", "{new}.png"], ("--width", "100000")),
    ("render-out-suffix", ["render", "--out", "{new}.txt"], ("--out",)),
    ("render-out-dir", ["render", "--out", "{dir}"], ("--out", "{dir}")),
    ("render-out-parent-file", ["render", "--out", "{file}/x.png"], ("--out",)),
    ("render-depth-suffix", ["render", "--out", "{new}.png", "--depth", "{new}.txt"], ("--depth",)),
    ("render-seg-npy", ["render", "--out", "{new}.png", "--segmentation", "{new}.npy"], ("--segmentation",)),
    ("render-preset", ["render", "--out", "{new}.png", "--preset", "bogus"], ("'bogus'",)),
    # replay
    ("replay-missing", ["replay", "{new}.h5", "--out", "{new}.mp4"], ("{new}.h5",)),
    ("replay-not-episode", ["replay", "{file}", "--out", "{new}.mp4"], ("{file}",)),
    ("replay-truncated", ["replay", "{truncated_episode}", "--out", "{new}.mp4"], ("{truncated_episode}",)),
    ("replay-out-suffix", ["replay", "{episode}", "--out", "{new}.txt"], ("--out",)),
    ("replay-camera", ["replay", "{episode}", "--out", "{new}.mp4", "--camera", "bogus"], ("bogus",)),
    ("replay-width", ["replay", "{episode}", "--out", "{new}.mp4", "--width", "0"], ("--width", "0")),
    ("replay-sheet-suffix", ["replay", "{episode}", "--out", "{new}.mp4", "--sheet", "{new}.txt"], ("--sheet",)),
    # vocab
    ("vocab-missing", ["vocab", "--instructions", "{new}.json", "--out", "{new}2.json"], ("{new}.json",)),
    ("vocab-badjson", ["vocab", "--instructions", "{cfg:bad_json.json}", "--out", "{new}.json"], ("bad_json.json",)),
    ("vocab-list", ["vocab", "--instructions", "{cfg:list.json}", "--out", "{new}.json"], ("list.json",)),
    ("vocab-min-count", ["vocab", "--instructions", "{instructions}", "--out", "{new}.json", "--min-count", "0"],
     ("--min-count", "0")),
    ("vocab-out-dir", ["vocab", "--instructions", "{instructions}", "--out", "{dir}"], ("--out", "{dir}")),
    # evaluate
    ("evaluate-policy", ["evaluate", "--policy", "bogus"], ("--policy", "bogus")),
    ("evaluate-policy-module", ["evaluate", "--policy", "no_such_module_x:act"], ("no_such_module_x",)),
    ("evaluate-episodes-zero", ["evaluate", "--policy", "random", "--episodes", "0"], ("--episodes", "0")),
    ("evaluate-episodes-neg", ["evaluate", "--policy", "random", "--episodes", "-1"], ("--episodes", "-1")),
    ("evaluate-families", ["evaluate", "--policy", "random", "--families", "bogus"], ("bogus",)),
    ("evaluate-seed", ["evaluate", "--policy", "random", "--seed", "-1"], ("--seed", "-1")),
    ("evaluate-width", ["evaluate", "--policy", "random", "--width", "0"], ("width", "0")),
    ("evaluate-max-steps-zero", ["evaluate", "--policy", "random", "--max-episode-steps", "0"],
     ("max_episode_steps", "0")),
    ("evaluate-max-steps-neg", ["evaluate", "--policy", "random", "--max-episode-steps", "-1"],
     ("max_episode_steps", "-1")),
    ("evaluate-workers", ["evaluate", "--policy", "random", "--workers", "0"], ("--workers", "0")),
    ("evaluate-env-missing", ["evaluate", "--policy", "random", "--env-options", "{new}.json"], ("{new}.json",)),
    ("evaluate-env-badjson", ["evaluate", "--policy", "random", "--env-options", "{cfg:bad_json.json}"],
     ("bad_json.json",)),
    ("evaluate-env-list", ["evaluate", "--policy", "random", "--env-options", "{cfg:list.json}"], ("list.json",)),
    ("evaluate-env-unknown", ["evaluate", "--policy", "random", "--env-options", "{cfg:env_unknown.json}"],
     ("bogus_option",)),
    ("evaluate-env-obs", ["evaluate", "--policy", "random", "--env-options", "{cfg:env_obs.json}"], ("bogus",)),
    # compare
    ("compare-not-json", ["compare", "{file}", "{file}"], ("{file}", "invalid JSON")),
    ("compare-bad-json", ["compare", "{cfg:bad_json.json}", "{file}"], ("bad_json.json", "invalid JSON")),
    ("compare-not-a-report", ["compare", "{instructions}", "{instructions}"],
     ("{instructions}", "not a samplehd evaluation report")),
    ("compare-folder", ["compare", "{dir}", "{file}"], ("{dir}", "is a folder, not a file")),
    ("compare-missing", ["compare", "{new}.json", "{file}"], ("{new}.json", "cannot read")),
    ("compare-out-suffix", ["compare", "{instructions}", "{instructions}", "--out", "{new}.txt"],
     ("--out", ".md or .json")),
    ("compare-out-input", ["compare", "{instructions_copy}", "{file}", "--out", "{instructions_copy}"],
     ("--out", "input")),
    ("compare-out-dataset", ["compare", "{instructions_copy}", "{file}", "--out", "{ds}/cmp.md"], ("--out", "dataset")),
    ("evaluate-env-cameras-str", ["evaluate", "--policy", "random", "--env-options", "{cfg:env_cameras.json}"],
     ("cameras",)),
    ("evaluate-env-steps", ["evaluate", "--policy", "random", "--env-options", "{cfg:env_steps.json}"],
     ("max_episode_steps",)),
    ("evaluate-out-dir", ["evaluate", "--policy", "random", "--out", "{dir}"], ("--out", "{dir}")),
    ("evaluate-video-file", ["evaluate", "--policy", "random", "--video", "{file}"], ("--video", "{file}")),
    # export-mjcf
    ("export-mjcf-suffix", ["export-mjcf", "--out", "{new}.txt"], (".xml",)),
    ("export-mjcf-dir", ["export-mjcf", "--out", "{dir}"], ("--out", "{dir}")),
    ("export-mjcf-parent-file", ["export-mjcf", "--out", "{file}/w.xml"], ("--out",)),
    # bench
    ("bench-only", ["bench", "--only", "bogus", "--out", "{new}"], ("bogus",)),
    ("bench-repeats", ["bench", "--repeats", "0", "--out", "{new}"], ("--repeats", "0")),
    ("bench-out-file", ["bench", "--out", "{file}"], ("--out", "{file}")),
    ("bench-handoff-width", ["bench", "paths", "handoff", "--width", "4"], ("--width", "4")),
    ("bench-handoff-rounds", ["bench", "paths", "handoff", "--repeats", "0"], ("--repeats", "0")),
    ("bench-generate-repeats", ["bench", "generate", "--repeats", "0"], ("--repeats", "0")),
    ("bench-generate-against", ["bench", "generate", "--against", "{dir}"], ("--against", "{dir}", "checkout")),
    ("bench-generate-config", ["bench", "generate", "--configs", "{new}.json"], ("--configs", "{new}.json")),
    # demo
    ("demo-workers", ["demo", "--out", "{new}", "--workers", "0"], ("--workers", "0")),
    ("demo-seed", ["demo", "--out", "{new}", "--seed", "-1"], ("--seed", "-1")),
    ("demo-out-file", ["demo", "--out", "{file}"], ("--out", "{file}")),
    # assets
    ("assets-import-missing", ["assets", "import", "{new}.obj", "--name", "thing"], ("{new}.obj",)),
    ("assets-import-suffix", ["assets", "import", "{file}", "--name", "thing"], ("{file}",)),
    ("assets-import-name", ["assets", "import", "{mesh}", "--name", "Bad Name"], ("Bad Name",)),
    ("assets-import-builtin", ["assets", "import", "{mesh}", "--name", "mug"], ("mug",)),
    ("assets-import-name-too-long", ["assets", "import", "{mesh}", "--name", "a" * 300], ("--name", "300 characters")),
    ("assets-import-scale-zero", ["assets", "import", "{mesh}", "--name", "thing", "--scale", "0"], ("scale",)),
    ("assets-import-scale-neg", ["assets", "import", "{mesh}", "--name", "thing", "--scale", "-1"], ("scale",)),
    ("assets-import-scale-nan", ["assets", "import", "{mesh}", "--name", "thing", "--scale", "nan"], ("scale",)),
    ("assets-import-size-zero", ["assets", "import", "{mesh}", "--name", "thing", "--size", "0"], ("size",)),
    ("assets-import-size-inf", ["assets", "import", "{mesh}", "--name", "thing", "--size", "inf"], ("size",)),
    ("assets-import-material", ["assets", "import", "{mesh}", "--name", "thing", "--material", "bogus"],
     ("bogus",)),
    ("assets-import-colour", ["assets", "import", "{mesh}", "--name", "thing", "--colour", "bogus"], ("bogus",)),
    ("assets-import-sizes", ["assets", "import", "{mesh}", "--name", "thing", "--sizes", "bogus"], ("bogus",)),
    ("assets-import-threshold", ["assets", "import", "{mesh}", "--name", "thing", "--threshold", "0"],
     ("threshold",)),
    ("assets-import-pieces", ["assets", "import", "{mesh}", "--name", "thing", "--max-pieces", "0"],
     ("max",)),
    ("assets-preview-class", ["assets", "preview", "bogus", "--out", "{new}.png"], ("bogus",)),
    ("assets-preview-colour", ["assets", "preview", "mug", "--out", "{new}.png", "--colour", "bogus"], ("bogus",)),
    ("assets-preview-material", ["assets", "preview", "mug", "--out", "{new}.png", "--material", "bogus"],
     ("bogus",)),
    ("assets-preview-size", ["assets", "preview", "mug", "--out", "{new}.png", "--size", "bogus"], ("bogus",)),
    ("assets-preview-width", ["assets", "preview", "mug", "--out", "{new}.png", "--width", "0"], ("width", "0")),
    ("assets-preview-suffix", ["assets", "preview", "mug", "--out", "{new}.txt"], ("--out",)),
    ("assets-sheet-suffix", ["assets", "sheet", "--out", "{new}.txt"], ("--out",)),
    ("assets-remove-unknown", ["assets", "remove", "bogus"], ("bogus",)),
    ("assets-remove-builtin", ["assets", "remove", "mug"], ("mug",)),
    ("assets-action", ["assets", "bogus"], ("bogus",)),
    ("command-bogus", ["bogus"], ("bogus",)),
]

EXTRA_FILES: dict[str, Any] = {
    "scene_bogus.json": {"bogus": {}},
    "scene_field.json": {"scene": {"min_objects": -1}},
    "scene_classes.json": {"scene": {"classes": "mug"}},
    "env_unknown.json": {"bogus_option": 1},
    "env_obs.json": {"obs_mode": "bogus"},
    "env_cameras.json": {"obs_mode": "rgb", "cameras": "scene"},
    "env_steps.json": {"max_episode_steps": -1},
}


# Every command that changes, resumes or exports a dataset, on every kind of damage: each must refuse
# (one line, exit 2) and leave the damaged dataset byte for byte as it was.
DAMAGES = ("version", "truncated", "missing", "badinfo", "noinfo", "escape", "absolute", "null", "one_scene",
           "instructions_dict")
DATASET_COMMANDS: dict[str, list[str]] = {
    "rerender": ["rerender", "--quiet", "{DS}", "--width", "64", "--height", "36"],
    "rerender-add": ["rerender", "--quiet", "{DS}", "--add", "--cameras", "wrist", "--width", "48", "--height", "48"],
    "generate-resume": ["generate", "--quiet", "--out", "{DS}", "--resume", "--config", "{cfg:micro.json}"],
    "export-lerobot": ["export", "lerobot", "{DS}", "--out", "{new}"],
    "export-sample-hd": ["export", "sample-hd", "{DS}", "--out", "{new}", "--workers", "1"],
    "stats": ["stats", "{DS}"],
}
DAMAGE_FRAGMENT = {"version": "format_version", "truncated": "bytes", "missing": "missing", "badinfo": "info.json",
                   "noinfo": "info.json", "escape": "outside the dataset", "absolute": "outside the dataset",
                   "null": "episodes[0]", "one_scene": "scenes.json", "instructions_dict": "instructions.json"}
# Damage only a whole read of every episode finds (same sizes): the commands that rewrite episodes
# (rerender, and generate --resume, which builds on them) must find it before they write.
VERIFY_DAMAGES = {"modified": "SHA-256", "frames": "frames", "version_attr": "format_version"}
VERIFY_COMMANDS = ("rerender", "rerender-add", "generate-resume")


def _snapshot(root: Path, digest: bool = False) -> dict[str, str]:
    """Every path under ``root`` with its size and modification time, or its bytes' hash
    (``digest``); 'dir' for folders. Any write changes the modification time."""
    out: dict[str, str] = {}
    for p in sorted(root.rglob("*")):
        rel = str(p.relative_to(root))
        if p.is_symlink():
            out[rel] = "link"
        elif p.is_dir():
            out[rel] = "dir"
        elif digest:
            out[rel] = hashlib.sha256(p.read_bytes()).hexdigest()
        else:
            st = p.stat()
            out[rel] = f"{st.st_size}:{st.st_mtime_ns}"
    return out


def _damage(src: Path, dst: Path, how: str) -> None:
    shutil.copytree(src, dst)
    info = json.loads((dst / "info.json").read_text())
    first = dst / info["episodes"][0]["file"]
    if how == "version":
        info["format_version"] = "9.9"
        (dst / "info.json").write_text(json.dumps(info, indent=1))
    elif how == "truncated":
        data = first.read_bytes()
        first.write_bytes(data[: len(data) // 2])
    elif how == "missing":
        first.unlink()
    elif how == "badinfo":
        (dst / "info.json").write_text((dst / "info.json").read_text()[:200])
    elif how == "noinfo":
        (dst / "info.json").unlink()
    elif how in ("escape", "absolute"):  # a file beside the dataset, the same size as the episode it replaces
        beside = dst.parent / f"outside_{how}.h5"
        shutil.copyfile(first, beside)
        info["episodes"][0]["file"] = f"../{beside.name}" if how == "escape" else str(beside)
        (dst / "info.json").write_text(json.dumps(info, indent=1))
    elif how == "one_scene":  # scenes.json holding one scene (the layout `samplehd instructions` also reads)
        scenes = json.loads((dst / "scenes.json").read_text())["scenes"]
        (dst / "scenes.json").write_text(json.dumps(scenes[0]))
    elif how == "instructions_dict":
        doc = json.loads((dst / "instructions.json").read_text())
        doc["instructions"] = {"0": doc["instructions"][0]}
        (dst / "instructions.json").write_text(json.dumps(doc))
    elif how == "null":
        info["episodes"][0] = None
        (dst / "info.json").write_text(json.dumps(info, indent=1))
    elif how == "modified":  # same size, a few bytes changed in the middle
        data = bytearray(first.read_bytes())
        middle = len(data) // 2
        data[middle:middle + 8] = bytes(b ^ 0x5A for b in data[middle:middle + 8])
        first.write_bytes(bytes(data))
    elif how == "frames":  # info.json's frame count no longer that of the file
        info["episodes"][0]["num_frames"] += 1
        (dst / "info.json").write_text(json.dumps(info, indent=1))
    elif how == "version_attr":  # the episode's own format version, changed in place
        import h5py

        with h5py.File(first, "r+") as f:
            f.attrs["format_version"] = "9.9"
        from samplehd.fileio import file_sha256

        info["episodes"][0].update(size=first.stat().st_size, sha256=file_sha256(first))  # info.json agrees
        (dst / "info.json").write_text(json.dumps(info, indent=1))


@pytest.fixture(scope="module")
def workspace(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """The pristine workspace (made once) and the placeholder values of the cases."""
    from samplehd.dataset.config import GenerateConfig, preset_config
    from samplehd.dataset.generate import generate_dataset

    root = tmp_path_factory.mktemp("bad_inputs")
    pristine = root / "ws"
    pristine.mkdir()
    ds = pristine / "ds"
    summary = generate_dataset(ds, GenerateConfig.from_dict(MICRO, base=preset_config("tiny")))
    assert summary.episodes >= 1
    for how in (*DAMAGES, *VERIFY_DAMAGES):
        _damage(ds, pristine / f"ds_{how}", how)
    (pristine / "notes.txt").write_text("a plain file\n")
    (pristine / "folder").mkdir()
    (pristine / "folder" / "keep.txt").write_text("not a dataset\n")
    (pristine / "cube.obj").write_text(CUBE_OBJ)
    cfg = pristine / "cfg"
    cfg.mkdir()
    for name, text in CONFIG_FILES.items():
        (cfg / name).write_text(text)
    for name, doc in EXTRA_FILES.items():
        (cfg / name).write_text(json.dumps(doc))
    for cid, doc, _ in CONFIG_CASES:
        (cfg / f"gen_{cid}.json").write_text(json.dumps(doc))
    (cfg / "micro.json").write_text(json.dumps(MICRO))
    shutil.copyfile(ds / "instructions.json", cfg / "instructions_copy.json")
    shutil.copyfile(ds / "scenes.json", cfg / "scenes_copy.json")
    for name, spoil in CONTRADICTIONS.items():
        doc = json.loads((ds / "instructions.json").read_text())
        spoil(doc["instructions"])
        (cfg / f"contra_{name}.json").write_text(json.dumps(doc))
    for name, text in RAW_CONFIGS.items():
        (cfg / name).write_text(text)
    _model_folders(pristine)
    (root / "registry").mkdir()
    info = json.loads((ds / "info.json").read_text())
    keep = root / "pristine"
    shutil.copytree(pristine, keep)
    return {"root": root, "ws": pristine, "pristine": keep, "snapshot": _snapshot(pristine),
            "digests": {how: _snapshot(pristine / f"ds_{how}", digest=True) for how in (*DAMAGES, *VERIFY_DAMAGES)},
            "episode_file": info["episodes"][0]["file"]}


def _placeholders(ws: Path, episode_file: str) -> dict[str, str]:
    return {
        "ws": str(ws), "ds": str(ws / "ds"), "new": str(ws / "new_out"), "file": str(ws / "notes.txt"),
        "dir": str(ws / "folder"), "mesh": str(ws / "cube.obj"), "scenes": str(ws / "ds" / "scenes.json"),
        "instructions": str(ws / "ds" / "instructions.json"), "episode": str(ws / "ds" / episode_file),
        "truncated_episode": str(ws / "ds_truncated" / episode_file),
        **{f"ds_{how}": str(ws / f"ds_{how}") for how in (*DAMAGES, *VERIFY_DAMAGES)},
        "instructions_copy": str(ws / "cfg" / "instructions_copy.json"), "long": "n" * 300,
    }


def _fill(text: str, values: dict[str, str], ws: Path) -> str:
    while "{cfg:" in text:
        start = text.index("{cfg:")
        end = text.index("}", start)
        text = text[:start] + str(ws / "cfg" / text[start + 5:end]) + text[end + 1:]
    return text.format(**values)


def run_refusal(workspace: dict[str, Any], argv: list[str], fragments: tuple[str, ...],
                capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch) -> None:
    """Run one bad command line in the workspace and check the refusal is clean."""
    ws = workspace["ws"]
    monkeypatch.setenv("SAMPLEHD_REGISTRY_DIR", str(workspace["root"] / "registry"))
    monkeypatch.chdir(ws)
    values = _placeholders(ws, workspace["episode_file"])
    args = [_fill(a, values, ws) for a in argv]
    before = workspace["snapshot"]
    registry_before = _snapshot(workspace["root"] / "registry")
    try:
        code = main(args)
    except SystemExit as exc:  # argparse refuses before main's handler
        code = exc.code
    err = capsys.readouterr().err.strip()
    lines = err.splitlines()
    after = _snapshot(ws)
    if after != before:  # restore the workspace for the next case
        shutil.rmtree(ws)
        shutil.copytree(workspace["pristine"], ws)
    assert code == 2, f"exit {code}, stderr {err[-600:]!r}"
    assert len(lines) == 1, f"expected one line, got {len(lines)}: {err[-600:]!r}"
    assert "Traceback" not in err
    for frag in fragments:
        assert _fill(frag, values, ws) in lines[0], f"{frag!r} not in {lines[0]!r}"
    changed = sorted(k for k in set(before) | set(after) if before.get(k) != after.get(k))
    assert not changed, f"the refused command changed the workspace: {changed[:5]}"
    assert _snapshot(workspace["root"] / "registry") == registry_before


@pytest.mark.parametrize(("argv", "fragments"), [pytest.param(a, f, id=i) for i, a, f in CLI_CASES])
def test_bad_command_line_is_refused_cleanly(workspace, argv, fragments, capsys, monkeypatch) -> None:
    run_refusal(workspace, argv, fragments, capsys, monkeypatch)


@pytest.mark.parametrize(("cid", "fragments"), [pytest.param(i, f, id=i) for i, _, f in CONFIG_CASES])
def test_bad_generate_config_is_refused_cleanly(workspace, cid, fragments, capsys, monkeypatch) -> None:
    argv = ["generate", "--quiet", "--out", "{new}", "--config", "{cfg:gen_" + cid + ".json}"]
    run_refusal(workspace, argv, (f"gen_{cid}.json", *fragments), capsys, monkeypatch)


@pytest.mark.parametrize("damage", DAMAGES)
@pytest.mark.parametrize("command", list(DATASET_COMMANDS))
def test_damaged_dataset_is_refused_and_left_as_it_was(workspace, command, damage, capsys, monkeypatch) -> None:
    argv = [a.replace("{DS}", "{ds_" + damage + "}") for a in DATASET_COMMANDS[command]]
    run_refusal(workspace, argv, ("{ds_" + damage + "}", DAMAGE_FRAGMENT[damage]), capsys, monkeypatch)
    assert _snapshot(workspace["ws"] / f"ds_{damage}", digest=True) == workspace["digests"][damage]


def test_rerender_of_a_spoilt_episode_changes_nothing(tmp_path: Path, workspace, capsys) -> None:
    """An episode spoilt behind info.json's back (same size, corrupted frames) is found before any
    episode is re-rendered: rerender stops with one line naming it and the dataset keeps every byte
    (an earlier rerender rewrote the episodes before it and re-hashed nothing it could check)."""
    import h5py

    ds = tmp_path / "ds"
    shutil.copytree(workspace["pristine"] / "ds", ds)
    info = json.loads((ds / "info.json").read_text())
    episodes = info["episodes"]
    assert len(episodes) >= 2
    bad = ds / episodes[-1]["file"]
    with h5py.File(bad, "r") as f:  # the first stored chunk of the joint positions, spoilt in place
        chunk = f["frames/qpos"].id.get_chunk_info(0)
    data = bytearray(bad.read_bytes())
    data[chunk.byte_offset:chunk.byte_offset + min(chunk.size, 64)] = b"\xff" * min(chunk.size, 64)
    bad.write_bytes(bytes(data))
    before = _snapshot(ds, digest=True)
    code = main(["rerender", "--quiet", str(ds), "--width", "64", "--height", "36", "--workers", "1"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1 and str(bad) in err, err
    assert _snapshot(ds, digest=True) == before


@pytest.mark.parametrize("damage", list(VERIFY_DAMAGES))
@pytest.mark.parametrize("command", VERIFY_COMMANDS)
def test_damage_found_only_by_reading_is_refused_before_writing(workspace, command, damage, capsys,
                                                                 monkeypatch) -> None:
    argv = [a.replace("{DS}", "{ds_" + damage + "}") for a in DATASET_COMMANDS[command]]
    run_refusal(workspace, argv, ("{ds_" + damage + "}", VERIFY_DAMAGES[damage]), capsys, monkeypatch)
    assert _snapshot(workspace["ws"] / f"ds_{damage}", digest=True) == workspace["digests"][damage]


# Outputs that would overwrite an input, another output or a dataset's own files (one rule for all).
OUTPUT_CASES: list[tuple[str, list[str], tuple[str, ...]]] = [
    ("instructions-into-dataset", ["instructions", "--scenes", "{scenes}", "--out", "{instructions}"],
     ("--out", "inside the dataset")),
    ("instructions-over-input", ["instructions", "--scenes", "{cfg:scenes_copy.json}", "--out",
                                 "{cfg:scenes_copy.json}"], ("--out", "input")),
    ("instructions-other-dataset", ["instructions", "--scenes", "{scenes}", "--out", "{ds_version}/i.json"],
     ("--out", "ds_version")),
    ("vocab-over-input", ["vocab", "--instructions", "{instructions_copy}", "--out", "{instructions_copy}"],
     ("--out", "input")),
    ("vocab-into-dataset", ["vocab", "--instructions", "{instructions}", "--out", "{ds}/vocab.json"],
     ("--out", "inside the dataset")),
    ("train-into-dataset", ["train", "parser", "--dataset", "{ds}", "--out", "{ds}", "--steps", "1"],
     ("--out", "dataset")),
    ("train-into-episodes", ["train", "parser", "--dataset", "{ds}", "--out", "{ds}/episodes/m", "--steps", "1"],
     ("--out", "inside the dataset")),
    ("train-out-file", ["train", "parser", "--dataset", "{ds}", "--out", "{file}", "--steps", "1"],
     ("--out", "{file}")),
    ("generate-inside-dataset", G + ["{ds}/episodes/inner"], ("--out", "inside the dataset")),
    ("generate-inside-other", G + ["{ds_version}/inner"], ("--out", "inside the dataset")),
    ("generate-long-name", G + ["{new}/{long}"], ("--out", "bytes")),
    ("render-depth-same", ["render", "--out", "{new}.png", "--depth", "{new}.png"], ("--depth", "--out")),
    ("render-seg-same", ["render", "--out", "{new}.png", "--segmentation", "{new}.png"],
     ("--segmentation", "--out")),
    ("render-preview-same", ["render", "--out", "{new}_preview.png", "--depth", "{new}.png", "--preview"],
     ("--preview",)),
    ("render-into-dataset", ["render", "--out", "{ds}/x.png"], ("--out", "inside the dataset")),
    ("render-long-name", ["render", "--out", "{new}/{long}.png"], ("--out", "bytes")),
    ("paths-into-dataset", ["paths", "--scenes", "{ds}", "--instructions", "{instructions}", "--out",
                            "{ds}/more"], ("--out", "inside the dataset")),
    ("scenes-into-dataset", ["scenes", "--num", "1", "--out", "{ds}/scenes_more"], ("--out", "inside the dataset")),
    ("export-into-other", ["export", "lerobot", "{ds}", "--out", "{ds_version}/lr"], ("--out", "ds_version")),
    ("export-sample-hd-into-other", ["export", "sample-hd", "{ds}", "--out", "{ds_missing}/sh"],
     ("--out", "ds_missing")),
    ("replay-into-dataset", ["replay", "{episode}", "--out", "{ds}/ep.mp4"], ("--out", "inside the dataset")),
    ("evaluate-into-dataset", ["evaluate", "--policy", "random", "--out", "{ds}/eval.json"],
     ("--out", "inside the dataset")),
    ("export-mjcf-into-dataset", ["export-mjcf", "--out", "{ds}/world.xml"], ("--out", "inside the dataset")),
    ("stats-into-other", ["stats", "{ds}", "--out", "{ds_version}/stats"], ("--out", "ds_version")),
    ("bench-into-dataset", ["bench", "--out", "{ds}/bench"], ("--out", "inside the dataset")),
    ("assets-preview-into-dataset", ["assets", "preview", "mug", "--out", "{ds}/mug.png"],
     ("--out", "inside the dataset")),
    ("demo-over-dataset", ["demo", "--out", "{ds}"], ("--out", "dataset")),
]


@pytest.mark.parametrize(("argv", "fragments"), [pytest.param(a, f, id=i) for i, a, f in OUTPUT_CASES])
def test_output_that_would_overwrite_inputs_or_datasets_is_refused(workspace, argv, fragments, capsys,
                                                                   monkeypatch) -> None:
    run_refusal(workspace, argv, fragments, capsys, monkeypatch)


def _swap_scenes(entries: list[dict[str, Any]]) -> None:
    """The instructions of scene 1 given for scene 0 and back: instructions made for other scenes."""
    for e in entries:
        e["image_index"] = 1 - e["image_index"]


def _set(key: str, value: Any, index: int = 0) -> Any:
    def spoil(entries: list[dict[str, Any]]) -> None:
        entries[index][key] = value
    return spoil


def _task(**changes: Any) -> Any:
    def spoil(entries: list[dict[str, Any]]) -> None:
        entries[-1]["task"] = {**entries[-1]["task"], **changes}
    return spoil


def _all_missing(entries: list[dict[str, Any]]) -> None:
    for e in entries:
        e["task"] = {**e["task"], "objects": [40]}


# Instruction files that contradict the dataset's scenes: `paths` must refuse them before planning.
CONTRADICTIONS: dict[str, Any] = {
    "other-scenes": _swap_scenes,
    "missing-object": _task(objects=[7]),
    "negative-object": _task(objects=[-1]),
    "every-object-missing": _all_missing,
    "family-juggle": _set("family", "juggle"),
    "family-null": _set("family", None),
    "scene-absent": _set("image_index", 99),
    "scene-index-str": _set("image_index", "0"),
    "task-other-part": _task(subject="behind"),
    "program-garbage": _set("program", [{"type": "juggle"}]),
    "entry-null": lambda entries: entries.__setitem__(1, None),
}


@pytest.mark.parametrize("case", list(CONTRADICTIONS))
def test_instructions_that_contradict_the_scenes_are_refused_before_planning(workspace, case, capsys,
                                                                             monkeypatch) -> None:
    argv = ["paths", "--scenes", "{ds}", "--instructions", "{cfg:contra_" + case + ".json}", "--out", "{new}"]
    run_refusal(workspace, argv, ("contra_" + case + ".json", "instructions["), capsys, monkeypatch)


# Config files and command lines with options that do nothing, or a key or item given twice.
RAW_CONFIGS: dict[str, str] = {
    "dup_top.json": '{"num_scenes": 2, "num_scenes": 3}',
    "dup_section.json": '{"render": {"mode": "none"}, "render": {"mode": "fast"}}',
    "dup_nested.json": '{"paths": {"planner": {"order": "nearest", "order": "instruction"}}}',
    "none_cameras.json": '{"render": {"mode": "none", "cameras": ["wrist"]}}',
    "none_every.json": '{"render": {"mode": "none", "every": 2}}',
    "fast_look.json": '{"render": {"mode": "fast", "look": "random"}}',
    "deep.json": "[" * 100_000 + "]" * 100_000,
    "deep_object.json": '{"a":' * 50_000 + "1" + "}" * 50_000,
    "families_dup.json": '{"instructions": {"families": ["place", "place"]}}',
    "env_dup.json": '{"obs_mode": "state", "obs_mode": "rgb"}',
}
GN = G + ["{new}"]
OPTION_CASES: list[tuple[str, list[str], tuple[str, ...]]] = [
    ("config-dup-top", GN + ["--config", "{cfg:dup_top.json}"], ("dup_top.json", "num_scenes", "twice")),
    ("config-dup-section", GN + ["--config", "{cfg:dup_section.json}"], ("dup_section.json", "render", "twice")),
    ("config-dup-nested", GN + ["--config", "{cfg:dup_nested.json}"], ("dup_nested.json", "order", "twice")),
    ("config-none-cameras", GN + ["--config", "{cfg:none_cameras.json}"], ("none_cameras.json", "cameras")),
    ("config-none-every", GN + ["--config", "{cfg:none_every.json}"], ("none_every.json", "every")),
    ("config-fast-look", GN + ["--config", "{cfg:fast_look.json}"], ("fast_look.json", "look")),
    ("config-deep-array", GN + ["--config", "{cfg:deep.json}"], ("deep.json", "nested")),
    ("config-deep-object", GN + ["--config", "{cfg:deep_object.json}"], ("deep_object.json", "nested")),
    ("config-families-dup", GN + ["--config", "{cfg:families_dup.json}"], ("families_dup.json", "families")),
    ("env-options-dup", ["evaluate", "--policy", "random", "--env-options", "{cfg:env_dup.json}"],
     ("env_dup.json", "obs_mode", "twice")),
    ("scenes-config-deep", ["scenes", "--num", "1", "--out", "{new}", "--config", "{cfg:deep.json}"],
     ("deep.json",)),
    ("generate-cameras-twice", GN + ["--cameras", "scene", "wrist", "scene"], ("--cameras", "twice")),
    ("generate-modalities-twice", GN + ["--modalities", "depth", "depth"], ("--modalities", "twice")),
    ("generate-modalities-comma-twice", GN + ["--modalities", "rgb,depth,rgb"], ("--modalities", "twice")),
    ("rerender-cameras-twice", ["rerender", "--quiet", "{ds}", "--cameras", "scene", "scene"], ("--cameras", "twice")),
    ("paths-modalities-twice", ["paths", "--scenes", "{ds}", "--instructions", "{instructions}", "--out", "{new}",
                                "--cameras", "scene", "--modalities", "rgb", "rgb"], ("--modalities", "twice")),
    ("instructions-families-twice", ["instructions", "--scenes", "{scenes}", "--out", "{new}.json", "--families",
                                     "place", "place"], ("--families", "twice")),
    ("rerender-modalities-twice", ["rerender", "--quiet", "{ds}", "--modalities", "depth", "rgb", "depth"],
     ("--modalities", "twice")),
    ("generate-ray-address-local", GN + ["--ray-address", "auto"], ("--ray-address", "--backend ray")),
    ("generate-ray-closed-port", GN + ["--backend", "ray", "--ray-address", "127.0.0.1:1"],
     ("--ray-address", "127.0.0.1:1")),
    ("rerender-ray-closed-port", ["rerender", "--quiet", "{ds}", "--backend", "ray", "--ray-address", "127.0.0.1:1"],
     ("--ray-address", "127.0.0.1:1")),
    ("generate-ray-malformed", GN + ["--backend", "ray", "--ray-address", "nonsense"], ("--ray-address", "HOST:PORT")),
    ("generate-ray-bad-port", GN + ["--backend", "ray", "--ray-address", "ray://localhost:99999"],
     ("--ray-address", "HOST:PORT")),
    ("rerender-ray-address-local", ["rerender", "--quiet", "{ds}", "--ray-address", "auto"], ("--ray-address",)),
    ("generate-none-cameras", GN + ["--render", "none", "--cameras", "wrist"], ("--cameras", "none")),
    ("generate-none-modalities", GN + ["--render", "none", "--modalities", "depth"], ("--modalities", "none")),
    ("rerender-look-fast", ["rerender", "--quiet", "{ds}", "--photo-look", "random"], ("--photo-look", "photo")),
    ("scenes-look-banana", ["scenes", "--num", "1", "--out", "{new}", "--photo-look", "banana"],
     ("--photo-look", "banana")),
    ("scenes-look-banana-photo", ["scenes", "--num", "1", "--out", "{new}", "--preset", "photo", "--photo-look",
                                  "banana"], ("--photo-look", "banana")),
    ("scenes-look-fast", ["scenes", "--num", "1", "--out", "{new}", "--photo-look", "random"],
     ("--photo-look", "photo")),
    ("evaluate-programs-oracle", ["evaluate", "--policy", "oracle", "--programs", "gt"], ("--programs", "oracle")),
    ("evaluate-perception-random", ["evaluate", "--policy", "random", "--perception", "gt"], ("--perception",)),
    ("evaluate-models-random", ["evaluate", "--policy", "random", "--models", "{dir}"], ("--models", "random")),
    ("evaluate-models-oracle", ["evaluate", "--policy", "oracle", "--models", "{dir}"], ("--models", "oracle")),
    ("export-previews-no-images", ["export", "sample-hd", "{ds}", "--out", "{new}", "--previews", "--no-images"],
     ("--previews", "--no-images")),
    ("view-host-empty", ["view", "{ds}", "--host", "", "--port", "0"], ("--host", "--allow-remote")),
    ("view-host-any", ["view", "{ds}", "--host", "0.0.0.0", "--port", "0"], ("--host", "--allow-remote")),
    ("view-host-any6", ["view", "{ds}", "--host", "::", "--port", "0"], ("--host", "--allow-remote")),
    ("view-host-name", ["view", "{ds}", "--host", "example.org", "--port", "0"], ("--host", "--allow-remote")),
]


def _model_folders(ws: Path) -> None:
    """Training folders with a checkpoint or model that must be refused before anything is written:
    garbage bytes, a pickled object (torch refuses it with weights_only, in many lines), a future format."""
    import torch

    pickled = {"model": Path("not-a-tensor"), "optimizer": {}, "step": 1}
    for name, files in {
        "train_garbage": {"checkpoint.pt": b"garbage, not a checkpoint"},
        "train_pickled": {"checkpoint.pt": pickled},
        "train_truncated": {"checkpoint.pt": "truncated"},
        "train_not_checkpoint": {"checkpoint.pt": {"weights": torch.zeros(2)}},
        "model_pickled": {"model.pt": pickled, "config.json": b'{"kind": "parser", "format": 1}'},
        "model_future": {"model.pt": {}, "config.json": b'{"kind": "parser", "format": 99}'},
    }.items():
        folder = ws / name
        folder.mkdir()
        for file, content in files.items():
            if isinstance(content, bytes):
                (folder / file).write_bytes(content)
            elif content == "truncated":
                torch.save({"model": {"w": torch.zeros(64)}, "optimizer": {}, "step": 1}, folder / file)
                (folder / file).write_bytes((folder / file).read_bytes()[:100])
            else:
                torch.save(content, folder / file)


TRAIN = ["train", "parser", "--dataset", "{ds}", "--steps", "1", "--quiet", "--out"]
OPTION_CASES += [
    ("train-device-quantum", TRAIN + ["{new}", "--device", "quantum"], ("--device", "quantum")),
    ("train-device-empty-index", TRAIN + ["{new}", "--device", "cpu:x"], ("--device",)),
    ("train-garbage-checkpoint", TRAIN + ["{ws}/train_garbage"], ("checkpoint.pt",)),
    ("train-pickled-checkpoint", TRAIN + ["{ws}/train_pickled"], ("checkpoint.pt", "weights_only")),
    ("train-truncated-checkpoint", TRAIN + ["{ws}/train_truncated"], ("checkpoint.pt",)),
    ("train-foreign-checkpoint", TRAIN + ["{ws}/train_not_checkpoint"], ("checkpoint.pt", "not a samplehd")),
    ("train-pickled-model", ["train", "parser", "--dataset", "{ds}", "--evaluate-only", "--out", "{ws}/model_pickled"],
     ("model.pt", "weights_only")),
    ("train-future-model", ["train", "parser", "--dataset", "{ds}", "--evaluate-only", "--out", "{ws}/model_future"],
     ("config.json", "format 99")),
    ("train-parser-demos", TRAIN + ["{new}", "--demos", "5"], ("--demos", "train policy")),
    ("train-noise-without-demos", ["train", "policy", "--dataset", "{ds}", "--out", "{new}", "--noise", "0.1"],
     ("--noise", "--demos")),
    ("train-noise-too-big", ["train", "policy", "--dataset", "{ds}", "--out", "{new}", "--demos", "2", "--noise",
                             "3"], ("--noise", "[0, 1]")),
    ("train-negative-demos", ["train", "policy", "--dataset", "{ds}", "--out", "{new}", "--demos", "-1"],
     ("--demos", "-1")),
    ("train-dagger-episodes-alone", ["train", "policy", "--dataset", "{ds}", "--out", "{new}", "--dagger-episodes",
                                     "3"], ("--dagger-episodes", "--dagger-rounds")),
    ("train-inputs-unknown", ["train", "policy", "--dataset", "{ds}", "--out", "{new}", "--inputs", "depth"],
     ("--inputs", "depth")),
    ("train-action-unknown", ["train", "policy", "--dataset", "{ds}", "--out", "{new}", "--action", "joints"],
     ("--action", "joints")),
    ("train-parser-action", TRAIN + ["{new}", "--action", "waypoint"], ("--action", "train policy")),
    ("train-zero-batch", ["train", "policy", "--dataset", "{ds}", "--out", "{new}", "--batch", "0"],
     ("--batch", "0")),
    ("train-grasp-head-unknown", ["train", "policy", "--dataset", "{ds}", "--out", "{new}", "--action", "keypose",
                                  "--grasp-head", "dot"], ("--grasp-head", "dot")),
    ("train-grasp-head-not-keypose", ["train", "policy", "--dataset", "{ds}", "--out", "{new}", "--grasp-head",
                                      "product"], ("--grasp-head", "product", "--action keypose")),
]


@pytest.mark.parametrize(("argv", "fragments"), [pytest.param(a, f, id=i) for i, a, f in OPTION_CASES])
def test_options_that_do_not_apply_or_repeat_are_refused(workspace, argv, fragments, capsys, monkeypatch) -> None:
    run_refusal(workspace, argv, fragments, capsys, monkeypatch)


# The commands that write to or read a dataset for their whole run, while another process holds it.
LOCKED_COMMANDS = ("rerender", "rerender-add", "generate-resume", "export-lerobot", "export-sample-hd")
_HOLDER = ("import sys\nfrom samplehd.dataset.lock import dataset_lock\n"
           "with dataset_lock(sys.argv[1], shared=sys.argv[2] == 'shared'):\n"
           "    print('held', flush=True)\n    sys.stdin.read()\n")


@pytest.mark.parametrize("holder", ["exclusive", "shared"])
@pytest.mark.parametrize("command", LOCKED_COMMANDS)
def test_dataset_in_use_by_another_process_is_refused(workspace, command, holder, capsys, monkeypatch) -> None:
    """A second command on a dataset another samplehd process is using: one line naming that
    process, nothing changed; a reader (export) may share the dataset with another reader."""
    import os
    import subprocess
    import sys

    if holder == "shared" and command.startswith("export"):
        pytest.skip("two exports of one dataset may run together")
    ws = workspace["ws"]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    proc = subprocess.Popen([sys.executable, "-c", _HOLDER, str(ws / "ds"), holder], stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, text=True, env=env)
    try:
        assert proc.stdout is not None and proc.stdout.readline().strip() == "held"
        argv = [a.replace("{DS}", "{ds}") for a in DATASET_COMMANDS[command]]
        run_refusal(workspace, argv, ("{ds}", f"process {proc.pid}"), capsys, monkeypatch)
    finally:
        proc.communicate("", timeout=30)


@pytest.mark.parametrize("frozen", ["root", "episodes", "info", "one-episode"])
@pytest.mark.parametrize("command", ["rerender", "rerender-add"])
def test_rerender_of_an_immutable_dataset_is_refused(tmp_path: Path, workspace, command, frozen, capsys) -> None:
    """A dataset folder or file the command cannot replace (chattr +i: refused even to root): one line,
    nothing changed (no temporary file either), instead of a traceback half-way."""
    import subprocess

    ds = tmp_path / "ds"
    shutil.copytree(workspace["pristine"] / "ds", ds)
    folder = {"root": ds, "episodes": ds / "episodes", "info": ds / "info.json",
              "one-episode": sorted((ds / "episodes").iterdir())[-1]}[frozen]
    if subprocess.run(["chattr", "+i", str(folder)], capture_output=True).returncode != 0:
        pytest.skip("chattr +i is not available here")
    try:
        before = _snapshot(ds, digest=True)
        argv = [a.replace("{DS}", str(ds)) for a in DATASET_COMMANDS[command]]
        code = main(argv)
        err = capsys.readouterr().err.strip()
        assert code == 2 and len(err.splitlines()) == 1 and "not writable" in err, err
        assert _snapshot(ds, digest=True) == before
    finally:
        subprocess.run(["chattr", "-i", str(folder)], check=True)


def _dead_pid() -> int:

    pid = 4_000_000
    while Path(f"/proc/{pid}").exists():
        pid += 1
    return pid


@pytest.mark.parametrize("export", [["lerobot"], ["sample-hd", "--no-images", "--workers", "1"]])
def test_staging_folders_of_killed_exports_are_removed_by_the_next(tmp_path: Path, workspace, export) -> None:
    """A killed export leaves its hidden staging folder; the next export to the same place removes
    it (its process is gone), and leaves the staging folder of an export still running alone."""
    import os

    out = tmp_path / "exported"
    dead = tmp_path / f".exported.tmp-{_dead_pid()}"
    running = tmp_path / f".exported.tmp-{os.getppid()}"
    for folder in (dead, running):
        (folder / "data").mkdir(parents=True)
        (folder / "data" / "part.bin").write_bytes(b"half written")
    ds = tmp_path / "ds"
    shutil.copytree(workspace["pristine"] / "ds", ds)
    assert main(["export", export[0], str(ds), "--out", str(out), *export[1:]]) == 0
    assert out.is_dir() and not dead.exists() and running.is_dir()


@pytest.mark.slow
def test_a_start_that_failed_before_info_json_does_not_block_the_next(tmp_path: Path, workspace) -> None:
    """The empty layout folders of a start that failed before info.json (disk full) are no dataset
    and no user files: the same command runs there afterwards."""
    out = tmp_path / "ds"
    for sub in ("scenes", "episodes", "images", "depth", "segmentation"):
        (out / sub).mkdir(parents=True)
    micro = workspace["pristine"] / "cfg" / "micro.json"
    assert main(["generate", "--quiet", "--out", str(out), "--config", str(micro), "--workers", "1"]) == 0
    assert json.loads((out / "info.json").read_text())["status"] == "complete"
