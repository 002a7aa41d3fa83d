"""The plan type (calibrator/planning/plan.py): its digest, as the journal format defines it."""

import hashlib
import struct

import numpy as np

from calibrator import planning, robots
from calibrator.model import frames

UR10E = robots.get("ur10e")
TOOL = frames.transform(translation=[0.0, 0.0, 100.0])
TOOL_MM = (0.0, 0.0, 100.0)
LIMITS = np.tile([-2.0, 3.0], (6, 1))


def test_the_digest_is_the_sha256_of_the_little_endian_doubles_row_by_row():
    q = np.arange(12, dtype=float).reshape(2, 6) / 7
    expected = hashlib.sha256(struct.pack("<12d", *q.ravel()))
    assert planning.digest(q) == expected.hexdigest()
    assert (
        planning.digest(q.astype(">f8"))
        == planning.digest(np.asfortranarray(q))
        == planning.digest(q)
    )
    assert planning.digest(np.arange(12).reshape(2, 6)) == planning.digest(
        np.arange(12.0).reshape(2, 6)
    )
    nudged = q.copy()
    nudged[1, 5] = np.nextafter(nudged[1, 5], 9)
    assert planning.digest(nudged) != planning.digest(q)
