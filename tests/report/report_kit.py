"""A report's content built by hand, for the page and plot tests."""

from calibrator.report import data


def content(**fields):
    """A :class:`calibrator.report.data.Content` holding nothing but ``fields``."""
    empty = dict(
        title="t",
        facts=[],
        stats={},
        deltas={},
        standard_errors=None,
        dropped=[],
        convergence=None,
        poses=None,
    )
    return data.Content(**{**empty, **fields})


def calibration_of(doc):
    """A :class:`calibrator.calibration.Calibration` of a partial document.

    Arms and frames default to a nominal UR10e in the base frame; the
    provenance and fit report keys are read by their own readers. Built
    without :func:`calibrator.calibration.from_json`'s checks, so a test can
    hand the report an arm whose fixed parameters differ from nominal (a
    known true arm).
    """
    import numpy as np

    from calibrator import calibration, robots

    nominal = np.asarray(doc.get("nominal_mdh", robots.get("ur10e").mdh), dtype=float)
    deltas = {k: float(v) for k, v in doc.get("deltas", {}).items()}
    free = doc.get("free_parameters", list(deltas))
    mdh = nominal.copy()
    if "mdh" in doc:
        mdh = calibration.mdh_from_records(doc["mdh"])
    else:
        for name, value in deltas.items():
            if name in calibration.parameters.MDH_NAMES:
                mdh.ravel()[calibration.parameters.MDH_NAMES.index(name)] += value
    rest = {k: v for k, v in doc.items() if k not in calibration.TYPED_KEYS}
    return calibration.Calibration(
        nominal_mdh=nominal,
        mdh=mdh,
        base2tracker=np.asarray(doc.get("base2tracker", np.eye(4)), dtype=float),
        flange2tool=np.asarray(doc.get("flange2tool", np.eye(4)), dtype=float),
        free=tuple(free),
        deltas=deltas or {n: 0.0 for n in free},
        dropped=list(doc.get("dropped_parameters", [])),
        model=doc.get("model"),
        session=doc.get("session"),
        provenance=calibration.Provenance.from_json(doc),
        fit=calibration.FitReport.from_json(doc),
        diagnostics=rest,
    )
