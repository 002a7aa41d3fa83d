"""docs/history.md's example (one arm calibrated three times, a crash before the third) runs
as written and prints what the doc shows."""

from executed_docs_kit import run


def test_the_three_calibrations_example_prints_what_the_doc_says(tmp_path):
    outcomes = run("history.md", "three calibrations", tmp_path)
    alarms = [line for line in outcomes[-1].stdout.splitlines() if line.startswith("ALARM")]
    assert len(alarms) == 1  # the crash, and nothing else
