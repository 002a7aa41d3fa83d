"""``--frames``: each entry's rotation by angles or by quaternion, and a refusal naming the entry.

A frame given as ``abc_deg`` and the same frame as a unit ``quaternion``
(``[w, x, y, z]``) are one transform; each table records which file gave
each frame. A bad file is refused with one line naming the file, the entry
and what it needed.
"""

from __future__ import annotations

import numpy as np
import pytest
from filter_kit import frame_yaml

from calibrator.errors import CalibrationError
from calibrator.languages import frames_file
from calibrator.model import frames, rotations

FRAME = frames.transform(rotations.zyx_to_matrix([[30.0, -20.0, 10.0]])[0], [1.0, 2.0, 3.0])


def test_a_frame_by_quaternion_is_the_frame_by_angles(tmp_path):
    w, x, y, z = rotations.matrix_to_quaternion(FRAME[None, :3, :3], [[1, 0, 0, 0]])[0]
    path = tmp_path / "frames.yaml"
    path.write_text(
        f"tools:\n  Gun: {frame_yaml(FRAME)}\n"
        f"bases:\n  '2': {{xyz_mm: [1.0, 2.0, 3.0], quaternion: [{w}, {x}, {y}, {z}]}}\n"
        "pulses_per_degree: [1, 2, 3, 4, 5, 6]\nzero_pulses: [0, -1, 2, 0, 0, 7]\n"
    )
    table = frames_file.read(path)
    np.testing.assert_allclose(table.tools["gun"], FRAME, atol=1e-9)
    np.testing.assert_allclose(table.bases["2"], FRAME, atol=1e-9)
    assert table.source == {"tools:gun": str(path), "bases:2": str(path)}
    np.testing.assert_array_equal(table.pulses_per_degree, [1, 2, 3, 4, 5, 6])
    np.testing.assert_array_equal(table.zero_pulses, [0, -1, 2, 0, 0, 7])


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("- 1\n- 2\n", "expected a mapping with tools, bases, pulses_per_degree"),
        ("tool: {}\n", "unknown key(s) tool (known: "),
        ("tools:\n  t: {xyz_mm: [1, 2, 3], abc_deg: [1, 2]}\n",
         "tools.t.abc_deg: expected a list of 3 numbers"),
        ("bases:\n  b: {xyz_mm: [1, 2, 3], quaternion: [1, 0, 0]}\n",
         "bases.b.quaternion: expected a list of 4 numbers"),
        ("bases:\n  b: {xyz_mm: [1, 2, 3], quaternion: [2, 0, 0, 0]}\n",
         "bases.b.quaternion: not a unit quaternion"),
        ("tools:\n  t: {xyz_mm: [1, 2], abc_deg: [1, 2, 3]}\n",
         "tools.t.xyz_mm: expected a list of 3 numbers"),
        ("tools:\n  T: {xyz_mm: [1, 2, 3], abc_deg: [1, 2, 3]}\n  t: {xyz_mm: [1, 2, 3], "
         "abc_deg: [1, 2, 3]}\n", "tools names 't' twice (names ignore case)"),
        ("pulses_per_degree: [1, 2, 3, 4, 5]\n", "pulses_per_degree: expected a list of 6 numbers"),
        ("pulses_per_degree: [1, 2, 0, 4, 5, 6]\n", "pulses_per_degree must not be 0"),
        ("zero_pulses: [1, 2, 3, 4, 5, x]\n", "zero_pulses: expected a list of 6 numbers"),
    ],
)  # fmt: skip
def test_a_bad_frames_file_is_refused_naming_the_entry(tmp_path, text, message):
    path = tmp_path / "frames.yaml"
    path.write_text(text)
    with pytest.raises(CalibrationError) as refused:
        frames_file.read(path)
    assert str(refused.value).startswith(f"{path}: {message}"), str(refused.value)
