"""Streaming a program through its language, block by block, and the filter summary.

Targets are gathered until a block of :data:`BLOCK` is full; the block is
solved with one vectorised call per step (:mod:`calibrator.compensate.solve`,
:func:`calibrator.compensate.compensate`), its lines written out and
dropped. Memory is bounded by the block, whatever the program's length.

Per target: Cartesian targets are corrected (desired pose = the controller's
base frame @ its base frame @ its pose, its tool on the controller's flange;
the calibrated arm's joints in the stated configuration; the nominal pose
of those joints, written back in the same frame); joint targets are kept,
or with ``--joint-targets correct`` replaced by the joints that make the
calibrated arm reach the nominal pose of the original joints. A target
fails, named with its file and line, when no solution keeps its
configuration, the calibrated arm cannot reach it, its joints leave the
limits, a joint would turn more than
:data:`calibrator.compensate.MAX_JOINT_CHANGE_DEG` between the nominal and
the calibrated solution, or the correction exceeds ``--max-correction``.
"""

from __future__ import annotations

import gc
import json
from collections import defaultdict
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO

import numpy as np

from calibrator import outputs
from calibrator.compensate import core as compensate
from calibrator.compensate.solve import Solver
from calibrator.languages import configuration, convention, numbers, registry
from calibrator.languages.reading import Job, Target, Unit
from calibrator.model import frames, kinematics, rotations, singularities

#: Targets solved together.
BLOCK = 10_000
#: Failures kept in the summary (all are counted).
MAX_LISTED = 1000


@dataclass
class Summary:
    """What the filter did: counts per kind, failures with their lines, correction sizes."""

    language: str = ""
    found: dict = field(default_factory=lambda: defaultdict(int))
    corrected: dict = field(default_factory=lambda: defaultdict(int))
    kept: dict = field(default_factory=lambda: defaultdict(int))
    failed: dict = field(default_factory=lambda: defaultdict(int))
    failures: list = field(default_factory=list)
    max_mm: float = 0.0
    max_deg: float = 0.0
    sum_mm: float = 0.0
    sum_deg: float = 0.0
    outputs: list = field(default_factory=list)

    @property
    def n_failed(self) -> int:
        return sum(self.failed.values())

    def fail(self, target: Target, reason: str) -> None:
        self.failed[target.layout.kind] += 1
        if len(self.failures) < MAX_LISTED:
            self.failures.append(
                {"file": target.file, "line": target.line, "target": target.label, "reason": reason}
            )

    def to_json(self) -> dict:
        n = sum(self.corrected.values())
        kinds = sorted(set(self.found))
        return {
            "language": self.language,
            "targets": {
                k: {
                    "found": self.found[k],
                    "corrected": self.corrected[k],
                    "kept": self.kept[k],
                    "failed": self.failed[k],
                }
                for k in kinds
            },
            "failed": self.failures,
            "failed_total": self.n_failed,
            "correction": {
                "max_mm": self.max_mm,
                "mean_mm": self.sum_mm / n if n else 0.0,
                "max_deg": self.max_deg,
                "mean_deg": self.sum_deg / n if n else 0.0,
            },
            "outputs": self.outputs,
        }

    def lines(self) -> list[str]:
        out = []
        for k in sorted(self.found):
            out.append(
                f"{self.found[k]} {k} target(s): {self.corrected[k]} corrected, "
                f"{self.kept[k]} kept, {self.failed[k]} failed"
            )
        n = sum(self.corrected.values())
        if n:
            out.append(
                f"corrections: largest {self.max_mm:.3f} mm and {self.max_deg:.4f} deg, "
                f"mean {self.sum_mm / n:.3f} mm and {self.sum_deg / n:.4f} deg"
            )
        for f in self.failures[:20]:
            out.append(f"{f['file']}:{f['line']}: {f['target']}: {f['reason']}")
        if self.n_failed > 20:
            out.append(f"... and {self.n_failed - 20} more (see --summary)")
        return out


def run(
    fmt: str,
    job: Job,
    program: Path,
    output: Path,
    inputs: list,
    summary_path: Path | None = None,
    force: bool = False,
) -> Summary:
    """Compensate the program ``program`` in language ``fmt`` into ``output``; its summary.

    Every file the filter writes (KRL: ``OUT.dat`` beside ``OUT.src``) is
    checked first under the output policy (:func:`calibrator.outputs.check`:
    none may be an input, an existing file only with ``force``); the outputs
    are written only if no target failed or ``job.keep_failed``. With
    ``summary_path`` the summary is also written there as JSON.

    Parameters
    ----------
    fmt : str
        A reader's name (:func:`calibrator.languages.registry.readers`).
    job : Job
        The calibration, frames, limits and options.
    program, output : Path
    inputs : list of Path or None
        The other files read (frames, ``--config-dat``): no output may replace one.

    Raises
    ------
    CalibrationError
        An output path refused, or a program the reader cannot read.
    """
    inputs = [program] + list(inputs)
    filt = Filter(fmt, job, program)
    for _, written in filt.lang.files(output):
        outputs.check(written, inputs + [summary_path], force=force)
    summary = filt.run(output, inputs + [summary_path])
    if summary_path is not None:
        write_summary(summary_path, summary, inputs + [output])
    return summary


class Filter:
    """One program through one language; :meth:`run` writes the outputs or none."""

    def __init__(self, fmt: str, job: Job, program: Path) -> None:
        job.convention = job.convention or convention.for_model(job.calibration.model)
        if job.controller_base is None or job.controller_flange is None:
            base, flange = convention.controller_frames(job.calibration.model)
            job.controller_base = base if job.controller_base is None else job.controller_base
            job.controller_flange = (
                flange if job.controller_flange is None else job.controller_flange
            )
        self.job = job
        self.lang = registry.readers()[fmt].cls(job, program)
        self.solver = Solver(self.lang, job)
        self.summary = Summary(language=fmt)
        self.last_q: np.ndarray | None = None  # model joints the arm comes from

    def run(self, output: Path, inputs: list) -> Summary:
        """Filter every file of the program; write them only if nothing failed (or keep_failed)."""
        pairs = self.lang.files(output)
        # Every file read is an input no output may replace (KRL: the .dat too).
        batch = outputs.Outputs(list(inputs) + [src for src, _ in pairs])
        try:
            for src, dst in pairs:

                def write(tmp: Path, src: Path = src) -> None:
                    self._stream(src, tmp)

                batch.file(dst, write)
                self.summary.outputs.append(str(dst))
        except BaseException:
            batch.discard()
            raise
        if self.summary.n_failed and not self.job.keep_failed:
            batch.discard()
            self.summary.outputs = []
        else:
            batch.commit()
        return self.summary

    def _stream(self, src: Path, tmp: Path) -> None:
        with open(tmp, "w", encoding="latin-1", newline="") as out, _collector_paused():
            pending: list[Unit] = []
            count = 0
            for unit in self.lang.scan(src):
                if not unit.targets and not pending:
                    out.write("".join(unit.lines))
                    continue
                pending.append(unit)
                count += len(unit.targets)
                if count >= BLOCK:
                    self._flush(pending, out)
                    pending, count = [], 0
            self._flush(pending, out)

    def _flush(self, units: list[Unit], out: IO[str]) -> None:
        targets = [(u, t) for u in units for t in u.targets]
        if targets:
            self._solve(targets)
        out.write("".join([line for u in units for line in u.lines]))

    # -- solving -----------------------------------------------------------------------
    def _solve(self, items: list) -> None:
        """Solve, correct and splice a block of ``(unit, target)`` pairs, in place."""
        items = self._drop_unreadable(items)
        if not items:
            return
        units = [u for u, _ in items]
        targets = [t for _, t in items]
        block = _Block(targets, self.job)
        for layout, lrows, _ in block.groups:
            self.summary.found[layout.kind] += len(lrows)
        known_q, q_nom, bits, reasons = self._nominal(block, targets)
        joint_rows = np.flatnonzero(~block.is_pose)
        # Which rows go through the calibrated solver.
        active = np.zeros(block.n, dtype=bool)
        active[block.pose_rows] = ~np.isnan(q_nom[block.pose_rows, 0])
        if self.job.correct_joints:
            active[joint_rows] = True
        else:
            self.summary.kept["joints"] += len(joint_rows)
        result_q = np.full((block.n, 6), np.nan)  # model joints of the corrected target
        result_pose = np.full((block.n, 4, 4), np.nan)  # and their nominal tool poses
        rows = np.flatnonzero(active)
        if len(rows):
            self._compensate(targets, rows, block, q_nom, bits, reasons, result_q, result_pose)
        ok = active & np.array([r is None for r in reasons])
        self._rewrite(units, targets, block, ok, result_q, result_pose)
        for i in np.flatnonzero((~ok & active) | (~active & block.is_pose)).tolist():
            self._mark(units[i], targets[i], reasons[i])
        last = np.flatnonzero(~np.isnan(result_q[:, 0]) | ~np.isnan(known_q[:, 0]))
        if len(last):
            i = last[-1]
            self.last_q = q_nom[i] if not np.isnan(q_nom[i, 0]) else known_q[i]

    def _drop_unreadable(self, items: list) -> list:
        """Fail the targets the reader could not read (counted as found); the rest."""
        if all(t.problem is None for _, t in items):
            return items
        for u, t in items:
            if t.problem is not None:
                self.summary.found[t.layout.kind] += 1
                self._mark(u, t, t.problem)
        return [(u, t) for u, t in items if t.problem is None]

    def _nominal(self, block: _Block, targets: list) -> tuple:
        """Model joints of the joint targets, nominal solutions of the poses, and why not.

        Returns
        -------
        known_q : ndarray, shape (N, 6)
            Model joints of the joint targets (NaN for poses), rad.
        q_nom : ndarray, shape (N, 6)
            Nominal model joints of every target (NaN where none was found), rad.
        bits : ndarray, shape (N, 3)
            Arm bits of the nominal solutions where the solver took them (NaN elsewhere).
        reasons : list of (str or None), length N
        """
        conv = self.job.convention or convention.IDENTITY
        n, pose_rows = block.n, block.pose_rows
        reasons: list = [None] * n
        # Joint targets: known joints (also the arm's position for the poses after them).
        known_q = np.full((n, 6), np.nan)
        joint_rows = np.flatnonzero(~block.is_pose)
        known_q[joint_rows] = convention.to_model(block.joints[joint_rows], conv)
        q_nom = np.full((n, 6), np.nan)
        bits = np.full((n, 3), np.nan)
        if len(pose_rows):
            stated_codes = [targets[i].code for i in pose_rows.tolist()]
            stated = np.array([c is not None for c in stated_codes])
            k = len(self.solver.code_of(np.zeros((1, 6)))[0])
            codes = np.zeros((len(pose_rows), k), dtype=int)
            if stated.any():
                codes[stated] = np.array([c for c in stated_codes if c is not None])
            start = self._start(known_q, pose_rows[0])
            # A pose right after a joint target comes from those joints: the controller
            # solves it nearest them (a via, or a generated program's approach move).
            is_pose = block.is_pose
            after_joints = pose_rows[1:][~is_pose[pose_rows[1:] - 1]]
            comes_from = np.full((len(pose_rows), 6), np.nan)
            comes_from[np.searchsorted(pose_rows, after_joints)] = known_q[after_joints - 1]
            q, found, bits[pose_rows] = self.solver.solve(
                block.desired[pose_rows], block.tool[pose_rows], codes, stated, start, comes_from
            )
            q_nom[pose_rows] = q
            for j in np.flatnonzero(~found).tolist():
                want = self.lang.describe(tuple(codes[j])) if stated[j] else "the previous target's"
                reasons[pose_rows[j]] = (
                    f"no nominal joint solution found in the configuration ({want})"
                )
        q_nom[joint_rows] = known_q[joint_rows]
        return known_q, q_nom, bits, reasons

    def _rewrite(
        self, units: list, targets: list, block: _Block, ok, result_q, result_pose
    ) -> None:
        """Encode the corrected targets by layout and splice the tokens that read differently.

        Every changed line is spliced once, left to right (spans index the
        original line), whatever the number of targets or tokens on it.
        """
        job = self.job
        conv = job.convention or convention.IDENTITY
        # Per changed line: (unit, line index, [(span, text), ...]) of its tokens.
        lines: list[tuple] = []
        shared: dict = {}  # (id(unit), line index) -> its entry, where several targets may meet
        for layout, lrows, vals in block.groups:
            keep = ok[lrows]
            good = lrows[keep]
            if not len(good):
                continue
            old = vals[keep]
            if layout.kind == "pose":
                enc = layout.encode(frames.invert(block.base[good]) @ result_pose[good], old)
            else:
                enc = layout.encode(convention.to_controller(result_q[good], conv), old)
            tokens = [targets[i].tokens for i in good.tolist()]
            texts = numbers.write_many(tokens, old, enc, layout.units)
            self.summary.corrected[layout.kind] += len(good)
            for i, toks, new in zip(good.tolist(), tokens, texts, strict=True):
                if toks == new:
                    continue
                unit = units[i]
                if len(unit.lines) == 1 and len(unit.targets) == 1:
                    # The usual unit, one target on one line: its line's changes are all here.
                    lines.append((unit, 0, list(zip(targets[i].spans, new, strict=True))))
                    continue
                # A token put back as it was splices to the same text: all go in.
                for span, text in zip(targets[i].spans, new, strict=True):
                    key = (id(unit), span[0])
                    found = shared.get(key)
                    if found is None:
                        changes: list[tuple] = []
                        found = shared[key] = (unit, span[0], changes)
                        lines.append(found)
                    found[2].append((span, text))
        for unit, li, on_line in lines:
            unit.lines[li] = _splice(unit.lines[li], on_line)

    def _mark(self, unit: Unit, target: Target, reason: str) -> None:
        """Count a failure; with ``--keep-failed``, note it at the end of its line."""
        self.summary.fail(target, reason)
        if self.job.keep_failed and self.lang.comment is not None:
            body, ending = _split(unit.lines[target.mark_line])
            unit.lines[target.mark_line] = (
                f"{body} {self.lang.comment} not corrected: {reason}{ending}"
            )

    def _start(self, known_q: np.ndarray, first_pose: int) -> np.ndarray | None:
        before = np.flatnonzero(~np.isnan(known_q[:first_pose, 0]))
        return known_q[before[-1]] if len(before) else self.last_q

    def _compensate(self, items, rows, block, q_nom, bits, reasons, result_q, result_pose):
        """Calibrated solutions of ``rows``: where good, into ``result_q`` (model joints, rad)
        and ``result_pose`` (their nominal tool poses, the corrected targets, mm); else a reason.
        """
        job, cal = self.job, self.job.calibration
        pose = block.is_pose[rows]
        d = block.desired[rows]
        q0 = q_nom[rows]
        tool = block.tool[rows]
        # Joint rows: desired = the nominal pose of their joints (compensate computes it).
        if not pose.all():
            d[~pose] = kinematics.tool_poses(cal.nominal_mdh, q0[~pose], tool[~pose])
        comp = compensate.compensate(
            cal, d, q0, job.limits, job.payload_kg, tool=tool, nominal_solved=True
        )
        sol = comp.solution
        q_cal = comp.q
        move_mm = np.linalg.norm(comp.corrected[:, :3, 3] - d[:, :3, 3], axis=1)
        turn_deg = np.degrees(
            np.linalg.norm(
                rotations.rotation_error(comp.corrected[:, :3, :3], d[:, :3, :3]), axis=1
            )
        )
        jump = np.degrees(np.abs(q_cal - comp.q_nominal))
        # The configuration to keep: the one the target states, else its nominal solution's.
        keep = self.solver.code_of(comp.q_nominal, bits[rows])
        for j, i in enumerate(rows.tolist()):
            if pose[j] and items[i].code is not None:
                keep[j] = items[i].code
        code_cal = self.solver.code_of(q_cal)
        kept = np.all(code_cal == keep, axis=1)
        if not kept.all():  # within the boundary tolerance?
            kept[~kept] = self.solver.matches(q_cal[~kept], keep[~kept])
        if (~pose).any():
            # A joint target states joints, not configuration data: it only must not
            # flip the arm (shoulder, elbow, wrist); a joint crossing 0 deg is fine.
            mdh = cal.nominal_mdh
            same = np.all(
                configuration.arm_bits(mdh, q_cal[~pose]) == configuration.arm_bits(mdh, q0[~pose]),
                axis=1,
            )
            kept[~pose] = same
        limits = job.limits
        outside = ~sol.within_limits
        jumped = jump.max(axis=1) > compensate.MAX_JOINT_CHANGE_DEG
        too_big = (move_mm > job.max_mm) | (turn_deg > job.max_deg)
        bad = ~sol.converged | ~kept | outside | jumped | too_big
        near = dict.fromkeys(rows[bad].tolist(), "")
        if (bad & (~sol.converged | jumped)).any():
            pick = np.flatnonzero(bad & (~sol.converged | jumped))
            named = singularities.nearest(cal.nominal_mdh, q0[pick])
            near.update(zip(rows[pick].tolist(), named, strict=True))
        for j in np.flatnonzero(bad).tolist():
            i = int(rows[j])
            if not sol.converged[j]:
                where = f"; {near[i]}" if near[i] else ""
                reasons[i] = (
                    f"the calibrated arm cannot reach it ({sol.error_mm[j]:.3g} mm off{where})"
                )
            elif not kept[j]:
                reasons[i] = (
                    f"the configuration would change from {self.lang.describe(tuple(keep[j]))} "
                    f"to {self.lang.describe(tuple(code_cal[j]))}"
                )
            elif outside[j]:
                joints = [
                    k + 1 for k in range(6) if not limits[k, 0] <= q_cal[j, k] <= limits[k, 1]
                ]
                reasons[i] = f"outside the joint limits (joint {', '.join(map(str, joints))})"
            elif jumped[j]:
                k = int(np.argmax(jump[j]))
                where = f" ({near[i]})" if near[i] else ""
                reasons[i] = (
                    f"joint {k + 1} would turn {jump[j, k]:.2f} deg between the nominal and the "
                    f"calibrated solution{where}"
                )
            else:
                reasons[i] = (
                    f"correction {move_mm[j]:.3f} mm / {turn_deg[j]:.3f} deg exceeds "
                    f"--max-correction {job.max_mm:g},{job.max_deg:g} "
                    "(a wrong frame or calibration?)"
                )
        good = ~bad
        result_q[rows[good]] = q_cal[good]
        result_pose[rows[good]] = comp.corrected[good]
        if good.any():
            self.summary.max_mm = max(self.summary.max_mm, float(move_mm[good].max()))
            self.summary.max_deg = max(self.summary.max_deg, float(turn_deg[good].max()))
            self.summary.sum_mm += float(move_mm[good].sum())
            self.summary.sum_deg += float(turn_deg[good].sum())


@contextmanager
def _collector_paused() -> Iterator[None]:
    """Python's cycle collector off while a program streams through (as it was, after).

    A block keeps some 60,000 small containers (units, targets, their lists)
    alive until it is written; the collector's full passes over them and
    every other object cost 10-14 % of the filter's time (10^5 URScript
    targets, measured) and find nothing: the filter makes no reference
    cycles. Reference counting still frees each block once it is written.
    """
    was = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was:
            gc.enable()


class _Block:
    """A block's targets as arrays: numbers decoded per layout, frames stacked.

    Attributes
    ----------
    n : int
    groups : list of (Layout, ndarray of int, ndarray (M, m))
        Each layout, its rows and their numbers as read (every target of a
        layout has the same numbers).
    is_pose : ndarray of bool, shape (N,)
    pose_rows : ndarray of int
    joints : ndarray, shape (N, 6)
        Controller joints of the joint targets (NaN for poses), rad.
    tool, base : ndarray, shape (N, 4, 4)
        Each target's tool on the model's flange and base frame in the
        model's base frame (the controller's frames placed on the model), mm.
    desired : ndarray, shape (N, 4, 4)
        Tool poses of the pose targets in the model's base frame (NaN for joints), mm.
    """

    def __init__(self, targets: list, job: Job) -> None:
        n = self.n = len(targets)
        by_layout: dict = defaultdict(list)
        for i, t in enumerate(targets):
            by_layout[id(t.layout)].append(i)
        self.groups = []
        pose_in_frame = np.full((n, 4, 4), np.nan)
        self.joints = np.full((n, 6), np.nan)
        self.is_pose = np.zeros(n, dtype=bool)
        for members in by_layout.values():
            rows = np.array(members)
            layout = targets[members[0]].layout
            vals = np.array([targets[i].tokens for i in members], dtype=float)
            if layout.kind == "pose":
                pose_in_frame[rows] = layout.decode(vals)
                self.is_pose[rows] = True
            else:
                self.joints[rows] = layout.decode(vals)
            self.groups.append((layout, rows, vals))
        # The program's frames are the controller's: tool 0 is its flange and base 0 its
        # base (world) frame, placed on the model's flange and MDH frame 0.
        self.tool = np.asarray(job.controller_flange) @ _stack([t.tool for t in targets])
        self.base = np.asarray(job.controller_base) @ _stack([t.base for t in targets])
        self.pose_rows = np.flatnonzero(self.is_pose)
        self.desired = np.full((n, 4, 4), np.nan)
        rows = self.pose_rows
        if len(rows):
            self.desired[rows] = self.base[rows] @ pose_in_frame[rows]


def _stack(transforms: list) -> np.ndarray:
    """(N, 4, 4) of per-target transforms (None: identity); targets share a few objects."""
    index: dict = {}
    unique: list = []
    rows = []
    for t in transforms:
        k = index.get(id(t))
        if k is None:
            k = index[id(t)] = len(unique)
            unique.append(np.eye(4) if t is None else t)
        rows.append(k)
    return np.array(unique)[np.array(rows)]


def _splice(line: str, changes: list) -> str:
    """``line`` with each ``((line index, start, end), text)`` of ``changes`` put in.

    Spans index the original line: spliced in one pass, left to right.
    """
    changes.sort()
    parts: list[str] = []
    at = 0
    for (_, start, end), text in changes:
        parts += (line[at:start], text)
        at = end
    parts.append(line[at:])  # spans end before the line ending: it stays
    return "".join(parts)


def _split(line: str) -> tuple[str, str]:
    body = line.rstrip("\r\n")
    return body, line[len(body) :]


def write_summary(path: Path, summary: Summary, inputs: list) -> None:
    """The summary as JSON, written atomically."""
    outputs.write_text(path, json.dumps(summary.to_json(), indent=2) + "\n", inputs=inputs)
