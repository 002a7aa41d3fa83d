"""A calibration file missing parts of its uncertainty: the check uses what is there.

An older or hand-written calibration may record standard errors without
their correlations (the parameters' covariance is then unknown: zeros, no
crash), or a residual section whose position noise is unknown (no noise: the
check cannot predict its error and refuses the file, as one with no
uncertainty at all).
"""

from __future__ import annotations

import numpy as np
import pytest

from calibrator import calibration, session, simulate
from calibrator.calibration import Calibration
from calibrator.check import procedure
from calibrator.check.model import Calibrated
from calibrator.errors import CalibrationError
from calibrator.identify import pipeline


@pytest.fixture(scope="module")
def document():
    """A ur10e calibrated on 30 simulated poses in the tracker frame, as its JSON document."""
    table, meta, _ = simulate.simulate(
        "ur10e", poses=30, seed=8, frame="tracker", orientation=False, noise_mm=0.02,
        errors="random",
    )  # fmt: skip
    result = pipeline.identify(session.Session(table, meta), pipeline.Options(method="lm"))
    return Calibration.from_result(result, model="ur10e", frame="tracker").to_json()


def _edited(document, **uncertainty):
    """The calibration with its uncertainty's sections replaced (None: left out)."""
    kept = {**document["uncertainty"], **uncertainty}
    doc = {**document, "uncertainty": {k: v for k, v in kept.items() if v is not None}}
    return calibration.from_json(doc)


def test_standard_errors_without_correlations_give_no_covariance(document):
    whole = Calibrated.of(calibration.from_json(document))
    assert np.abs(whole.cov).max() > 0  # the premise: the file's covariance is used
    part = Calibrated.of(_edited(document, correlation=None))
    assert part.cov.shape == whole.cov.shape and not part.cov.any()
    assert part.sigma_mm == whole.sigma_mm > 0


def test_a_residual_without_its_position_noise_is_refused(tmp_path, document):
    residual = dict(document["uncertainty"]["residual_sigma"])
    residual["position_mm"] = None  # recorded as unknown (JSON null)
    cal = _edited(document, residual_sigma=residual)
    assert Calibrated.of(cal).sigma_mm == 0.0
    with pytest.raises(CalibrationError, match="records no residual noise"):
        procedure.checkable(cal, tmp_path / "cal.json")
