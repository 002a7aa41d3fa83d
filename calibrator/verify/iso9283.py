"""ISO 9283 pose test: the test cube, its five test poses and the pose figures.

ISO 9283 (manipulating industrial robots, performance criteria and test
methods) measures pose accuracy and repeatability at five test poses on a
diagonal plane of a cube in the working space:

- the cube has its edges parallel to the robot base frame and is the largest
  one that fits where the arm works (:func:`largest_cube`);
- P1 is the centre of the cube; P2 to P5 lie on the two diagonals of the plane
  at 10 % of the diagonal's length from its corners (:func:`test_positions`);
- every cycle visits P5, P4, P3, P2, P1 (:data:`CYCLE_ORDER`), so each pose is
  always approached from the same direction;
- per test pose, from the ``n`` attained positions ``x_j`` and the commanded
  position ``x_c``, :func:`position_figures` gives

  * ``APx = xbar - x_c`` (and y, z), ``AP = sqrt(APx^2 + APy^2 + APz^2)``;
  * ``l_j = |x_j - xbar|``, ``RP = lbar + 3 S_l`` with ``S_l`` the sample
    standard deviation (``n - 1``) of the ``l_j``;

  and, with orientations, :func:`orientation_figures` gives ``APa = abar - a_c``
  and ``RPa = 3 S_a`` (and b, c).

Everything is vectorised over test poses; units are mm and rad inside.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from calibrator.errors import CalibrationError
from calibrator.model import frames, inverse

#: Visiting order of one cycle (test pose numbers), as the standard gives it.
CYCLE_ORDER = (5, 4, 3, 2, 1)
#: Distance of P2..P5 from their corners, as a fraction of the plane's diagonal.
CORNER_FRACTION = 0.1
#: Corners of the diagonal plane near P2, P3, P4, P5, in half sides from the centre.
#: The plane holds the lower edge along x at -y and the upper edge along x at +y.
PLANE_CORNERS = np.array([[1.0, 1.0, 1.0], [-1.0, 1.0, 1.0], [-1.0, -1.0, -1.0], [1.0, -1.0, -1.0]])
#: Constant tool orientation of the test (tool z pointing down, x along base x).
TOOL_DOWN = np.diag([1.0, -1.0, -1.0])
#: Joint space margin kept from every joint limit by :func:`largest_cube`, rad.
LIMIT_MARGIN_RAD = np.deg2rad(5.0)
#: Largest joint change allowed between the cube's centre and any point of the
#: cube: beyond it the arm would change its configuration (elbow, wrist), rad.
MAX_JOINT_CHANGE_RAD = np.deg2rad(90.0)
#: Smallest singular value of the position Jacobian allowed in the cube, mm/rad:
#: keeps every test pose away from the arm's singularities.
MIN_SINGULAR_MM = 50.0


class Iso9283Error(CalibrationError):
    """A test cube that cannot be placed, or clouds that cannot give the figures."""


@dataclass(frozen=True)
class Admissible:
    """What the cell allows, as two vectorised predicates (no hardware, no geometry here).

    Attributes
    ----------
    poses : callable
        ``poses(q)`` with ``q`` shape (N, 6), rad, returns bool (N,): True
        where the arm may stand (clear of the plane, itself and the cell, the
        reflector seen by the tracker).
    moves : callable
        ``moves(qa, qb)`` with shapes (M, 6), rad, returns bool (M,): True
        where the joint-space line ``qa -> qb`` stays clear all along.
    """

    poses: Callable[[np.ndarray], np.ndarray]
    moves: Callable[[np.ndarray, np.ndarray], np.ndarray]


def _cycle_moves(q_test: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Start and end of every move of a cycle, closing P1 -> P5, shapes (..., 5, 6)."""
    order = np.array(CYCLE_ORDER) - 1
    path = q_test[..., order, :]
    return path, np.roll(path, -1, axis=-2)


@dataclass(frozen=True)
class Cube:
    """A test cube, edges parallel to the robot base frame.

    Attributes
    ----------
    centre_mm : ndarray, shape (3,)
        Centre, robot base frame, mm.
    side_mm : float
        Edge length, mm.
    """

    centre_mm: np.ndarray
    side_mm: float

    def to_json(self) -> dict:
        return {"centre_mm": [float(v) for v in self.centre_mm], "side_mm": float(self.side_mm)}


def test_positions(centre_mm: npt.ArrayLike, side_mm: float) -> np.ndarray:
    """Positions of the test poses P1..P5 in a cube.

    Parameters
    ----------
    centre_mm : array_like, shape (3,)
        Cube centre, robot base frame, mm.
    side_mm : float
        Edge length, mm.

    Returns
    -------
    ndarray, shape (5, 3)
        Row ``k`` is test pose ``P(k+1)``, base frame, mm. P1 is the centre;
        P2..P5 sit on the plane's diagonals at ``CORNER_FRACTION`` of the
        diagonal's length (``side * sqrt(3)``) from the corners of
        :data:`PLANE_CORNERS`.
    """
    centre = np.asarray(centre_mm, dtype=float).reshape(3)
    half = 0.5 * float(side_mm)
    # A corner is half a diagonal from the centre; 10 % of the whole diagonal
    # from the corner leaves 1 - 2 * 0.1 of the centre-to-corner vector.
    corners = centre + half * PLANE_CORNERS
    inner = centre + (1.0 - 2.0 * CORNER_FRACTION) * (corners - centre)
    return np.vstack([centre, inner])


def facing(from_mm: npt.ArrayLike, tracker_mm: npt.ArrayLike) -> np.ndarray:
    """A constant tool orientation whose z axis points from ``from_mm`` at the tracker.

    A reflector accepts the beam within a cone about its axis (the tool z
    axis), so the test poses face the tracker. x is kept horizontal where it
    can be (the tool's "up" stays up).

    Parameters
    ----------
    from_mm, tracker_mm : array_like, shape (3,)
        A point of the test region and the tracker, base frame, mm.

    Returns
    -------
    ndarray, shape (3, 3)
        Rotation of the tool frame in the base frame.
    """
    z = np.asarray(tracker_mm, float) - np.asarray(from_mm, float)
    z = z / np.linalg.norm(z)
    x = np.cross([0.0, 0.0, 1.0], z)
    if np.linalg.norm(x) < 1e-9:  # tracker straight above: any horizontal x
        x = np.array([1.0, 0.0, 0.0])
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z])


def test_poses(
    centre_mm: npt.ArrayLike, side_mm: float, rotation: npt.ArrayLike = TOOL_DOWN
) -> np.ndarray:
    """Tool poses P1..P5 with one constant orientation, shape (5, 4, 4), base frame, mm."""
    return frames.transform(np.asarray(rotation, float), test_positions(centre_mm, side_mm))


def position_figures(
    attained_mm: npt.ArrayLike, commanded_mm: npt.ArrayLike
) -> dict[str, np.ndarray]:
    """Pose accuracy and repeatability of positions, per test pose.

    Parameters
    ----------
    attained_mm : array_like, shape (P, n, 3)
        ``n`` attained positions of each of ``P`` test poses (mm), n >= 2.
    commanded_mm : array_like, shape (P, 3)
        Commanded positions, same frame (mm).

    Returns
    -------
    dict of ndarray, each shape (P,)
        ``AP_mm``, ``APx_mm``, ``APy_mm``, ``APz_mm``, ``RP_mm``.
    """
    d = _deviations(attained_mm, commanded_mm, "positions")
    ap = d.mean(axis=1)  # barycentre - commanded
    dist = np.linalg.norm(d - ap[:, None, :], axis=2)  # from the barycentre
    rp = dist.mean(axis=1) + 3.0 * dist.std(axis=1, ddof=1)
    return {
        "AP_mm": np.linalg.norm(ap, axis=1),
        "APx_mm": ap[:, 0],
        "APy_mm": ap[:, 1],
        "APz_mm": ap[:, 2],
        "RP_mm": rp,
    }


def orientation_figures(
    attained_rad: npt.ArrayLike, commanded_rad: npt.ArrayLike
) -> dict[str, np.ndarray]:
    """Orientation accuracy and repeatability, per test pose.

    Parameters
    ----------
    attained_rad : array_like, shape (P, n, 3)
        Attained orientation angles ``(a, b, c)`` about x, y, z
        (:func:`calibrator.model.rotations.angles_xyz`), rad.
    commanded_rad : array_like, shape (P, 3)
        Commanded angles, rad.

    Returns
    -------
    dict of ndarray, each shape (P,)
        ``APa_deg``, ``APb_deg``, ``APc_deg`` (``mean(a_j) - a_c``) and
        ``RPa_deg``, ``RPb_deg``, ``RPc_deg`` (``3 S_a``, the half width of
        the standard's ``+-3 S_a``), degrees. Differences are taken wrapped
        to (-180, 180] degrees so that a pose near +-180 degrees is not torn.
    """
    d = _deviations(attained_rad, commanded_rad, "orientations", wrap=True)
    ap = np.rad2deg(d.mean(axis=1))
    rp = np.rad2deg(3.0 * d.std(axis=1, ddof=1))
    return {
        f"{fig}{name}_deg": v[:, k]
        for fig, v in (("AP", ap), ("RP", rp))
        for k, name in enumerate("abc")
    }


def _deviations(
    attained: npt.ArrayLike, commanded: npt.ArrayLike, what: str, wrap: bool = False
) -> np.ndarray:
    """Attained minus commanded per test pose, shape (P, n, 3).

    ``attained`` has shape (P, n >= 2, 3), ``commanded`` (P, 3), same unit and
    frame; other shapes raise :class:`Iso9283Error` naming ``what``. ``wrap``:
    angles in rad, the differences wrapped to (-pi, pi].
    """
    x = np.asarray(attained, dtype=float)
    c = np.asarray(commanded, dtype=float)
    if x.ndim != 3 or x.shape[-1] != 3 or x.shape[1] < 2 or c.shape != (x.shape[0], 3):
        raise Iso9283Error(
            f"attained and commanded {what} need shapes (P, n >= 2, 3) and (P, 3), "
            f"got {x.shape} and {c.shape}"
        )
    d = x - c[:, None, :]
    return np.angle(np.exp(1j * d)) if wrap else d


# ---------------------------------------------------------------- the cube


def solve_poses(
    mdh: npt.ArrayLike,
    targets: npt.ArrayLike,
    flange2tool: npt.ArrayLike,
    limits_rad: npt.ArrayLike,
    q_start: npt.ArrayLike,
) -> inverse.Solution:
    """Nominal inverse kinematics of tool poses from one start, with the cube's checks.

    Parameters
    ----------
    mdh : array_like, shape (6, 5)
    targets : array_like, shape (N, 4, 4)
        Tool poses, base frame, mm.
    flange2tool : array_like, shape (4, 4)
    limits_rad : array_like, shape (6, 2)
    q_start : array_like, shape (6,) or (N, 6)
        Start of the solver, rad.

    Returns
    -------
    inverse.Solution
        ``ok`` is True where the pose is reached within the joint limits.
    """
    targets = np.asarray(targets, dtype=float)
    start = np.broadcast_to(np.asarray(q_start, float), (len(targets), 6)).copy()
    return inverse.solve(mdh, targets, start, flange2tool, limits_rad)


def _regular(mdh, flange2tool, q, q_centre, limits, cell: Admissible | None = None) -> np.ndarray:
    """Poses inside the margins: limits, same configuration as the centre, no singularity,
    and (with ``cell``) poses the cell allows."""
    lim = np.asarray(limits, float)
    inside = np.all(
        (q >= lim[:, 0] + LIMIT_MARGIN_RAD) & (q <= lim[:, 1] - LIMIT_MARGIN_RAD), axis=-1
    )
    same = np.all(np.abs(q - q_centre) < MAX_JOINT_CHANGE_RAD, axis=-1)
    jac, _ = inverse.jacobian(mdh, q.reshape(-1, 6), flange2tool)
    smallest = np.linalg.svd(jac[:, :3, :3], compute_uv=False)[:, -1].reshape(q.shape[:-1])
    ok = inside & same & (smallest > MIN_SINGULAR_MM)
    if cell is not None:
        # NaN joints (no solution) are already refused; the cell sees finite ones only.
        flat = np.nan_to_num(q.reshape(-1, 6))
        ok &= np.asarray(cell.poses(flat), bool).reshape(q.shape[:-1])
    return ok


def _reach_mm(mdh) -> float:
    table = np.asarray(mdh, float)
    return float(np.abs(table[:, 0]).sum() + np.abs(table[:, 3]).sum())


def _centre_solutions(mdh, flange2tool, limits, centres, rotation, rng, cell=None):
    """A joint solution per candidate centre (or NaN): best-conditioned of many starts.

    With ``cell`` only solutions the cell allows compete: the elbow-down or
    wrist-flipped branches of the same tool pose drop out here, so every pose
    solved from this centre stays on the allowed branch.
    """
    lim = np.asarray(limits, float)
    starts = rng.uniform(lim[:, 0] * 0.5, lim[:, 1] * 0.5, size=(48, 6))
    m, s = len(centres), len(starts)
    targets = np.repeat(frames.transform(rotation, centres), s, axis=0)
    sol = solve_poses(mdh, targets, flange2tool, lim, np.tile(starts, (m, 1)))
    q = sol.q.reshape(m, s, 6)
    good = sol.ok.reshape(m, s) & _regular(mdh, flange2tool, q, q, lim, cell)
    jac, _ = inverse.jacobian(mdh, sol.q, flange2tool)
    score = np.linalg.svd(jac[:, :3, :3], compute_uv=False)[:, -1].reshape(m, s)
    score = np.where(good, score, -np.inf)
    best = np.argmax(score, axis=1)
    out = q[np.arange(m), best]
    out[~np.isfinite(score[np.arange(m), best])] = np.nan
    return out


def _fits(mdh, flange2tool, limits, centres, sides, q_centres, rotation, cell=None) -> np.ndarray:
    """Whether each cube (centre, side) is inside the regular working space, shape (M,).

    With ``cell`` the 27 points must be allowed poses and the test poses'
    cycle (P5 .. P1 and back to P5) allowed moves.
    """
    grid = np.stack(np.meshgrid(*[np.array([-0.5, 0.0, 0.5])] * 3, indexing="ij"), -1)
    grid = grid.reshape(-1, 3)  # 27 points: corners, edge middles, face centres, centre
    m, g = len(centres), len(grid)
    points = centres[:, None, :] + sides[:, None, None] * grid[None]
    targets = frames.transform(rotation, points.reshape(-1, 3))
    start = np.repeat(np.nan_to_num(q_centres), g, axis=0)
    sol = solve_poses(mdh, targets, flange2tool, limits, start)
    q = sol.q.reshape(m, g, 6)
    ok = sol.ok.reshape(m, g) & _regular(mdh, flange2tool, q, q_centres[:, None, :], limits, cell)
    fit = ok.all(axis=1) & np.isfinite(q_centres).all(axis=1)
    if cell is not None and fit.any():
        # The commanded joints of the fitting cubes, solved as commanded_joints does.
        idx = np.flatnonzero(fit)
        poses = np.concatenate([test_poses(centres[i], sides[i], rotation) for i in idx])
        tp = solve_poses(mdh, poses, flange2tool, limits, np.repeat(q_centres[idx], 5, axis=0))
        q_test = tp.q.reshape(len(idx), 5, 6)
        good = tp.ok.reshape(len(idx), 5).all(axis=1) & np.isfinite(q_test).all(axis=(1, 2))
        qa, qb = _cycle_moves(np.nan_to_num(q_test))
        clear = np.asarray(cell.moves(qa.reshape(-1, 6), qb.reshape(-1, 6)), bool)
        fit[idx] = good & clear.reshape(len(idx), 5).all(axis=1)
    return fit


def largest_cube(
    mdh: npt.ArrayLike,
    limits_rad: npt.ArrayLike,
    flange2tool: npt.ArrayLike,
    rotation: npt.ArrayLike = TOOL_DOWN,
    min_z_mm: float | None = None,
    cell: Admissible | None = None,
) -> Cube:
    """The largest test cube in the arm's working space with a constant tool orientation.

    The working space here is where the tool reaches ``rotation`` within the
    joint limits (minus :data:`LIMIT_MARGIN_RAD`), without changing its
    configuration from the cube's centre (no joint turns more than
    :data:`MAX_JOINT_CHANGE_RAD`) and away from singularities (position
    Jacobian's smallest singular value above :data:`MIN_SINGULAR_MM`), at
    27 points of the cube (corners, edge middles, face centres, centre).
    Centres are tried on a grid in the base's x-z half plane in front of the
    arm (the region a cell uses); each gets the largest side that fits
    (bisection to 1 mm); the largest cube wins. Deterministic.

    Parameters
    ----------
    mdh : array_like, shape (6, 5)
        Nominal MDH table (the controller's model), mm and rad.
    limits_rad : array_like, shape (6, 2)
    flange2tool : array_like, shape (4, 4)
        Nominal tool (TCP) on the flange, mm.
    rotation : array_like, shape (3, 3)
        Tool orientation in the base frame.
    min_z_mm : float, optional
        Lowest z the cube may reach, base frame, mm: the working space ends
        above the mounting plane (a quick bound; ``cell`` has the last word).
    cell : Admissible, optional
        What the cell allows: the working space is then also where the arm
        may stand (every one of the 27 points, on the centre's joint
        solution branch) and the cycle's moves between the test poses stay
        clear. Without it the cube ignores the arm's surroundings.

    Returns
    -------
    Cube

    Raises
    ------
    Iso9283Error
        No cube of at least 10 mm fits.
    """
    rng = np.random.default_rng(9283)  # fixed: the cube is a property of the arm
    reach = _reach_mm(mdh)
    xs = np.linspace(0.25, 0.65, 5) * reach
    zs = np.linspace(-0.1, 0.5, 5) * reach
    centres = np.array([[x, 0.0, z] for x in xs for z in zs])
    rotation = np.asarray(rotation, float)
    q_centres = _centre_solutions(mdh, flange2tool, limits_rad, centres, rotation, rng, cell)
    lo, hi = np.zeros(len(centres)), np.full(len(centres), reach)
    if min_z_mm is not None:  # the cube's floor stays above min_z_mm
        hi = np.clip(2.0 * (centres[:, 2] - min_z_mm), 0.0, hi)
    while np.max(hi - lo) > 1.0:
        mid = 0.5 * (lo + hi)
        fit = _fits(mdh, flange2tool, limits_rad, centres, mid, q_centres, rotation, cell)
        lo, hi = np.where(fit, mid, lo), np.where(fit, hi, mid)
    best = int(np.argmax(lo))
    if lo[best] < 10.0:
        raise Iso9283Error("no test cube of at least 10 mm fits the working space")
    return Cube(centres[best], float(np.floor(lo[best])))


def cube_fits(
    mdh: npt.ArrayLike,
    limits_rad: npt.ArrayLike,
    flange2tool: npt.ArrayLike,
    cube: Cube,
    rotation: npt.ArrayLike = TOOL_DOWN,
    cell: Admissible | None = None,
) -> bool:
    """Whether ``cube`` lies in the regular working space (the test :func:`largest_cube` uses)."""
    rng = np.random.default_rng(9283)
    centre = np.asarray(cube.centre_mm, float)[None]
    rotation = np.asarray(rotation, float)
    q_centre = _centre_solutions(mdh, flange2tool, limits_rad, centre, rotation, rng, cell)
    side = np.array([float(cube.side_mm)])
    return bool(_fits(mdh, flange2tool, limits_rad, centre, side, q_centre, rotation, cell)[0])


def check_cube(
    mdh: npt.ArrayLike,
    limits_rad: npt.ArrayLike,
    flange2tool: npt.ArrayLike,
    cube: Cube,
    rotation: npt.ArrayLike = TOOL_DOWN,
    cell: Admissible | None = None,
) -> None:
    """Refuse a given cube whose test poses the arm cannot reach regularly.

    With ``cell``, also a cube whose test poses or cycle moves the cell refuses.

    Raises
    ------
    Iso9283Error
        Naming the first test pose out of reach.
    """
    commanded_joints(mdh, limits_rad, flange2tool, cube, rotation, cell, what="--cube: ")


def commanded_joints(
    mdh: npt.ArrayLike,
    limits_rad: npt.ArrayLike,
    flange2tool: npt.ArrayLike,
    cube: Cube,
    rotation: npt.ArrayLike = TOOL_DOWN,
    cell: Admissible | None = None,
    what: str = "",
) -> np.ndarray:
    """Nominal joint targets of P1..P5 (what an uncalibrated controller commands).

    All five are solved from the centre's joint solution (one branch: elbow,
    wrist), which with ``cell`` is one the cell allows.

    Parameters
    ----------
    mdh, limits_rad, flange2tool, cube, rotation
        As :func:`largest_cube`.
    cell : Admissible, optional
        Refuse test poses, or moves of the cycle (P5 .. P1, then P1 -> P5),
        the cell does not allow.
    what : str
        Prefix of the error messages (the option that gave the cube).

    Returns
    -------
    ndarray, shape (5, 6)
        Row ``k`` reaches test pose ``P(k+1)`` on the nominal model, rad.

    Raises
    ------
    Iso9283Error
        Naming the first test pose, or move, out of reach and why.
    """
    rng = np.random.default_rng(9283)
    centre = np.asarray(cube.centre_mm, float)[None]
    rotation = np.asarray(rotation, float)
    q_centre = _centre_solutions(mdh, flange2tool, limits_rad, centre, rotation, rng, cell)[0]
    if not np.isfinite(q_centre).all():
        where = " the cell allows" if cell is not None else ""
        raise Iso9283Error(
            f"{what}the cube centre {cube.centre_mm.tolist()} mm is out of reach{where}"
        )
    poses = test_poses(cube.centre_mm, cube.side_mm, rotation)
    sol = solve_poses(mdh, poses, flange2tool, limits_rad, q_centre)
    ok = sol.ok & _regular(mdh, flange2tool, sol.q, q_centre, limits_rad, cell)
    if not ok.all():
        why = "joint limits, configuration change, singularity" + (
            " or the cell" if cell is not None else ""
        )
        raise Iso9283Error(
            f"{what}test pose P{int(np.flatnonzero(~ok)[0]) + 1} is out of reach "
            f"({why}); choose a smaller cube"
        )
    if cell is not None:
        qa, qb = _cycle_moves(sol.q)
        clear = np.asarray(cell.moves(qa, qb), bool)
        if not clear.all():
            k = int(np.flatnonzero(~clear)[0])
            a, b = CYCLE_ORDER[k], CYCLE_ORDER[(k + 1) % len(CYCLE_ORDER)]
            raise Iso9283Error(
                f"{what}the move from P{a} to P{b} is not clear in the cell; choose a smaller cube"
            )
    return sol.q


def cycle_plan(q_test: npt.ArrayLike, cycles: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The run's joint plan: ``cycles`` times P5, P4, P3, P2, P1.

    Parameters
    ----------
    q_test : array_like, shape (5, 6)
        Joint targets of P1..P5, rad.
    cycles : int

    Returns
    -------
    plan : ndarray, shape (5 * cycles, 6)
    test_pose : ndarray of int, shape (5 * cycles,)
        Test pose number (1..5) of each plan row.
    cycle : ndarray of int, shape (5 * cycles,)
        Cycle number (1..cycles) of each plan row.
    """
    order = np.tile(np.array(CYCLE_ORDER), cycles)
    cycle = np.repeat(np.arange(1, cycles + 1), len(CYCLE_ORDER))
    return np.asarray(q_test, float)[order - 1], order, cycle
