"""``samplehd bench --report``: the performance table goes between its markers, and nothing is measured
or written when the target cannot take it. (Figures themselves are never asserted.)"""

from __future__ import annotations

from samplehd.bench._table import BEGIN, END, Row, check_target, table_markdown, write_report
from samplehd.cli import main

FACTS = {"date": "2026-01-01 00:00 UTC", "machine": "test machine, 2 logical cores", "load_start": (1.0, 2.0, 3.0),
         "load_end": (1.5, 2.0, 3.0), "commit": "abc123", "seconds": 10.0, "cpu_seconds": 9.0, "repeats": 3}


def test_table_replaces_only_the_text_between_the_markers(tmp_path):
    readme = tmp_path / "README.md"
    readme.write_text(f"# Title\n\nbefore\n{BEGIN}\nold table\n{END}\nafter\n", encoding="utf-8")
    table = table_markdown([Row("render frames/s", "15.4", "55.0", "`samplehd bench --report FILE --only paths`")],
                           FACTS)
    write_report(readme, table, check_target(readme))
    text = readme.read_text(encoding="utf-8")
    assert text.startswith("# Title\n\nbefore\n" + BEGIN) and text.endswith(END + "\nafter\n")
    assert "old table" not in text
    assert "| render frames/s | 15.4 | 55.0 | `samplehd bench --report FILE --only paths` |" in text
    assert "2026-01-01 00:00 UTC" in text and "abc123" in text and "1.0 / 2.0 / 3.0" in text
    # run again: still one table
    write_report(readme, table, check_target(readme))
    assert readme.read_text(encoding="utf-8").count(BEGIN) == 1


def test_a_file_without_the_markers_is_refused_before_measuring(tmp_path, capsys):
    readme = tmp_path / "README.md"
    readme.write_text("# no markers here\n", encoding="utf-8")
    assert main(["bench", "--report", str(readme), "--only", "robot"]) == 2
    err = capsys.readouterr().err
    assert "README.md" in err and "must hold the line" in err
    assert len(err.strip().splitlines()) == 1
    assert readme.read_text(encoding="utf-8") == "# no markers here\n"


def test_a_missing_folder_and_an_unknown_area_are_refused(tmp_path, capsys):
    assert main(["bench", "--report", str(tmp_path / "nowhere" / "table.md")]) == 2
    assert "does not exist" in capsys.readouterr().err
    assert main(["bench", "--report", str(tmp_path / "table.md"), "--only", "scenes"]) == 2
    assert "valid: robot, paths, language" in capsys.readouterr().err
    assert not (tmp_path / "table.md").exists()
