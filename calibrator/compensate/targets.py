"""Compensation of a targets CSV: read in blocks, solved, written as the result CSV.

:func:`iter_targets` reads a targets CSV (nominal joints, optional desired
poses) block by block in the strict number grammar; :func:`run` compensates
each block (:func:`calibrator.compensate.core.compensate`) and writes the
result CSV atomically, so memory does not grow with the file.
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Iterator
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from calibrator.compensate.core import MAX_JOINT_CHANGE_DEG, compensate, correction_sizes
from calibrator.errors import CalibrationError
from calibrator.inputs import grammar
from calibrator.inputs.errors import StrictError
from calibrator.model import frames, rotations, singularities
from calibrator.model.inverse import Solution

if TYPE_CHECKING:
    from calibrator.calibration import Calibration


#: Columns of the nominal joints (rad) in a targets CSV and of the calibrated ones in the result.
JOINT_COLUMNS = tuple(f"q{i}_rad" for i in range(1, 7))
#: The same joints in degrees, as a plan file may give them (``plan --from`` reads both).
DEG_COLUMNS = tuple(f"q{i}_deg" for i in range(1, 7))
#: Columns of a pose (base frame, mm; rotation vector, rad), desired or corrected.
POSE_COLUMNS = ("x_mm", "y_mm", "z_mm", "rx_rad", "ry_rad", "rz_rad")


@dataclass(frozen=True)
class Report:
    """Outcome of :func:`run`: whether every target was reached, and lines to print."""

    ok: bool
    lines: list


def _repeated_header_names(path):
    """Column names the CSV header at ``path`` gives more than once, sorted."""
    import csv

    # Called once pandas has read the file: it is UTF-8 text with a header.
    with open(path, newline="", encoding="utf-8") as fh:
        header = next(csv.reader(fh))
    return sorted({name for name in header if header.count(name) > 1})


#: Targets read, solved and written together by :func:`run`.
BLOCK = 10_000


def _read_table(path, **kw):
    """pandas' reader of a targets CSV as text, one error line for anything it refuses."""
    import pandas as pd

    try:
        # As text: numbers are read by the one strict grammar, not pandas' own.
        # index_col=False and the warning as an error: a row longer than the
        # header must not turn its first field into a silent index.
        with warnings.catch_warnings():
            warnings.simplefilter("error", pd.errors.ParserWarning)
            yield from pd.read_csv(
                path, dtype=str, keep_default_na=False, index_col=False, chunksize=BLOCK, **kw
            )
    except pd.errors.ParserWarning:
        raise CalibrationError(f"{path}: a row has more fields than the header") from None
    except (OSError, ValueError, pd.errors.ParserError) as exc:
        raise CalibrationError(f"{path}: not a readable CSV ({str(exc).splitlines()[0]})") from None


def _numbers_fast(cells: np.ndarray) -> np.ndarray | None:
    """The cells (n, m) as floats when every one is plainly in the strict grammar, else None.

    Python's ``float`` reads every number of the strict grammar
    (:func:`calibrator.inputs.grammar.parse_number`) and more: underscores, non-ASCII
    digits, ``nan`` and ``inf``. A block with none of those (no ``_``, ASCII
    only, every value finite, no cell over 64 characters) that ``float``
    reads whole is read at C speed; anything else returns None and goes
    to the cell-by-cell reader, which names the first bad cell.
    """
    flat = cells.ravel()
    try:
        joined = "\n".join(flat)
    except TypeError:
        return None
    if not joined.isascii() or "_" in joined or max(map(len, flat), default=0) > 64:
        return None
    try:
        values = flat.astype(float)
    except ValueError:
        return None
    if not np.all(np.isfinite(values)):
        return None
    return values.reshape(cells.shape)


def iter_targets(
    path: str | os.PathLike[str],
) -> Iterator[tuple[int, np.ndarray, np.ndarray | None]]:
    """Blocks of at most :data:`BLOCK` targets from a targets CSV, in order.

    Yields
    ------
    first : int
        Row number (from 0) of the block's first target.
    q : ndarray, shape (n, 6)
        Nominal joints (rad), from ``q1_rad..q6_rad`` or, as a plan file may
        give them, ``q1_deg..q6_deg`` (one set, not both).
    desired : ndarray, shape (n, 4, 4) or None
        Desired poses, when the file has pose columns.

    Raises
    ------
    CalibrationError
        Missing or repeated columns, non-numeric or non-finite values, a
        partial pose, no targets.
    """
    first = 0
    present: list = []
    joints, factor = JOINT_COLUMNS, 1.0
    for table in _read_table(path):
        if first == 0:
            has_deg = all(c in table.columns for c in DEG_COLUMNS)
            if has_deg and any(c in table.columns for c in JOINT_COLUMNS):
                raise CalibrationError(f"{path}: both q1_rad..q6_rad and q1_deg..q6_deg; keep one")
            if has_deg:
                joints, factor = DEG_COLUMNS, np.pi / 180.0
            missing = [c for c in joints if c not in table.columns]
            if missing:
                raise CalibrationError(f"{path}: missing column(s) {', '.join(missing)}")
            present = [c for c in POSE_COLUMNS if c in table.columns]
            if present and len(present) != len(POSE_COLUMNS):
                raise CalibrationError(f"{path}: a pose needs all of {', '.join(POSE_COLUMNS)}")
            repeated = _repeated_header_names(path)
            if repeated:
                # pandas renames a repeated "q1_rad" to "q1_rad.1" and would read the first.
                raise CalibrationError(f"{path}: repeated column(s) {', '.join(repeated)}")

        def numbers(cols, table=table, first=first):
            cells = table[list(cols)].to_numpy(dtype=object)
            values = _numbers_fast(cells)
            if values is None:  # something is off: the cell-by-cell reading names it
                try:
                    values = grammar.parse_columns(cells, cols, str(path), first)
                except StrictError as exc:
                    raise CalibrationError(str(exc)) from None
            bad = ~np.isfinite(values)
            if bad.any():
                row = first + int(np.argwhere(bad)[0, 0]) + 1
                raise CalibrationError(f"{path}: NaN or infinite value in row {row}")
            return values

        q = numbers(joints) * factor
        desired = None
        if present:
            pose = numbers(POSE_COLUMNS)
            desired = frames.transform(rotations.rotvec_to_matrix(pose[:, 3:]), pose[:, :3])
        yield first, q, desired
        first += len(q)
    if first == 0:
        raise CalibrationError(f"{path}: no targets")


def read_targets(path: str | os.PathLike[str]) -> tuple[np.ndarray, np.ndarray | None]:
    """Nominal joints (N, 6) and desired poses (N, 4, 4) or None from a targets CSV.

    Raises
    ------
    CalibrationError
        Missing or repeated columns, non-numeric or non-finite values, a
        partial pose, no targets.
    """
    blocks = list(iter_targets(path))
    q = np.concatenate([b[1] for b in blocks])
    if blocks[0][2] is None:
        return q, None
    return q, np.concatenate([b[2] for b in blocks])


def run(
    calibration: Calibration,
    targets_path: str | os.PathLike[str],
    output: str | os.PathLike[str],
    payload_kg: float | None = None,
) -> Report:
    """Compensate a targets CSV and write the result CSV atomically, block by block.

    Output columns: ``target`` (row number, from 0, as plans number their
    poses), ``status`` (``ok``, ``outside joint limits``, ``not reached`` or
    ``large joint change``: a joint would turn more than
    :data:`MAX_JOINT_CHANGE_DEG` between the nominal and the calibrated
    solution, near a singularity), ``q1_rad..q6_rad`` (joints of the
    calibrated arm; empty when not ok), ``x_mm .. rz_rad`` (corrected target
    for a nominal controller, base frame, rotation vector; empty when not
    ok), ``correction_mm`` and ``correction_mrad`` (how far the corrected
    target is from the desired one: distance and turn),
    ``joint_correction_mrad`` (largest change of a joint from the nominal
    solution), ``iterations``, ``error_mm``.

    Targets are read, solved and written :data:`BLOCK` at a time, so memory
    does not grow with the file.

    Returns
    -------
    Report
    """
    from calibrator import outputs, robots

    limits = None
    # The CSV's joints are the controller's angles and its poses in the controller's
    # base frame; the solver's, the model's.
    convention, base = robots.JointConvention(), np.eye(4)
    try:
        if calibration.model:
            arm = robots.get(calibration.model)
            limits, convention = arm.joint_limits_rad, arm.convention
            base = arm.model_base2controller_base
    except CalibrationError:
        limits = None
    frame = _Frame(convention, base)
    tally = _Tally()

    def write(tmp):
        import pyarrow.csv as pa_csv

        with open(tmp, "wb") as fh:
            for first, q_stated, desired in iter_targets(targets_path):
                q_nom = convention.to_model(q_stated)
                if desired is not None:
                    desired = base @ desired
                block = _solve_block(calibration, q_nom, desired, limits, payload_kg, first, frame)
                # pyarrow's writer: numbers in C, shortest text that reads back exactly.
                options = pa_csv.WriteOptions(
                    include_header=first == 0, quoting_style="none", quoting_header="none"
                )
                pa_csv.write_csv(block.frame, fh, options)
                tally.add(block, calibration, limits)

    outputs.write_with(output, write, inputs=[targets_path])
    return tally.report(calibration, limits, output)


@dataclass
class _Block:
    frame: object  # pyarrow.Table of the output rows
    first: int
    solution: Solution
    q_nominal: np.ndarray
    size: dict
    jump: np.ndarray


@dataclass(frozen=True)
class _Frame:
    """How the CSV states joints and poses: the controller's angles, in its base frame."""

    convention: Any
    model_base2controller_base: np.ndarray


def _solve_block(calibration, q_nom, desired, limits, payload_kg, first, frame):
    import pyarrow as pa

    result = compensate(calibration, desired, q_nom, limits, payload_kg)
    sol = result.solution
    # A joint swinging far between the nominal and calibrated solution: near a singularity.
    jump = np.degrees(np.max(np.abs(result.q - result.q_nominal), axis=1))
    ok = sol.ok & (jump <= MAX_JOINT_CHANGE_DEG)
    status = np.where(ok, "ok", np.where(sol.ok, "large joint change", sol.reason))
    shown = frames.invert(frame.model_base2controller_base) @ result.corrected
    corrected = np.concatenate(
        [shown[:, :3, 3], rotations.matrix_to_rotvec(shown[:, :3, :3])], axis=1
    )
    size = correction_sizes(result, q_nom if desired is None else None)
    data = {"target": pa.array(first + np.arange(len(status))), "status": pa.array(status)}
    q_controller = frame.convention.to_controller(sol.q)
    for k, col in enumerate(JOINT_COLUMNS):
        data[col] = pa.array(q_controller[:, k], mask=~ok)  # empty when not ok
    for k, col in enumerate(POSE_COLUMNS):
        data[col] = pa.array(corrected[:, k], mask=~ok)
    for col, values in size.items():
        data[col] = pa.array(values, mask=~ok)
    data["iterations"] = pa.array(sol.iterations)
    data["error_mm"] = pa.array(sol.error_mm)
    return _Block(pa.table(data), first, sol, result.q_nominal, size, jump)


class _Tally:
    """What the blocks of :func:`run` add up to: counts, largest corrections, failures."""

    def __init__(self) -> None:
        self.n = 0
        self.failed = 0
        self.largest = np.zeros(3)
        self.any_ok = False
        self.lines: list = []
        self.ok_q: list = []

    def add(self, block: _Block, calibration, limits) -> None:
        sol = block.solution
        ok = sol.ok & (block.jump <= MAX_JOINT_CHANGE_DEG)
        self.n += len(ok)
        if ok.any():
            self.any_ok = True
            sizes = [
                block.size[k][ok]
                for k in ("correction_mm", "correction_mrad", "joint_correction_mrad")
            ]
            self.largest = np.maximum(self.largest, [np.max(v) for v in sizes])
            self.ok_q.append(sol.q[ok])
        failed = np.flatnonzero(~ok)
        self.failed += len(failed)
        room = max(0, 10 - len(self.lines))
        show = failed[:room]
        near = (
            singularities.nearest(calibration.nominal_mdh, block.q_nominal[show])
            if len(show)
            else []
        )
        for i, why in zip(show, near, strict=True):
            number = block.first + i
            if not sol.converged[i]:
                self.lines.append(
                    f"target {number}: not reached ({sol.error_mm[i]:.3g} mm off after "
                    f"{sol.iterations[i]} iterations{'; ' + why if why else ''})"
                )
            elif not sol.within_limits[i] and limits is not None:
                lo, hi = limits[:, 0], limits[:, 1]
                joints = [j + 1 for j in range(6) if not lo[j] <= sol.q[i, j] <= hi[j]]
                self.lines.append(
                    f"target {number}: unreachable within the joint limits "
                    f"(joint {', '.join(map(str, joints))})"
                )
            else:
                j = int(np.argmax(np.abs(sol.q[i] - block.q_nominal[i])))
                self.lines.append(
                    f"target {number}: large joint change: joint {j + 1} would turn "
                    f"{block.jump[i]:.1f} deg between the nominal and the calibrated solution"
                    + (f" ({why})" if why else "")
                )

    def report(self, calibration, limits, output) -> Report:
        lines = [
            f"{self.n - self.failed} of {self.n} targets compensated"
            + ("" if limits is not None else " (no joint limits known for this model)")
            + f"; wrote {output}"
        ]
        if self.any_ok:
            mm, mrad, joint = self.largest
            lines.append(
                f"corrections: up to {mm:.3f} mm and {mrad:.3f} mrad on the targets, "
                f"{joint:.3f} mrad on a joint"
            )
        lines += self.lines
        if self.failed > 10:
            lines.append(f"... and {self.failed - 10} more (see the status column)")
        # Targets outside the joint ranges the calibration was fitted on: extrapolated.
        ranges = calibration.fit.fitted_joint_ranges_rad
        if np.shape(ranges) == (6, 2) and self.ok_q:
            from calibrator import robots
            from calibrator.identify.uncertainty import range_warnings

            fitted = np.asarray(ranges, dtype=float).T
            # Both in the controller's angles (the calibration's ranges are).
            q_ok = robots.convention_of(calibration.model).to_controller(np.concatenate(self.ok_q))
            lines += [f"warning: {w}" for w in range_warnings(fitted, q_ok, "target")]
        return Report(self.failed == 0, lines)
