from pathlib import Path

import av
import pytest

from samplehd.cli import main


def test_replay_renders_a_generated_hdf5_episode(micro_dataset: Path, tmp_path: Path,
                                                 capsys: pytest.CaptureFixture) -> None:
    episode = sorted((micro_dataset / "episodes").glob("*.h5"))[0]
    out = tmp_path / "ep.mp4"
    assert main(["replay", str(episode), "--out", str(out), "--width", "96", "--height", "54",
                 "--sheet", str(tmp_path / "sheet.png")]) == 0
    with av.open(str(out)) as video:
        frames = sum(1 for _ in video.decode(video=0))
    from samplehd.dataset.container import read_meta

    assert frames == int(read_meta(episode)["num_frames"])
    assert (tmp_path / "sheet.png").stat().st_size > 0
    err = capsys.readouterr().err
    assert "replay" in err and f"{frames}/{frames} frames" in err, err  # the progress bar, on stderr
    assert main(["replay", str(episode), "--out", str(out), "--width", "32", "--height", "18", "--quiet"]) == 0
    assert capsys.readouterr().err == ""
