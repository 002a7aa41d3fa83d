"""identify judges its own answer: deltas a real arm cannot have are warned about or refused."""

import dataclasses

import pytest

from calibrator import session
from calibrator.errors import CalibrationError
from calibrator.identify import pipeline
from calibrator.simulate import simulate


def _session_with_nominal_a2_off_by(offset_mm):
    # The arm is a UR10e; the session's nominal table says a2 is offset_mm longer,
    # as if the wrong model variant had been chosen: the fit must absorb it in a2.
    table, meta, _ = simulate(model="ur10e", poses=30, seed=4, errors="none")
    nominal = meta.nominal_mdh.copy()
    nominal[1, 0] += offset_mm
    return session.Session(table, dataclasses.replace(meta, nominal_mdh=nominal, model=None))


def test_a_large_but_possible_delta_is_a_warning():
    result = pipeline.identify(_session_with_nominal_a2_off_by(30.0), pipeline.Options(method="lm"))
    assert result.stats["validation"]["after"]["position_mm"]["mean"] < 1e-3
    assert any(w.startswith("identified a2 is -30") for w in result.warnings), result.warnings


def test_an_implausible_delta_refuses_the_result():
    with pytest.raises(CalibrationError, match="identified a2 is -150.* implausible"):
        pipeline.identify(_session_with_nominal_a2_off_by(150.0), pipeline.Options(method="lm"))
