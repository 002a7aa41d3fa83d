"""Alarms between calibrations of one simulated arm: none for an unchanged arm, one for a crash.

The arm (a ``--world`` file with its seed, a typical arm's repeatability) is
measured three times by ``measure`` and identified by ``identify``: with
other seeds (poses, noise), the tracker set up elsewhere each time, the
tool's first guess moved by 0.45 mm in the second session's footer (the
same reflector: both declare ``tool_id``), and in the third a crash that
turned joint 4's zero by 1 mrad. The history compares their joint
parameters and tool (same tool) but not their base (no tracker pose in a
world frame), and raises exactly one alarm, naming joint 4, on SQLite and on
PostgreSQL.
"""

import json
from dataclasses import replace

import numpy as np
import pytest
from cli_kit import cli

from calibrator import session as sessions
from calibrator.history import open_history

ROBOT = "sim:ur10e:seed=11"
CRASH_RAD = 1e-3


def _world(folder, name, shifts=(0, 0, 0, 0, 0, 0)):
    path = folder / name
    path.write_text(
        "world: 1\nmodel: ur10e\nseed: 11\nrepeatability: true\n"
        f"joint_zero_shifts_rad: {list(shifts)}\n"
    )
    return path


def _declare(path, tool_id, guess_shift_mm=(0.0, 0.0, 0.0)):
    """Write ``tool_id`` into a session's footer and move its first guess of the tool."""
    loaded = sessions.load(path)
    guess = np.array(loaded.meta.flange2tool, float)
    guess[:3, 3] += guess_shift_mm
    meta = replace(loaded.meta, flange2tool=guess, extra={**loaded.meta.extra, "tool_id": tool_id})
    path.unlink()
    sessions.write(path, loaded.table, meta)


@pytest.fixture(scope="module")
def measured(tmp_path_factory):
    """Three sessions and their calibrations: same arm twice, then joint 4's zero crashed."""
    folder = tmp_path_factory.mktemp("compare")
    same = _world(folder, "same.yaml")
    crashed = _world(folder, "crashed.yaml", (0, 0, 0, CRASH_RAD, 0, 0))
    runs = (
        ("s0", same, 20, None, (0.0, 0.0, 0.0)),
        ("s1", same, 21, "2200,800,300", (0.3, -0.3, 0.2)),
        ("s2", crashed, 22, "1800,-1200,500", (0.0, 0.0, 0.0)),
    )
    for name, world, seed, at, shift in runs:
        where = ["--tracker-at", at] if at else []
        done = cli(
            "measure", "--model", "ur10e", "--world", world, "--seed", seed, "--poses", 40,
            "-o", f"{name}.parquet", "-q", *where, cwd=folder,
        )  # fmt: skip
        assert done.code == 0, done.stderr
        _declare(folder / f"{name}.parquet", "smr-1.5in", shift)
        done = cli("identify", f"{name}.parquet", "-o", f"{name}.json", "-q", cwd=folder)
        assert done.code == 0, done.stderr
    return folder


def _alarms(folder, url):
    shown = cli("history", "alarms", ROBOT, "--history", url, "--json", "-", cwd=folder)
    assert shown.code == 0, shown.stderr
    return json.loads(shown.stdout)


def test_an_unchanged_arm_raises_nothing_and_a_crash_names_its_joint(measured, history_url):
    folder = measured
    tools = [json.loads((folder / f"s{i}.json").read_text())["tool0"] for i in range(2)]
    # The two first guesses of the tool differ (the old alarms compared offsets from them).
    assert np.abs(np.array(tools[0]) - np.array(tools[1])).max() > 0.05
    with open_history(history_url) as store:
        store.record_calibration(folder / "s0.json")
        store.record_calibration(folder / "s1.json")
    found = _alarms(folder, history_url)
    assert found["alarms"] == []
    (note,) = found["not_compared"]  # the tool is compared: both sessions declare it
    assert note.startswith(f"{ROBOT}: base not compared: the tracker's pose is not recorded")
    with open_history(history_url) as store:
        store.record_calibration(folder / "s2.json")
        cals = store.calibrations(ROBOT)
    (alarm,) = _alarms(folder, history_url)["alarms"]
    assert (alarm["kind"], alarm["subject"]) == ("moved", "theta4")
    assert alarm["message"].startswith("joint 4 zero (theta4) moved +1.0")
    assert alarm["records"] == f"calibration {cals[1]['id']}; calibration {cals[2]['id']}"
    assert alarm["change"] == pytest.approx(CRASH_RAD, abs=5 * alarm["standard_error"] + 2e-5)
    assert alarm["change_unit"] == "rad" and alarm["unit"] == "chi2"
    assert alarm["figure"] > alarm["threshold"] > 0
    # Its time is when the crashed session was measured, to the second (or finer).
    assert alarm["time"] == cals[2]["time"].isoformat() + "Z"
    assert cals[2]["time"] == cals[2]["measured_at"]


def test_the_table_and_csv_say_what_each_column_holds(measured, tmp_path):
    history = tmp_path / "h.sqlite"
    with open_history(history) as store:
        store.record_calibration(measured / "s0.json")
        store.record_calibration(measured / "s2.json")
    done = cli("history", "alarms", "--history", history, "--csv", "alarms.csv", cwd=tmp_path)
    assert done.code == 0, done.stderr
    header, row = (tmp_path / "alarms.csv").read_text().splitlines()
    assert header == (
        "robot,time,kind,subject,records,figure,threshold,unit,change,standard_error,"
        "change_unit,message"
    )
    assert row.startswith(f"{ROBOT},20") and ",moved,theta4,calibration 1; calibration 2," in row
    shown = cli("history", ROBOT, "--history", history, cwd=tmp_path)
    head = shown.stdout.splitlines()[0].split()
    assert head[head.index("held-out") + 1] == "measured"


def test_a_footer_that_declares_its_set_up_wrongly_is_refused_in_one_line():
    from calibrator.history import HistoryError, records

    assert records.setup({}, "s.parquet") == {}
    pose = {"world": "cell-A", "tracker2world": np.eye(4).tolist()}
    assert records.setup({"tool_id": " smr-1 ", "tracker_pose": pose}, "s.parquet") == {
        "tool_id": "smr-1",
        "tracker_pose": pose,
    }
    skewed = np.eye(4)
    skewed[0, 1] = 0.5
    for extra, said in (
        ({"tool_id": 3}, "footer 'tool_id' must be the tool's name"),
        ({"tracker_pose": {"tracker2world": np.eye(4).tolist()}}, "footer 'tracker_pose' must be"),
        ({"tracker_pose": {"world": "w", "tracker2world": [[1, 0]]}}, "rigid 4x4 transform"),
        ({"tracker_pose": {"world": "w", "tracker2world": skewed.tolist()}}, "rigid 4x4"),
    ):
        with pytest.raises(HistoryError, match=said) as caught:
            records.setup(extra, "s.parquet")
        assert "\n" not in str(caught.value) and str(caught.value).startswith("s.parquet: ")
