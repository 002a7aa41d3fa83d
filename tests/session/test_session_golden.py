"""The session footer is byte for byte the golden file, and a loaded session is never changed.

The golden footer was written by the program before its documents were
frozen: the same inputs must keep giving the same bytes.
"""

from dataclasses import FrozenInstanceError
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest

from calibrator import robots, session

FOOTER = Path(__file__).parent / "golden" / "session_footer.json"


def test_a_session_footer_is_the_golden_bytes(tmp_path):
    extra = {"simulated": {"seed": 1}}
    flange2tool = np.eye(4)
    flange2tool[:3, 3] = [1.5, -2.0, 150.0]
    nominal = robots.get("ur10e").mdh
    meta = session.SessionMeta("tracker", nominal, "ur10e", flange2tool, True, extra)
    q = np.linspace(-1.0, 1.0, 36).reshape(6, 6)
    points = np.arange(18, dtype=float).reshape(6, 3) * 100.0 + 500.0
    table = session.to_table(q, points, spread=np.full((6, 3), 0.01), n_readings=np.full(6, 10))
    session.write(tmp_path / "s.parquet", table, meta)
    footer = pq.ParquetFile(tmp_path / "s.parquet").schema_arrow.metadata[session.META_KEY]
    assert footer == FOOTER.read_bytes()
    loaded = session.load(tmp_path / "s.parquet")
    with pytest.raises(FrozenInstanceError):
        loaded.meta.frame = "base"  # type: ignore[misc]
    with pytest.raises(ValueError, match="read-only"):
        loaded.meta.nominal_mdh[0, 0] = 1.0
    assert loaded.meta.extra == extra and loaded.meta.tool_known is True
