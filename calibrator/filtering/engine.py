"""Streaming a program through its language, block by block, and the filter summary.

Targets are gathered until a block of :data:`BLOCK` is full; the block is
solved with one vectorised call per step (:mod:`calibrator.filtering.solve`,
:func:`calibrator.compensate.compensate`), its lines written out and
dropped. Memory is bounded by the block, whatever the program's length.

Per target: Cartesian targets are corrected (desired pose = its base frame @
its pose; the calibrated arm's joints in the stated configuration; the
nominal pose of those joints, written back in the same frame); joint targets
are kept, or with ``--joint-targets correct`` replaced by the joints that make
the calibrated arm reach the nominal pose of the original joints. A target
fails, named with its file and line, when no solution keeps its
configuration, the calibrated arm cannot reach it, its joints leave the
limits, a joint would turn more than
:data:`calibrator.compensate.MAX_JOINT_CHANGE_DEG` between the nominal and
the calibrated solution, or the correction exceeds ``--max-correction``.
"""

from __future__ import annotations

import json
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO

import numpy as np

from calibrator import compensate, frames, outputs
from calibrator.filtering import REGISTRY, Job, Target, Unit, configuration, convention, numbers
from calibrator.filtering.solve import Solver

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


class Filter:
    """One program through one language; :meth:`run` writes the outputs or none."""

    def __init__(self, fmt: str, job: Job, program: Path) -> None:
        job.convention = job.convention or convention.for_model(job.calibration.model)
        self.job = job
        self.lang = REGISTRY[fmt](job, program)
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
        with open(tmp, "w", encoding="latin-1", newline="") as out:
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
        for u in units:
            out.write("".join(u.lines))

    # -- solving -----------------------------------------------------------------------
    def _solve(self, items: list) -> None:
        job, lang = self.job, self.lang
        for u, t in items:
            if t.problem is not None:
                self.summary.found[t.layout.kind] += 1
                self._mark(u, t, t.problem)
        items = [(u, t) for u, t in items if t.problem is None]
        if not items:
            return
        conv = job.convention
        n = len(items)
        by_layout: dict = defaultdict(list)
        for i, (_, t) in enumerate(items):
            by_layout[id(t.layout)].append(i)
        decoded: list = [None] * n
        values: list = [None] * n
        for rows in by_layout.values():
            layout = items[rows[0]][1].layout
            vals = np.array([items[i][1].tokens for i in rows]).astype(float)
            dec = layout.decode(vals)
            for j, i in enumerate(rows):
                decoded[i], values[i] = dec[j], vals[j]
        tool = _stack([t.tool for _, t in items])
        base = _stack([t.base for _, t in items])
        is_pose = np.array([t.layout.kind == "pose" for _, t in items])
        for _, t in items:
            self.summary.found[t.layout.kind] += 1
        result_q = np.full((n, 6), np.nan)  # model joints of the corrected target
        new: list = [None] * n
        reasons: list = [None] * n
        # Joint targets: known joints (also the arm's position for the poses after them).
        known_q = np.full((n, 6), np.nan)
        for i in np.flatnonzero(~is_pose).tolist():
            known_q[i] = convention.to_model(decoded[i], conv)
        pose_rows = np.flatnonzero(is_pose)
        joint_rows = np.flatnonzero(~is_pose)
        q_nom = np.full((n, 6), np.nan)
        desired = np.full((n, 4, 4), np.nan)
        if len(pose_rows):
            desired[pose_rows] = base[pose_rows] @ np.array([decoded[i] for i in pose_rows])
            k = len(self.solver.code_of(np.zeros((1, 6)))[0])
            codes = np.zeros((n, k), dtype=int)
            stated = np.zeros(n, dtype=bool)
            for i in pose_rows.tolist():
                c = items[i][1].code
                if c is not None:
                    codes[i], stated[i] = c, True
            start = self._start(known_q, pose_rows[0])
            q, found = self.solver.solve(
                desired[pose_rows], tool[pose_rows], codes[pose_rows], stated[pose_rows], start
            )
            q_nom[pose_rows] = q
            for j, i in enumerate(pose_rows.tolist()):
                if not found[j]:
                    want = lang.describe(tuple(codes[i])) if stated[i] else "the previous target's"
                    reasons[i] = f"no nominal joint solution found in the configuration ({want})"
        if len(joint_rows):
            q_nom[joint_rows] = known_q[joint_rows]
        # Which rows go through the calibrated solver.
        active = np.zeros(n, dtype=bool)
        active[pose_rows] = ~np.isnan(q_nom[pose_rows, 0])
        if job.correct_joints:
            active[joint_rows] = True
        else:
            self.summary.kept["joints"] += len(joint_rows)
        rows = np.flatnonzero(active)
        if len(rows):
            self._compensate(items, rows, desired, tool, q_nom, is_pose, reasons, result_q)
        # Encode what changed, by layout.
        for lrows in by_layout.values():
            layout = items[lrows[0]][1].layout
            good = [i for i in lrows if active[i] and reasons[i] is None]
            if not good:
                continue
            old = np.array([values[i] for i in good])
            if layout.kind == "pose":
                corrected = frames.invert(base[good]) @ (
                    compensate.tool_poses(
                        self.job.calibration.nominal_mdh, result_q[good], tool[good]
                    )
                )
                enc = layout.encode(corrected, old)
            else:
                enc = layout.encode(convention.to_controller(result_q[good], conv), old)
            texts = numbers.write_many([items[i][1].tokens for i in good], old, enc, layout.units)
            for j, i in enumerate(good):
                new[i] = texts[j]
        # Rewrite tokens (right to left within a line so spans stay valid).
        edits: dict = defaultdict(list)
        for i, (u, t) in enumerate(items):
            if reasons[i] is not None:
                self._mark(u, t, reasons[i])
                continue
            if new[i] is None:
                continue
            self.summary.corrected[t.layout.kind] += 1
            for (li, s, e), tok, text in zip(t.spans, t.tokens, new[i], strict=True):
                if text != tok:
                    edits[(id(u), li)].append((s, e, text, u))
        for (_, li), changes in edits.items():
            unit = changes[0][3]
            body, ending = _split(unit.lines[li])
            marks = [c for c in changes if c[0] is None]
            for s, e, text, _ in sorted(
                (c for c in changes if c[0] is not None), key=lambda c: -c[0]
            ):
                body = body[:s] + text + body[e:]
            for _, _, text, _ in marks:
                body += text
            unit.lines[li] = body + ending
        last = np.flatnonzero(~np.isnan(result_q[:, 0]) | ~np.isnan(known_q[:, 0]))
        if len(last):
            i = last[-1]
            self.last_q = q_nom[i] if not np.isnan(q_nom[i, 0]) else known_q[i]

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

    def _compensate(self, items, rows, desired, tool, q_nom, is_pose, reasons, result_q):
        job, cal = self.job, self.job.calibration
        pose = is_pose[rows]
        d = desired[rows]
        q0 = q_nom[rows]
        # Joint rows: desired = the nominal pose of their joints (compensate computes it).
        d = np.where(pose[:, None, None], d, compensate.tool_poses(cal.nominal_mdh, q0, tool[rows]))
        comp = compensate.compensate(
            cal, d, q0, job.limits, job.payload_kg, tool=tool[rows], nominal_solved=True
        )
        sol = comp.solution
        q_cal = comp.q
        move_mm = np.linalg.norm(comp.corrected[:, :3, 3] - d[:, :3, 3], axis=1)
        turn_deg = np.degrees(
            np.linalg.norm(frames.rotation_error(comp.corrected[:, :3, :3], d[:, :3, :3]), axis=1)
        )
        jump = np.degrees(np.abs(q_cal - comp.q_nominal))
        # The configuration to keep: the one the target states, else its nominal solution's.
        keep = self.solver.code_of(comp.q_nominal)
        for j, i in enumerate(rows.tolist()):
            if pose[j] and items[i][1].code is not None:
                keep[j] = items[i][1].code
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
        singular = None
        for j, i in enumerate(rows):
            t = items[i][1]
            reason = None
            if not sol.converged[j]:
                singular = singular or dict(
                    zip(rows, configuration.nearest_singularity(cal.nominal_mdh, q0), strict=False)
                )
                near = f"; {singular[i]}" if singular[i] else ""
                reason = f"the calibrated arm cannot reach it ({sol.error_mm[j]:.3g} mm off{near})"
            elif not kept[j]:
                reason = (
                    f"the configuration would change from {self.lang.describe(tuple(keep[j]))} "
                    f"to {self.lang.describe(tuple(code_cal[j]))}"
                )
            elif not sol.within_limits[j]:
                lim = job.limits
                bad = [k + 1 for k in range(6) if not lim[k, 0] <= q_cal[j, k] <= lim[k, 1]]
                reason = f"outside the joint limits (joint {', '.join(map(str, bad))})"
            elif jump[j].max() > compensate.MAX_JOINT_CHANGE_DEG:
                k = int(np.argmax(jump[j]))
                singular = singular or dict(
                    zip(rows, configuration.nearest_singularity(cal.nominal_mdh, q0), strict=False)
                )
                near = f" ({singular[i]})" if singular[i] else ""
                reason = (
                    f"joint {k + 1} would turn {jump[j, k]:.2f} deg between the nominal and the "
                    f"calibrated solution{near}"
                )
            elif move_mm[j] > job.max_mm or turn_deg[j] > job.max_deg:
                reason = (
                    f"correction {move_mm[j]:.3f} mm / {turn_deg[j]:.3f} deg exceeds "
                    f"--max-correction {job.max_mm:g},{job.max_deg:g} "
                    "(a wrong frame or calibration?)"
                )
            if reason is not None:
                reasons[i] = reason
                continue
            result_q[i] = q_cal[j]
            self.summary.max_mm = max(self.summary.max_mm, float(move_mm[j]))
            self.summary.max_deg = max(self.summary.max_deg, float(turn_deg[j]))
            self.summary.sum_mm += float(move_mm[j])
            self.summary.sum_deg += float(turn_deg[j])
            del t


def _stack(transforms: list) -> np.ndarray:
    """(N, 4, 4) of per-target transforms (None: identity); targets share a few objects."""
    index: dict = {}
    rows = [index.setdefault(id(t), len(index)) for t in transforms]
    unique = {id(t): t for t in transforms}
    table = np.array([np.eye(4) if unique[k] is None else unique[k] for k in index])
    return table[np.array(rows)]


def _split(line: str) -> tuple[str, str]:
    body = line.rstrip("\r\n")
    return body, line[len(body) :]


def write_summary(path: Path, summary: Summary, inputs: list) -> None:
    """The summary as JSON, written atomically."""
    outputs.write_text(path, json.dumps(summary.to_json(), indent=2) + "\n", inputs=inputs)
