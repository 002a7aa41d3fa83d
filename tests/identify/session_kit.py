"""Sessions for the identify tests, written and loaded back so the file format is exercised."""

from calibrator import session
from calibrator.simulate import simulate


def written(tmp_path, table, meta, name="s.parquet"):
    """``table`` and ``meta`` written as ``tmp_path / name``, and the session loaded back."""
    path = tmp_path / name
    session.write(path, table, meta)
    return session.load(path)


def simulated(tmp_path, name="session.parquet", **kwargs):
    """``calibrator.simulate.simulate(**kwargs)`` written and loaded back: (session, truth)."""
    table, meta, truth = simulate(**kwargs)
    return written(tmp_path, table, meta, name), truth
