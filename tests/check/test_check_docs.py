"""The crash example of docs/check.md runs as written and prints what the doc shows."""

from executed_docs_kit import run


def test_the_crash_example_prints_what_the_doc_says(tmp_path):
    *_, measured_again = run("check.md", "crash", tmp_path)
    assert measured_again.code == 4  # recalibrate
