"""Orientation notations of robot programs, vectorised over targets.

- ZYX Euler angles (KUKA's A, B, C; Fanuc's W, P, R and Yaskawa's Rx, Ry, Rz
  are the same rotation written in another order): ``R = Rz(a) Ry(b) Rx(c)``,
  A about Z, then B about the new Y, then C about the new X (equivalently C
  about the fixed X, B about the fixed Y, A about the fixed Z).
- Quaternions ``[w, x, y, z]`` (ABB's ``[q1, q2, q3, q4]``).

Writing an orientation back picks, of the notation's equivalent forms, the
one closest to what the program had, so that a corrected target keeps the
look (signs, branches) of the original.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike


def zyx_to_matrix(abc_deg: ArrayLike) -> np.ndarray:
    """``Rz(a) Ry(b) Rx(c)`` for angles (N, 3) in degrees -> (N, 3, 3)."""
    a, b, c = np.radians(np.asarray(abc_deg, dtype=float)).T
    ca, sa, cb, sb, cc, sc = np.cos(a), np.sin(a), np.cos(b), np.sin(b), np.cos(c), np.sin(c)
    out = np.empty((len(a), 3, 3))
    out[:, 0, 0] = ca * cb
    out[:, 0, 1] = ca * sb * sc - sa * cc
    out[:, 0, 2] = ca * sb * cc + sa * sc
    out[:, 1, 0] = sa * cb
    out[:, 1, 1] = sa * sb * sc + ca * cc
    out[:, 1, 2] = sa * sb * cc - ca * sc
    out[:, 2, 0] = -sb
    out[:, 2, 1] = cb * sc
    out[:, 2, 2] = cb * cc
    return out


def _wrap_near(angle, near):
    return near + (angle - near + 180.0) % 360.0 - 180.0


def matrix_to_zyx(rotation: ArrayLike, near_deg: ArrayLike) -> np.ndarray:
    """ZYX angles (N, 3) deg of rotations (N, 3, 3), the form closest to ``near_deg``.

    Of the two solutions ``(a, b, c)`` and ``(a + 180, 180 - b, c + 180)``,
    each angle wrapped to within 180 deg of ``near_deg``, the one with the
    smaller largest change is returned.
    """
    r = np.asarray(rotation, dtype=float)
    near = np.asarray(near_deg, dtype=float)
    b = np.degrees(np.arctan2(-r[:, 2, 0], np.hypot(r[:, 0, 0], r[:, 1, 0])))
    a = np.degrees(np.arctan2(r[:, 1, 0], r[:, 0, 0]))
    c = np.degrees(np.arctan2(r[:, 2, 1], r[:, 2, 2]))
    first = np.column_stack([a, b, c])
    second = np.column_stack([a + 180.0, 180.0 - b, c + 180.0])
    first = _wrap_near(first, near)
    second = _wrap_near(second, near)
    pick = np.max(np.abs(second - near), axis=1) < np.max(np.abs(first - near), axis=1)
    return np.where(pick[:, None], second, first)


def quaternion_to_matrix(wxyz: ArrayLike) -> np.ndarray:
    """Rotations (N, 3, 3) of quaternions (N, 4) ``[w, x, y, z]`` (normalised first)."""
    q = np.asarray(wxyz, dtype=float)
    q = q / np.linalg.norm(q, axis=1, keepdims=True)
    w, x, y, z = q.T
    out = np.empty((len(q), 3, 3))
    out[:, 0] = np.column_stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)])
    out[:, 1] = np.column_stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)])
    out[:, 2] = np.column_stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)])
    return out


def matrix_to_quaternion(rotation: ArrayLike, near: ArrayLike) -> np.ndarray:
    """Unit quaternions (N, 4) ``[w, x, y, z]`` of rotations, signed like ``near``."""
    r = np.asarray(rotation, dtype=float)
    trace = np.trace(r, axis1=1, axis2=2)
    cand = np.stack(
        [
            np.column_stack(
                [
                    1 + trace,
                    r[:, 2, 1] - r[:, 1, 2],
                    r[:, 0, 2] - r[:, 2, 0],
                    r[:, 1, 0] - r[:, 0, 1],
                ]
            ),
            np.column_stack(
                [
                    r[:, 2, 1] - r[:, 1, 2],
                    1 + r[:, 0, 0] - r[:, 1, 1] - r[:, 2, 2],
                    r[:, 0, 1] + r[:, 1, 0],
                    r[:, 0, 2] + r[:, 2, 0],
                ]
            ),
            np.column_stack(
                [
                    r[:, 0, 2] - r[:, 2, 0],
                    r[:, 0, 1] + r[:, 1, 0],
                    1 - r[:, 0, 0] + r[:, 1, 1] - r[:, 2, 2],
                    r[:, 1, 2] + r[:, 2, 1],
                ]
            ),
            np.column_stack(
                [
                    r[:, 1, 0] - r[:, 0, 1],
                    r[:, 0, 2] + r[:, 2, 0],
                    r[:, 1, 2] + r[:, 2, 1],
                    1 - r[:, 0, 0] - r[:, 1, 1] + r[:, 2, 2],
                ]
            ),
        ],
        axis=1,
    )  # (N, 4 candidates, 4): row k is 4 q_k * q, best conditioned for the largest q_k
    diag = np.column_stack([trace, r[:, 0, 0], r[:, 1, 1], r[:, 2, 2]])
    best = cand[np.arange(len(r)), np.argmax(diag, axis=1)]
    q = best / np.linalg.norm(best, axis=1, keepdims=True)
    sign = np.where(np.einsum("ij,ij->i", q, np.asarray(near, dtype=float)) < 0, -1.0, 1.0)
    return q * sign[:, None]
