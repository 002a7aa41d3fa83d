"""History cases the history tests did not reach. Found by mutation testing (issue 44).

The timeline's CSV and text table cell by cell: times in ISO 8601, absent
figures empty, one line per record; a check's explanation from its
document's sentences, else from its items.
"""

from __future__ import annotations

import csv
import io
from datetime import datetime

from calibrator.history import timeline

ROWS = [
    {c: None for c in timeline.COLUMNS}
    | {"time": datetime(2026, 1, 2, 3, 4, 5), "record": "session", "id": 1, "file": "s.parquet"},
    {c: None for c in timeline.COLUMNS}
    | {"time": datetime(2026, 2, 1, 0, 0, 0), "record": "check", "id": 2, "measured_mm": 0.0312,
       "verdict": "ok", "file": "c.json"},
]  # fmt: skip


def test_the_csv_has_iso_times_and_empty_absent_figures():
    read = list(csv.DictReader(io.StringIO(timeline.csv_text(ROWS))))
    assert [r["time"] for r in read] == ["2026-01-02T03:04:05", "2026-02-01T00:00:00"]
    assert read[0]["measured_mm"] == "" and read[0]["verdict"] == ""
    assert read[1]["measured_mm"] == "0.0312" and read[1]["verdict"] == "ok"
    assert list(read[0]) == list(timeline.COLUMNS)


def test_the_text_table_is_a_header_and_one_line_per_record():
    lines = timeline.format_table(ROWS).split("\n")
    assert len(lines) == 3 and lines[0].startswith("time (UTC)") and lines[0].endswith("(mm)")
    assert lines[1].startswith("2026-01-02 03:04:05  session")
    assert lines[2].startswith("2026-02-01 00:00:00  check") and lines[2].endswith("  ok")
    assert "0.0312" in lines[2]


def test_a_checks_explanation_is_its_documents_sentences_else_its_items_text():
    from calibrator.history import alarms

    check = {
        "document": {"explanation_text": ["joint 4 zero moved +1.0 mrad", "nothing else"]},
        "explanation": [{"cause": "joint 4 zero", "text": "an older summary"}],
    }
    assert alarms.explanations(check) == ["joint 4 zero moved +1.0 mrad", "nothing else"]
    older = {"document": {}, "explanation": [{"text": "an older summary"}, {"message": "m"}]}
    assert alarms.explanations(older) == ["an older summary", "m"]
