"""Joint solutions of a block of Cartesian targets, each in its stated configuration.

The accurate inverse kinematics (:func:`calibrator.model.inverse.solve`) is a
local solver: it needs a start in the right configuration. Starts come from,
in order of preference,

1. the solution of a neighbouring target of the program (programs move in
   small steps, so the neighbour's joints are a close start): every
   ``STRIDES[0]``-th target is an anchor, each finer level starts
   from the nearest solved target of the level above, and a target that still
   failed from the target before it;
2. a fixed library of the nominal arm's poses (:class:`Library`, drawn
   once per model with a fixed seed): the nearest flange poses of the
   configuration the target states.

A solution counts only in the configuration the target states, after its
joints 1, 4 and 6 are moved by whole turns where that makes it match (a
whole turn reaches the same pose). A target that states none (URScript,
KUKA ``FRAME`` targets) takes the configuration its neighbour had: the
controller picks the solution nearest the joints it comes from.
"""

from __future__ import annotations

import itertools

import numpy as np

from calibrator.languages import configuration, convention
from calibrator.languages.reading import Job, Language
from calibrator.model import frames, inverse, kinematics

#: Every STRIDES[0]-th target of a block is solved first (from the library or
#: the target before); each finer level starts from the nearest solved target
#: of the level above (16 times coarser), the last level is every target.
STRIDES = (256, 16)
#: Poses in the start library.
LIBRARY_SIZE = 20_000
#: A joint this close to a boundary of the configuration data counts on either side (deg).
BOUNDARY_DEG = 0.01
#: Library starts tried per target.
TRIES = 6
#: The arm's eight configurations (shoulder, elbow, wrist bits of :func:`configuration.arm_bits`).
_BITS = np.array([[a, b, c] for a in (0, 1) for b in (0, 1) for c in (0, 1)])
_LIBRARIES: dict = {}
_SHIFTS = np.array(list(itertools.product([0.0, 360.0, -360.0], repeat=3)))


def features(flange: np.ndarray) -> np.ndarray:
    """Flange poses (N, 4, 4) as points (N, 9) whose distances compare poses (mm)."""
    return np.concatenate(
        [flange[:, :3, 3], 500.0 * flange[:, :3, 0], 500.0 * flange[:, :3, 2]], axis=1
    )


class _FlangePoints:
    """:func:`features` of a block's flange poses, all computed on the first look-up.

    Most blocks never take a start from the library (their targets start
    from their neighbours): they never pay for these.
    """

    def __init__(self, desired: np.ndarray, tool: np.ndarray) -> None:
        self._desired, self._tool = desired, tool
        self._points: np.ndarray | None = None

    def __getitem__(self, rows: np.ndarray) -> np.ndarray:
        if self._points is None:
            self._points = features(self._desired @ frames.invert(self._tool))
        return self._points[rows]


class Library:
    """Nominal joint samples within the limits (joints 1, 4, 6 within one turn) and their poses."""

    def __init__(self, mdh: np.ndarray, limits: np.ndarray | None) -> None:
        rng = np.random.default_rng(20261127)
        lim = np.tile([-np.pi, np.pi], (6, 1)) if limits is None else np.asarray(limits, float)
        lo = np.maximum(lim[:, 0], -np.pi)
        hi = np.minimum(lim[:, 1], np.pi)
        self.q = rng.uniform(lo, hi, (LIBRARY_SIZE, 6))
        self.points = features(kinematics.chain(mdh, self.q))
        self.bits = configuration.arm_bits(mdh, self.q)
        self.sq = np.sum(self.points**2, axis=1)

    def nearest(self, points: np.ndarray, bits: np.ndarray | None, k: int) -> np.ndarray:
        """Indices (N, k) of the library poses nearest ``points`` (of the same bits if given)."""
        out = np.zeros((len(points), k), dtype=int)
        if bits is None:
            groups = [(np.arange(len(points)), np.arange(len(self.q)))]
        else:
            groups = []
            for key in {tuple(b) for b in bits}:
                rows = np.flatnonzero(np.all(bits == key, axis=1))
                members = np.flatnonzero(np.all(self.bits == key, axis=1))
                groups.append((rows, members if len(members) else np.arange(len(self.q))))
        for rows, members in groups:
            for chunk in np.array_split(rows, max(1, len(rows) // 512)):
                p = points[chunk]
                d = self.sq[members][None] - 2.0 * p @ self.points[members].T
                kk = min(k, len(members))
                part = np.argpartition(d, kk - 1, axis=1)[:, :kk]
                order = np.take_along_axis(d, part, axis=1).argsort(axis=1)
                out[chunk, :kk] = members[np.take_along_axis(part, order, axis=1)]
                out[chunk, kk:] = out[chunk, :1]
        return out


class Solver:
    """Nominal solutions of Cartesian targets in their configurations, for one language."""

    def __init__(self, lang: Language, job: Job) -> None:
        self.lang = lang
        self.job = job
        self.mdh = job.calibration.nominal_mdh
        self.conv = job.convention or convention.IDENTITY
        self._library: Library | None = None

    @property
    def library(self) -> Library:
        if self._library is None:
            lim = None if self.job.limits is None else np.asarray(self.job.limits, float)
            key = (self.mdh.tobytes(), None if lim is None else lim.tobytes())
            if key not in _LIBRARIES:
                _LIBRARIES.clear()  # one arm per run: keep one library
                _LIBRARIES[key] = Library(self.mdh, lim)
            self._library = _LIBRARIES[key]
        return self._library

    def code_of(self, q_model: np.ndarray, bits: np.ndarray | None = None) -> np.ndarray:
        """The configuration data (N, k) of model joints, as the language states it.

        ``bits`` (N, 3), optional: the joints' arm bits where already known
        (:meth:`solve`'s), NaN rows taken here.
        """
        q_deg = np.degrees(convention.to_controller(q_model, self.conv))
        if bits is None:
            return self.lang.code(q_deg, configuration.arm_bits(self.mdh, q_model))
        known = bits.copy()
        missing = np.isnan(known[:, 0])
        if missing.any():
            known[missing] = configuration.arm_bits(self.mdh, q_model[missing])
        return self.lang.code(q_deg, known.astype(int))

    def matches(self, q_model: np.ndarray, code: np.ndarray) -> np.ndarray:
        """Rows whose joints have the configuration ``code`` (N, k).

        A joint within :data:`BOUNDARY_DEG` of a boundary of the configuration
        data (0 deg for a turn bit, a quadrant's edge) counts on either side:
        a target taught at ``A6 = 0`` reads back a hair either side of it
        once its pose is printed with a few decimals.
        """
        q_deg = np.degrees(convention.to_controller(q_model, self.conv))
        bits = configuration.arm_bits(self.mdh, q_model)
        ok = np.all(self.lang.code(q_deg, bits) == code, axis=1)
        for j in range(6):
            for step in (BOUNDARY_DEG, -BOUNDARY_DEG):
                if ok.all():
                    return ok
                nudged = q_deg.copy()
                nudged[:, j] += step
                ok |= np.all(self.lang.code(nudged, bits) == code, axis=1)
        return ok

    def fit_turns(self, q_model: np.ndarray, code: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Joints 1, 4, 6 moved by whole turns to match ``code`` within the limits; which match."""
        q_ctrl = np.degrees(convention.to_controller(q_model, self.conv))
        # Start from joints 1, 4, 6 within [-180, 180): the solver may have left them a turn off.
        q_ctrl[:, [0, 3, 5]] = (q_ctrl[:, [0, 3, 5]] + 180.0) % 360.0 - 180.0
        lim = self.job.limits
        out = q_ctrl.copy()
        done = np.zeros(len(q_model), dtype=bool)
        for shift in _SHIFTS:
            trial = q_ctrl.copy()
            trial[:, [0, 3, 5]] += shift
            rows = np.flatnonzero(~done)
            if not len(rows):
                break
            q_try = convention.to_model(np.radians(trial[rows]), self.conv)
            hit = self.matches(q_try, code[rows])
            if lim is not None:
                hit &= np.all((q_try >= lim[:, 0]) & (q_try <= lim[:, 1]), axis=1)
            out[rows[hit]] = trial[rows[hit]]
            done[rows[hit]] = True
        return convention.to_model(np.radians(out), self.conv), done

    def _try(self, desired, tool, seeds, code, stated, ref_bits):
        """Solve from ``seeds``; keep a row only in its configuration.

        Returns ``(q, ok, bits)``: ``bits`` (N, 3) are the arm bits of the
        rows checked against ``ref_bits`` (NaN for the others).
        """
        sol = inverse.solve(self.mdh, desired, seeds, tool)
        # A joint the solver turned by whole turns reaches the same pose: take the
        # angle nearest the start (the arm comes from there, or the start is the library's).
        q = seeds + (sol.q - seeds + np.pi) % (2 * np.pi) - np.pi
        ok = sol.converged.copy()
        if stated.any():
            fitted, match = self.fit_turns(q[stated], code[stated])
            q[stated] = fitted
            ok[stated] &= match
        free = ~stated & ~np.isnan(ref_bits[:, 0])
        bits = np.full((len(q), 3), np.nan)
        if free.any():
            bits[free] = configuration.arm_bits(self.mdh, q[free])
            ok[free] &= np.all(bits[free] == ref_bits[free], axis=1)
        return q, ok, bits

    def solve(
        self,
        desired: np.ndarray,
        tool: np.ndarray,
        code: np.ndarray,
        stated: np.ndarray,
        start_q: np.ndarray | None,
        comes_from: np.ndarray | None = None,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Nominal joints of a block of targets.

        Parameters
        ----------
        desired : ndarray, shape (N, 4, 4)
            Tool poses in the robot base frame (mm).
        tool : ndarray, shape (N, 4, 4)
        code : ndarray of int, shape (N, k)
            Stated configurations (rows where ``stated`` is False are ignored).
        stated : ndarray of bool, shape (N,)
        start_q : ndarray, shape (6,), or None
            Model joints the arm comes from (the previous target), rad.
        comes_from : ndarray, shape (N, 6), optional
            Per target, the model joints of the joint target right before it
            (rad; NaN rows: a Cartesian target is before it). A target that
            states no configuration takes that joint target's and is solved
            from there first (the controller solves it nearest those joints).

        Returns
        -------
        q : ndarray, shape (N, 6)
            Model joints (rad); NaN where none was found.
        found : ndarray of bool, shape (N,)
        bits : ndarray, shape (N, 3)
            :func:`configuration.arm_bits` of the solutions whose bits were
            taken while solving (as floats; NaN for the others).
        """
        n = len(desired)
        q = np.full((n, 6), np.nan)
        found = np.zeros(n, dtype=bool)
        bits = np.full((n, 3), np.nan)
        lib_points = _FlangePoints(desired, tool)
        anchors = np.arange(0, n, STRIDES[0])
        nan_bits = np.full((n, 3), np.nan)
        # Anchors that state their configuration: library starts.
        a_st = anchors[stated[anchors]]
        if len(a_st):
            self._from_library(a_st, desired, tool, code, stated, nan_bits, lib_points, q, found)
        if comes_from is not None:
            # Targets right after joint targets: from those joints, in their configuration.
            seeded = np.flatnonzero(~np.isnan(comes_from[:, 0]) & ~stated)
            if len(seeded):
                seeds = comes_from[seeded]
                ref = configuration.arm_bits(self.mdh, seeds).astype(float)
                qa, ok, _ = self._try(
                    desired[seeded], tool[seeded], seeds, code[seeded], stated[seeded], ref
                )
                q[seeded[ok]], found[seeded[ok]] = qa[ok], True
        # Anchors that state none: each from the one before (the arm comes from there).
        prev = None if start_q is None else np.asarray(start_q, float)
        for a in anchors[~stated[anchors]]:
            if found[a]:
                prev = q[a]
                continue
            sl = slice(a, a + 1)
            if prev is not None:
                qa, ok, _ = self._try(
                    desired[sl], tool[sl], prev[None], code[sl], stated[sl], nan_bits[sl]
                )
                if ok[0]:
                    q[a], found[a] = qa[0], True
            if not found[a]:
                self._nearest(np.array([a]), desired, tool, prev, lib_points, q, found)
            if found[a]:
                prev = q[a]
        # Each finer level from the nearest solved target of the level above, then
        # whatever failed from the target before it.
        done_levels = anchors
        for stride in STRIDES[1:] + (1,):
            level = np.setdiff1d(np.arange(0, n, stride), done_levels)
            self._from_neighbours(level, (level // (stride * 16)) * (stride * 16), desired, tool,
                                  code, stated, q, found, bits)  # fmt: skip
            done_levels = np.union1d(done_levels, level)
        for _ in range(3):
            rest = np.flatnonzero(~found)
            rest = rest[rest > 0]
            if not len(rest):
                break
            self._from_neighbours(rest, rest - 1, desired, tool, code, stated, q, found, bits)
        # Whatever is left: library starts (in the stated configuration, or the
        # solution nearest the joints of the target before).
        left = np.flatnonzero(~found & stated)
        if len(left):
            self._from_library(left, desired, tool, code, stated, nan_bits, lib_points, q, found)
        for i in np.flatnonzero(~found & ~stated):
            before = q[i - 1] if i > 0 and found[i - 1] else (prev if i == 0 else None)
            self._nearest(np.array([i]), desired, tool, before, lib_points, q, found)
        return q, found, bits

    def _from_neighbours(self, rows, src, desired, tool, code, stated, q, found, bits):
        """Solve ``rows`` from the solutions of ``src`` (where found), in place (``bits`` too)."""
        todo = ~found[rows]
        rows, src = rows[todo], src[todo]
        have = found[src]
        rows, src = rows[have], src[have]
        if not len(rows):
            return
        # Many rows start from one source (16 from each of the level above): bits once each.
        sources, back = np.unique(src, return_inverse=True)
        ref = configuration.arm_bits(self.mdh, q[sources]).astype(float)[back]
        qa, ok, got = self._try(desired[rows], tool[rows], q[src], code[rows], stated[rows], ref)
        q[rows[ok]], found[rows[ok]], bits[rows[ok]] = qa[ok], True, got[ok]

    def _nearest(self, rows, desired, tool, ref_q, lib_points, q, found):
        """Of the solutions from library starts, the one nearest ``ref_q`` (any configuration)."""
        lib = self.library
        if ref_q is None:
            picks = lib.nearest(lib_points[rows], None, TRIES)
        else:
            # The controller takes the solution nearest the joints it comes from,
            # whichever configuration that is: start in each of the eight, or the
            # nearest starts (all of one configuration, often) can miss it.
            picks = np.hstack(
                [lib.nearest(lib_points[rows], np.tile(b, (len(rows), 1)), TRIES) for b in _BITS]
            )
        k = picks.shape[1]
        r = np.repeat(rows, k)
        sol = inverse.solve(self.mdh, desired[r], lib.q[picks.ravel()], tool[r])
        for j, row in enumerate(rows):
            cand = sol.q[j * k : (j + 1) * k][sol.converged[j * k : (j + 1) * k]]
            if not len(cand):
                continue
            if ref_q is not None:
                # Joints may differ by whole turns: compare each joint modulo one turn.
                gap = (cand - ref_q + np.pi) % (2 * np.pi) - np.pi
                best = cand[np.argmin(np.max(np.abs(gap), axis=1))]
                best = ref_q + (best - ref_q + np.pi) % (2 * np.pi) - np.pi
            else:
                best = cand[0]
            q[row], found[row] = best, True

    def _from_library(self, rows, desired, tool, code, stated, ref_bits, lib_points, q, found):
        lib = self.library
        want = self.lang.code_bits(code[rows]) if stated[rows].all() else None
        picks = lib.nearest(lib_points[rows], want, TRIES)
        ref = np.full((len(rows), 3), np.nan) if ref_bits is None else ref_bits[rows]
        for j in range(TRIES):
            todo = ~found[rows]
            if not todo.any():
                break
            r = rows[todo]
            qa, ok, _ = self._try(
                desired[r], tool[r], lib.q[picks[todo, j]], code[r], stated[r], ref[todo]
            )
            q[r[ok]], found[r[ok]] = qa[ok], True
