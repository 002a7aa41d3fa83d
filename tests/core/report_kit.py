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
