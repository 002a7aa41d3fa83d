"""Positions and frames of a KUKA controller's ``$config.dat`` (``--config-dat``).

A joint position declared there (``XHOME``, as KUKA's ``$config.dat`` ships
it) is not in the files the filter rewrites: moved to, it stays as taught,
which is what ``--joint-targets keep`` does with every joint target anyway.
A Cartesian one there would go uncorrected while the summary says
"corrected", so it is refused, as is any joint position once joint targets
are to be corrected. A ``TOOL_DATA``/``BASE_DATA`` entry without all six
components is named with its own array.
"""

from __future__ import annotations

import pytest
from filter_kit import calibration, job

from calibrator.compensate import programs
from calibrator.languages.reading import FilterError

CONFIG = """DEFDAT $CONFIG
DECL E6AXIS XHOME={A1 0.0,A2 -90.0,A3 90.0,A4 0.0,A5 0.0,A6 0.0,E1 0.0}
DECL AXIS XPARK={A1 10.0,A2 -80.0,A3 80.0,A4 0.0,A5 10.0,A6 0.0}
DECL E6POS XABOVE={X 500.0,Y 0.0,Z 800.0,A 0.0,B 90.0,C 0.0,S 2,T 0}
ENDDAT
"""


def _program(tmp_path, moves):
    config = tmp_path / "config.dat"
    config.write_text(CONFIG)
    src = tmp_path / "HOMES.src"
    src.write_text("DEF HOMES()\n$TOOL = $NULLFRAME\n$BASE = $NULLFRAME\n" + moves + "END\n")
    (tmp_path / "HOMES.dat").write_text("DEFDAT HOMES\nENDDAT\n")
    return src, config


@pytest.mark.parametrize("name", ["XHOME", "XPARK", "xhome"])
def test_a_joint_position_of_the_config_dat_is_moved_to_and_kept(tmp_path, name):
    """E6AXIS and AXIS alike (KRL ignores case)."""
    src, config = _program(tmp_path, f"PTP {name}\n")
    cal = calibration("kuka-kr6-r900", mm=0.3, rad=0.0005)
    out = tmp_path / "out" / "HOMES.src"
    out.parent.mkdir()
    summary = programs.Filter("krl", job(cal, config_dat=config), src).run(out, [src])
    assert summary.n_failed == 0
    assert out.read_bytes() == src.read_bytes()


@pytest.mark.parametrize(
    ("moves", "name", "options"),
    [
        ("PTP XABOVE\n", "XABOVE", {}),  # Cartesian: would go uncorrected
        ("PTP XHOME\n", "XHOME", {"correct_joints": True}),  # to be corrected, but not here
    ],
)
def test_a_config_dat_position_the_filter_cannot_correct_is_refused(tmp_path, moves, name, options):
    src, config = _program(tmp_path, moves)
    cal = calibration("kuka-kr6-r900", mm=0.3, rad=0.0005)
    with pytest.raises(FilterError) as refused:
        programs.Filter("krl", job(cal, config_dat=config, **options), src)
    assert str(refused.value) == (
        f"{src}:4: {name} is moved to but declared neither in the .src nor in its .dat; "
        "its target cannot be corrected"
    )


@pytest.mark.parametrize("array", ["TOOL_DATA", "BASE_DATA"])
def test_a_config_dat_frame_without_all_six_components_is_named(tmp_path, array):
    config = tmp_path / "config.dat"
    config.write_text(f"DEFDAT $CONFIG\n{array}[4]={{X 1.0,Y 2.0,Z 3.0,A 0.0,B 0.0}}\nENDDAT\n")
    src = tmp_path / "P.src"
    src.write_text("DEF P()\nEND\n")
    with pytest.raises(FilterError) as refused:
        programs.Filter("krl", job(calibration("kuka-kr6-r900"), config_dat=config), src)
    assert str(refused.value) == f"{config}:2: {array}[4] lacks one of X Y Z A B C"
