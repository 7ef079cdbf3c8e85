import subprocess
import sys

import numpy as np
import pytest
from PIL import Image

from samplehd.cli import main
from samplehd.render.image_io import read_depth, read_segmentation


@pytest.mark.render
def test_render_command_writes_three_files(tmp_path, capsys):
    rc = main(["render", "--camera", "operator", "--width", "160", "--height", "90", "--preset", "fast",
               "--out", str(tmp_path / "rgb.png"), "--depth", str(tmp_path / "d.npy"),
               "--segmentation", str(tmp_path / "seg.png")])
    assert rc == 0
    assert Image.open(tmp_path / "rgb.png").size == (160, 90)
    depth = read_depth(tmp_path / "d.npy")
    assert depth.shape == (90, 160) and np.isfinite(depth).all() and depth.min() > 0.3
    assert set(np.unique(read_segmentation(tmp_path / "seg.png"))) >= {0, 1, 2}


def test_unknown_camera_is_one_line_error(tmp_path, capsys):
    rc = main(["render", "--camera", "ceiling", "--width", "64", "--height", "64", "--preset", "fast",
               "--out", str(tmp_path / "x.png")])
    err = capsys.readouterr().err.strip()
    assert rc == 2
    assert err.count("\n") == 0
    assert "unknown camera 'ceiling'; valid: operator" in err


def test_bad_output_suffix_is_one_line_error(tmp_path, capsys):
    assert main(["export-mjcf", "--out", str(tmp_path / "w.txt")]) == 2
    assert "must end in .xml" in capsys.readouterr().err


def test_python_dash_m_and_help_everywhere():
    out = subprocess.run([sys.executable, "-m", "samplehd", "--help"], capture_output=True, text=True, check=True)
    assert "render" in out.stdout and "export-mjcf" in out.stdout
    from samplehd.cli import build_parser

    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    for name in sub.choices:
        r = subprocess.run([sys.executable, "-m", "samplehd", name, "--help"], capture_output=True, text=True)
        assert r.returncode == 0, (name, r.stderr)


def test_commands_load_lazily_and_their_help_is_read_from_source():
    from samplehd.cli import build_parser, command_help, command_names

    full = build_parser(full=True)
    sub = next(a for a in full._actions if a.dest == "command")
    assert set(sub.choices) == set(command_names())
    for module_name in command_names().values():
        module = __import__(f"samplehd.commands.{module_name}", fromlist=["HELP"])
        assert command_help(module_name) == module.HELP and "\n" not in module.HELP
    # `samplehd --help` and a light command load neither MuJoCo nor the stages
    probe = ("import sys; from samplehd.cli import main; import contextlib, io\n"
             "with contextlib.redirect_stdout(io.StringIO()):\n"
             "    try: main(['--help'])\n"
             "    except SystemExit: pass\n"
             "print(sorted(m for m in ('mujoco', 'samplehd.dataset.generate', 'samplehd.envs.tabletop') "
             "if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def test_width_and_height_size_scene_images_without_episode_frames(tmp_path):
    # --render none draws no episode frames, but each scene's own images still take --width/--height.
    out = tmp_path / "d"
    rc = main(["generate", "--preset", "tiny", "--scenes", "1", "--target", "1", "--render", "none", "--width", "64",
               "--height", "36", "--seed", "3", "--workers", "1", "--out", str(out), "--quiet"])
    assert rc == 0
    rgb = sorted((out / "images").glob("*.png"))
    assert rgb and all(Image.open(p).size == (64, 36) for p in rgb)
