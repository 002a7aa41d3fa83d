"""consistency: model against table, deltas against tables, session against calibration."""

import numpy as np
import pytest

from calibrator import robots
from calibrator.calibration import Calibration
from calibrator.errors import CalibrationError
from calibrator.inputs.errors import ConsistencyError
from calibrator.model import consistency, parameters
from calibrator.session import SessionMeta

UR10E = robots.get("ur10e").mdh
FREE = ("a2", "d4", "theta3")


def calibration(nominal=UR10E, model="ur10e", change=None, frame="base"):
    mdh = nominal.copy()
    mdh[1, 0] += 0.4  # a2
    mdh[3, 3] -= 0.2  # d4
    mdh[2, 2] += 0.001  # theta3
    space = parameters.ParameterSpace(nominal, free=FREE)
    deltas = dict(zip(space.free, space.pack(mdh), strict=True))
    if change:
        deltas.update(change)
    return Calibration(
        nominal_mdh=nominal, mdh=mdh, free=FREE, deltas=deltas, model=model, frame=frame
    )


def check(cal, where="calibration"):
    """check_calibration as reading a file calls it: with the catalogue's table of the model."""
    named = cal.model is not None and cal.model.lower() in robots.names()
    consistency.check_calibration(cal, where, robots.get(cal.model).mdh if named else None)


def test_a_consistent_calibration_passes():
    check(calibration())


def test_a_factory_calibration_as_nominal_is_still_its_model():
    # A few mm and mrad from the catalogue table: what --nominal imports.
    factory = UR10E + np.array([2.0, 0.003, -0.004, 1.5, 0.002])
    check(calibration(nominal=factory))


@pytest.mark.parametrize("model", ["ur5e", "ur10", "er10l-c10", "UR5E"])
def test_another_models_name_is_refused(model):
    with pytest.raises(ConsistencyError, match=f"is not a {model} "):
        check(calibration(model=model), "c.json")


def test_a_name_outside_the_catalogue_is_described_by_its_table():
    check(calibration(model="my-arm"))
    check(calibration(model=None))


@pytest.mark.parametrize(("name", "by"), [("a2", 1e-3), ("theta3", 1e-6), ("d4", -0.5)])
def test_a_hand_edited_delta_is_refused_naming_it(name, by):
    good = calibration()
    with pytest.raises(ConsistencyError, match=rf"^c.json: deltas.{name} is "):
        check(calibration(change={name: good.deltas[name] + by}), "c.json")


def test_rounding_of_a_delta_passes():
    good = calibration()
    check(calibration(change={"a2": good.deltas["a2"] + 1e-9}))


def test_an_absurd_table_is_refused_before_it_overflows():
    table = UR10E.copy()
    table[2, 3] = 1e308
    with pytest.raises(CalibrationError, match=r"^t: d3 = 1e\+308 mm is beyond 100000 mm"):
        consistency.check_mdh_sane(table, "t")
    table[2, 3] = 0.0
    table[4, 1] = -200.0
    with pytest.raises(CalibrationError, match=r"^t: alpha5 = -200 rad is beyond 100 rad"):
        consistency.check_mdh_sane(table, "t")
    consistency.check_mdh_sane(UR10E, "t")


def meta(model="ur10e", nominal=UR10E, frame="base"):
    return SessionMeta(frame=frame, nominal_mdh=nominal, model=model)


def test_a_session_of_the_same_arm_passes():
    consistency.check_session_matches(calibration(), meta())
    consistency.check_session_matches(calibration(), meta(model=None))
    factory = UR10E + 1.0 * (np.arange(5) % 3 == 0)  # factory deltas of 1 mm on a and d
    consistency.check_session_matches(calibration(), meta(nominal=factory))


@pytest.mark.parametrize(
    ("session", "message"),
    [
        (
            meta(model="ur5e", nominal=robots.get("ur5e").mdh),
            "s.parquet is of a ur5e, the calibration of a ur10e",
        ),
        (
            meta(model=None, nominal=robots.get("ur5e").mdh),
            "its nominal MDH table is not the calibration's (a2",
        ),
        (meta(frame="tracker"), "records points in the tracker frame"),
    ],
)
def test_a_session_of_another_arm_or_frame_is_refused(session, message):
    with pytest.raises(ConsistencyError) as info:
        consistency.check_session_matches(calibration(), session, "s.parquet")
    assert message in str(info.value)
