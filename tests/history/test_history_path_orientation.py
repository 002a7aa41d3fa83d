"""A path test's orientation figures in the history (migration 0005's columns).

A 6-DoF probe's ``verify --path`` recorded by ``--history`` keeps AT_a..RT_c
(degrees) in its row and on the page; a reflector's keeps NULL; a path test
recorded under schema 0004 keeps NULL after the upgrade.
"""

from __future__ import annotations

import json

import pytest
from cli_kit import cli

from calibrator.history import migrations, open_history, records, store

pytestmark = pytest.mark.timeout(900)

ROBOT = "sim:ur10e:seed=3"
RUN = ("verify", "--seed", "3", "--path", "line", "--cycles", "2", "--path-speed", "400")
COLUMNS = {"ATa_deg": "ata_deg", "ATb_deg": "atb_deg", "ATc_deg": "atc_deg",
           "RTa_deg": "rta_deg", "RTb_deg": "rtb_deg", "RTc_deg": "rtc_deg"}  # fmt: skip


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    """A 6-DoF probe's line test and a reflector's, recorded by the command."""
    folder = tmp_path_factory.mktemp("pathorient")
    for name, tracker in (("six.json", "sim://?probe=6dof"), ("three.json", "sim")):
        done = cli(*RUN, "--tracker", tracker, "-o", name, "--history", "h.db", cwd=folder)
        assert done.code == 0, done.stderr
        assert "recorded verification" in done.stdout
    return folder


def test_a_six_dof_path_test_keeps_its_orientation_figures(recorded):
    with open_history(str(recorded / "h.db")) as h:
        rows = {r["file"].rsplit("/", 1)[-1]: r for r in h.path_verifications(ROBOT)}
    six = json.loads((recorded / "six.json").read_text())["path"]
    for key, column in COLUMNS.items():
        assert isinstance(six[key], float)
        assert rows["six.json"][column] == six[key]
        assert rows["three.json"][column] is None


def test_the_page_shows_them_beside_the_position_figures(recorded):
    done = cli("history", ROBOT, "--history", "h.db", "--html", "page", cwd=recorded)
    assert done.code == 0, done.stderr
    assert "path line nominal" in done.stdout
    six = json.loads((recorded / "six.json").read_text())["path"]
    page = (recorded / "page" / "index.html").read_text()
    section = page[page.index('id="path-tests"') : page.index('id="records"')]
    assert "<th>AT_a deg</th>" in section and "<th>RT_c deg</th>" in section
    assert f"<td>{six['ATa_deg']:.4f}</td>" in section
    assert f"<td>{six['AT_P_mm']:.4f}</td>" in section


def test_a_path_test_recorded_under_0004_keeps_null_orientation(recorded, tmp_path):
    url = str(tmp_path / "old.db")
    engine = store._engine(store.resolve(url), create=True)
    record = records.verification(recorded / "three.json")
    with engine.begin() as conn:
        migrations.upgrade(conn, "0004")
        conn.exec_driver_sql("INSERT INTO robots (id, name) VALUES (1, ?)", (ROBOT,))
        row = {k: v for k, v in record.row.items() if k not in COLUMNS.values()}
        row["document"] = json.dumps(row["document"])
        names = ", ".join(row)
        marks = ", ".join("?" for _ in row)
        conn.exec_driver_sql(
            f"INSERT INTO path_verifications (robot_id, {names}) VALUES (1, {marks})",
            tuple(row.values()),
        )
    engine.dispose()
    with open_history(url) as h:
        (old,) = h.path_verifications(ROBOT)
    assert old["at_p_mm"] == record.row["at_p_mm"]
    assert all(old[c] is None for c in COLUMNS.values())
