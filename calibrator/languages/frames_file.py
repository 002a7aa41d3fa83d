"""``--frames FILE``: tools, bases and pulse scales a program names but does not define.

A YAML mapping (every length in mm, every angle in deg)::

    tools:                 # by the name or number the program uses
      "1": {xyz_mm: [0, 0, 150], abc_deg: [0, 0, 0]}
      gripper: {xyz_mm: [12.5, 0, 210], quaternion: [0.7071068, 0, 0.7071068, 0]}
    bases:                 # user frames, work objects, KUKA bases
      "2": {xyz_mm: [1200, -300, 0], abc_deg: [90, 0, 0]}
    pulses_per_degree: [1304.6, 1304.6, 1304.6, 975.6, 975.6, 614.8]   # Yaskawa
    zero_pulses: [0, 0, 0, 0, 0, 0]                                     # optional

Tools are given on the controller's flange (tool 0) and bases in its base
or world frame (base 0), as the pendant shows them; the engine places both
on the model (:attr:`calibrator.languages.reading.Job.controller_base`).
``abc_deg`` is ``Rz(a) Ry(b) Rx(c)`` (KUKA's A, B, C; Fanuc's W, P, R and
Yaskawa's Rx, Ry, Rz are written there as ``[r, p, w]``), ``quaternion`` is
``[w, x, y, z]`` (ABB's order). Names match without regard to case (KRL and
RAPID are case-insensitive). A duplicate key, an unknown key, a number
outside the strict grammar, a frame with both or neither orientation is
refused.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from calibrator.errors import CalibrationError
from calibrator.inputs import textfile, yamlfile
from calibrator.model import frames, rotations

#: Largest frames file read (bytes).
MAX_BYTES = 1_000_000
_TOP = {"tools", "bases", "pulses_per_degree", "zero_pulses"}


@dataclass
class FrameTable:
    """Frames by lower-case name (mm), and the pulse scale of Yaskawa jobs.

    Attributes
    ----------
    tools, bases : dict of str to ndarray, shape (4, 4)
        ``flange2tool`` and ``base2frame``: a tool on the controller's flange,
        a frame's pose in the controller's base frame.
    pulses_per_degree, zero_pulses : ndarray, shape (6,) or None
    source : dict of str to str
        Where each frame came from (for messages).
    """

    tools: dict = field(default_factory=dict)
    bases: dict = field(default_factory=dict)
    pulses_per_degree: np.ndarray | None = None
    zero_pulses: np.ndarray | None = None
    source: dict = field(default_factory=dict)


def _numbers(value, n, where):
    if (
        not isinstance(value, list)
        or len(value) != n
        or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value)
    ):
        raise CalibrationError(f"{where}: expected a list of {n} numbers")
    out = np.asarray(value, dtype=float)
    if not np.all(np.isfinite(out)):
        raise CalibrationError(f"{where}: numbers must be finite")
    return out


def frame_from(entry: object, where: str) -> np.ndarray:
    """A (4, 4) transform from one ``{xyz_mm, abc_deg | quaternion}`` entry."""
    if not isinstance(entry, dict) or "xyz_mm" not in entry:
        raise CalibrationError(f"{where}: expected a mapping with xyz_mm and abc_deg or quaternion")
    extra = set(entry) - {"xyz_mm", "abc_deg", "quaternion"}
    if extra:
        raise CalibrationError(f"{where}: unknown key(s) {', '.join(sorted(map(str, extra)))}")
    xyz = _numbers(entry["xyz_mm"], 3, f"{where}.xyz_mm")
    if ("abc_deg" in entry) == ("quaternion" in entry):
        raise CalibrationError(f"{where}: give exactly one of abc_deg and quaternion")
    if "abc_deg" in entry:
        rot = rotations.zyx_to_matrix(_numbers(entry["abc_deg"], 3, f"{where}.abc_deg")[None])[0]
    else:
        quat = _numbers(entry["quaternion"], 4, f"{where}.quaternion")
        if not 0.99 < np.linalg.norm(quat) < 1.01:
            raise CalibrationError(f"{where}.quaternion: not a unit quaternion")
        rot = rotations.quaternion_to_matrix(quat[None])[0]
    return frames.transform(rot, xyz)


def read(path: str | Path | None) -> FrameTable:
    """The frames of ``path`` (an empty table for None).

    Raises
    ------
    CalibrationError
        Unreadable file, not YAML, duplicate or unknown keys, bad values.
    """
    table = FrameTable()
    if path is None:
        return table
    doc = yamlfile.loads(textfile.read_text(path, MAX_BYTES, "a frames file"), str(path))
    if not isinstance(doc, dict):
        raise CalibrationError(f"{path}: expected a mapping with tools, bases, pulses_per_degree")
    unknown = set(doc) - _TOP
    if unknown:
        raise CalibrationError(
            f"{path}: unknown key(s) {', '.join(sorted(map(str, unknown)))} "
            f"(known: {', '.join(sorted(_TOP))})"
        )
    for group in ("tools", "bases"):
        entries = doc.get(group) or {}
        if not isinstance(entries, dict):
            raise CalibrationError(f"{path}: {group} must be a mapping of name to frame")
        for name, entry in entries.items():
            key = str(name).lower()
            target = getattr(table, group)
            if key in target:
                raise CalibrationError(f"{path}: {group} names {name!r} twice (names ignore case)")
            target[key] = frame_from(entry, f"{path}: {group}.{name}")
            table.source[f"{group}:{key}"] = str(path)
    if "pulses_per_degree" in doc:
        ppd = _numbers(doc["pulses_per_degree"], 6, f"{path}: pulses_per_degree")
        if np.any(ppd == 0):
            raise CalibrationError(f"{path}: pulses_per_degree must not be 0")
        table.pulses_per_degree = ppd
    if "zero_pulses" in doc:
        table.zero_pulses = _numbers(doc["zero_pulses"], 6, f"{path}: zero_pulses")
    return table
