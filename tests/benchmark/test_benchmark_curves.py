"""Records that carry robustness axes get curves (success against strength with the Wilson band) as a
PNG beside the report and an axis × strength table in its Markdown."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from PIL import Image

from samplehd.benchmark.compare import compare_reports, comparison_markdown
from samplehd.benchmark.curves import _BAND, _LINE, PANEL
from samplehd.benchmark.report_files import companion_paths, write_report_with_statistics
from samplehd.benchmark.statistics import wilson_interval


def _suite_like_records() -> list[dict]:
    """Ten clean episodes (nine solved) and, per axis, each strength 1-5 applied to every one of them: on
    ``lighting`` episode k fails from strength 5 - k // 3 on (0-2 at 5, 3-5 from 4, 6-8 from 3);
    ``camera`` changes nothing."""
    records = [{"id": f"c{k}", "index": k, "family": "place", "success": k != 9} for k in range(10)]
    for axis in ("lighting", "camera"):
        for strength in range(1, 6):
            for k in range(10):
                ok = records[k]["success"] and (axis == "camera" or strength < 5 - k // 3)
                records.append({"id": f"{axis}{strength}-{k}", "index": len(records), "family": "place",
                                "success": ok, "axis": axis, "strength": strength, "twin": f"c{k}"})
    return records


def test_axes_get_curves_a_table_and_paired_differences(tmp_path: Path) -> None:
    out = tmp_path / "eval.json"
    report = write_report_with_statistics({"policy": "oracle", "split": {"episodes": 110, "families": ["place"],
                                                                         "seed": 0, "level": None},
                                           "records": _suite_like_records()}, out)
    stats = json.loads(out.read_text())["statistics"]
    assert stats == report["statistics"]
    lighting = stats["curves"]["lighting"]
    assert [p["strength"] for p in lighting] == [0, 1, 2, 3, 4, 5]
    assert [p["successes"] for p in lighting] == [9, 9, 9, 6, 3, 0]  # strength 0: the ten clean twins
    assert (lighting[3]["low"], lighting[3]["high"]) == wilson_interval(6, 10)
    assert [p["successes"] for p in stats["curves"]["camera"]] == [9] * 6
    assert stats["twins"]["lighting"]["5"]["first_only"] == 9 and stats["twins"]["lighting"]["5"]["significant"]
    assert stats["twins"]["camera"]["5"]["p_value"] == 1.0

    page = companion_paths(out)["markdown"].read_text()
    assert "| axis | strength 0 | strength 1 | strength 2 | strength 3 | strength 4 | strength 5 |" in page
    assert "| lighting | 9/10 90.0 % [59.6, 98.2] | 9/10 90.0 % [59.6, 98.2] | 9/10 90.0 % [59.6, 98.2] | " \
           "6/10 60.0 % [31.3, 83.2] | 3/10 30.0 % [10.8, 60.3] | 0/10 0.0 % [0.0, 27.8] |" in page
    assert "| lighting | 5 | 10 | 9/10 90.0 % [59.6, 98.2] | 0/10 0.0 % [0.0, 27.8] | -90.0 pp" in page
    assert "| camera | 5 | 10 | 9/10 90.0 % [59.6, 98.2] | 9/10 90.0 % [59.6, 98.2] | +0.0 pp" in page

    png = companion_paths(out)["curves"]
    img = np.asarray(Image.open(png).convert("RGB"))
    assert img.shape[1] == 2 * PANEL[0] and img.shape[0] >= PANEL[1]
    left, right = img[:, :PANEL[0]], img[:, PANEL[0]:]
    for panel in (left, right):
        assert (panel == _LINE).all(axis=-1).sum() > 100  # the curve and its points
    # Panels in axis order: camera (flat at 0.9) on the left, lighting (down to 0) on the right.
    lowest = [np.nonzero((p == _LINE).all(axis=-1))[0].max() for p in (left, right)]
    assert lowest[1] - lowest[0] > 0.3 * PANEL[1], lowest
    assert all((p == _BAND).all(axis=-1).sum() > 1000 for p in (left, right))


def test_the_same_records_write_the_same_bytes(tmp_path: Path) -> None:
    files = []
    for name in ("a", "b"):
        out = tmp_path / name / "eval.json"
        write_report_with_statistics({"policy": "random", "split": {}, "records": _suite_like_records()}, out)
        files.append([out.read_bytes(), *(p.read_bytes() for p in companion_paths(out).values())])
    assert files[0] == files[1]


def test_compare_groups_paired_episodes_by_axis_and_strength() -> None:
    a = {"policy": "a", "split": {"seed": 0}, "records": _suite_like_records()}
    # B solves every lighting episode that A lost at strength 4 and 5, and loses camera's at strength 2.
    b_records = [{**r, "success": (True if r.get("axis") == "lighting" and r["strength"] >= 4 and r["id"][-1] != "9"
                                   else False if r.get("axis") == "camera" and r["strength"] == 2 else r["success"])}
                 for r in a["records"]]
    rows = {g.group: g.difference for g in compare_reports(a, {**a, "policy": "b", "records": b_records})}
    assert list(rows)[:3] == ["all", "family place", "clean 0"]
    assert rows["clean 0"].pairs == 10 and rows["clean 0"].difference == 0.0 and rows["clean 0"].p_value == 1.0
    assert (rows["lighting 5"].second_only, rows["lighting 5"].first_only) == (9, 0) and rows["lighting 5"].significant
    assert rows["lighting 4"].second_only == 6 and rows["lighting 4"].p_value == 2 / 64
    assert rows["camera 2"].first_only == 9 and rows["camera 2"].difference == -0.9
    assert rows["camera 1"].difference == 0.0
    page = comparison_markdown(list(compare_reports(a, {**a, "records": b_records})), "a", "b")
    assert "| lighting 5 | 10 | 0/10 0.0 % [0.0, 27.8] | 9/10 90.0 % [59.6, 98.2] | +90.0 pp" in page
    assert "Significant: camera 2, lighting 4, lighting 5." in page  # all: 15 against 9, p = 0.31
