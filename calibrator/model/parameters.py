"""Which parameters are identified, and how they map to one vector.

The full candidate set is the 6 x 5 MDH table, the pose of the robot base in
the tracker frame (6) and the tool frame in the flange frame (point 3,
rotation 3). A
:class:`ParameterSpace` fixes the nominal values and a boolean mask over the
candidates (the pybotics pattern); :meth:`ParameterSpace.unpack` turns a vector
of *deltas* (or a swarm of them) into MDH tables and frames.

Parameter names
---------------
``a1 .. beta6``
    MDH deltas (mm or rad), ``<column><joint>``.
``base_tx, base_ty, base_tz, base_rx, base_ry, base_rz``
    ``base2tracker = base0 . Trans(tx, ty, tz) . Rx(rx) . Ry(ry) . Rz(rz)``
    around the closed-form first guess ``base0`` (mm, rad).
``tool_x, tool_y, tool_z``
    The tool point in the flange frame minus its first guess (mm).
``tool_rx, tool_ry, tool_rz``
    Rotation of the tool frame: ``R(flange2tool) = R(tool0) . Rx(rx) . Ry(ry) . Rz(rz)``
    around the closed-form first guess ``tool0`` (rad). Only with orientation data.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from calibrator.errors import IdentifiabilityError
from calibrator.model import frames, joint_terms, kinematics, rotations

MDH_NAMES = kinematics.MDH_NAMES
BASE_NAMES = ("base_tx", "base_ty", "base_tz", "base_rx", "base_ry", "base_rz")
TOOL_NAMES = ("tool_x", "tool_y", "tool_z")
TOOL_ROTATION_NAMES = ("tool_rx", "tool_ry", "tool_rz")
# Opt-in joint error terms (scale, harmonic, compliance), see calibrator.model.joint_terms.
JOINT_TERM_NAMES = joint_terms.NAMES
ALL_NAMES = MDH_NAMES + BASE_NAMES + TOOL_NAMES + TOOL_ROTATION_NAMES
#: Every name a space can free: the geometry, then the opt-in joint terms.
NAMES_WITH_TERMS = ALL_NAMES + JOINT_TERM_NAMES
N_MDH, N_BASE, N_TOOL = len(MDH_NAMES), len(BASE_NAMES), len(TOOL_NAMES)
#: Offsets of the blocks in :data:`ALL_NAMES`.
TOOL_START = N_MDH + N_BASE
TOOL_ROTATION_START = TOOL_START + N_TOOL
JOINT_TERM_START = TOOL_ROTATION_START + len(TOOL_ROTATION_NAMES)
_INDEX = {name: i for i, name in enumerate(NAMES_WITH_TERMS)}


def unit(name: str) -> str:
    """Unit of a parameter, ``'mm'`` or ``'rad'``."""
    i = _INDEX[name]
    if i >= JOINT_TERM_START:
        return joint_terms.UNITS[joint_terms.prefix(name)]
    if i < N_MDH:
        return kinematics.UNITS[i % 5]
    if i < TOOL_START:
        return "mm" if name[-2] == "t" else "rad"
    return "mm" if i < TOOL_ROTATION_START else "rad"


#: Plausible size of a delta (one standard deviation of a prior), by block and
#: unit: MDH errors of a machined arm are a fraction of a millimetre and about
#: 10 mrad at most (the IPSO paper's injected errors); the frames start from
#: closed-form guesses a few millimetres and milliradians off.
PLAUSIBLE = {("mdh", "mm"): 1.0, ("mdh", "rad"): 0.01, ("frame", "mm"): 5.0, ("frame", "rad"): 0.02}


def plausible_range(name: str) -> float:
    """Plausible size of the delta of a parameter (mm or rad), see :data:`PLAUSIBLE`."""
    if _INDEX[name] >= JOINT_TERM_START:
        return joint_terms.PLAUSIBLE[joint_terms.prefix(name)]
    return PLAUSIBLE[("mdh" if _INDEX[name] < N_MDH else "frame", unit(name))]


@dataclass(frozen=True)
class ParameterSpace:
    """Nominal values plus the names of the free parameters, in vector order.

    Attributes
    ----------
    nominal_mdh : ndarray, shape (6, 5)
        MDH table the deltas are added to (mm, rad).
    base0 : ndarray, shape (4, 4)
        ``base2tracker`` first guess (identity in the base frame).
    tool0 : ndarray, shape (4, 4)
        ``flange2tool`` first guess (its point and, with orientation data,
        its rotation are identified around it).
    free : tuple of str
        Names of the free parameters, in :data:`ALL_NAMES` order.
    """

    nominal_mdh: np.ndarray
    base0: np.ndarray = field(default_factory=lambda: np.eye(4))
    tool0: np.ndarray = field(default_factory=lambda: np.eye(4))
    free: tuple = ()

    def __post_init__(self):
        unknown = [n for n in self.free if n not in _INDEX]
        if unknown:
            raise ValueError(f"unknown parameter names: {unknown}")
        order = tuple(sorted(set(self.free), key=_INDEX.__getitem__))
        object.__setattr__(self, "free", order)
        object.__setattr__(self, "nominal_mdh", kinematics.check_mdh(self.nominal_mdh))
        object.__setattr__(self, "base0", frames.check_transform(self.base0, "base0"))
        object.__setattr__(self, "tool0", frames.check_transform(self.tool0, "tool0"))

    @property
    def size(self) -> int:
        """Number of free parameters."""
        return len(self.free)

    @property
    def index(self) -> np.ndarray:
        """Positions of the free parameters in :data:`ALL_NAMES`, shape (size,)."""
        return np.array([_INDEX[n] for n in self.free], dtype=int)

    @property
    def units(self) -> tuple[str, ...]:
        """Unit of each free parameter."""
        return tuple(unit(n) for n in self.free)

    def joint_terms(self, x: ArrayLike) -> np.ndarray:
        """Joint-term values (zeros where not free), shape (..., 24); see model.joint_terms."""
        x = np.asarray(x, dtype=float)
        if not self.has_joint_terms:
            return np.zeros(x.shape[:-1] + (len(JOINT_TERM_NAMES),))
        return self.expand(x)[..., JOINT_TERM_START:]

    @property
    def has_joint_terms(self) -> bool:
        return bool(np.any(self.index >= JOINT_TERM_START))

    def with_free(self, free: Iterable[str]) -> ParameterSpace:
        """The same space with another free set."""
        return ParameterSpace(self.nominal_mdh, self.base0, self.tool0, tuple(free))

    def expand(self, x: ArrayLike) -> np.ndarray:
        """Deltas of every candidate parameter, zeros where not free.

        Parameters
        ----------
        x : array_like, shape (..., size)

        Returns
        -------
        ndarray, shape (..., len(ALL_NAMES)), or (..., len(NAMES_WITH_TERMS)) with joint terms
        """
        x = np.asarray(x, dtype=float)
        if x.shape[-1] != self.size:
            raise ValueError(f"parameter vector must end in {self.size}, got {x.shape}")
        # Joint terms widen the vector only when some are free (geometry stays 42 wide).
        width = len(NAMES_WITH_TERMS) if self.has_joint_terms else len(ALL_NAMES)
        full = np.zeros(x.shape[:-1] + (width,))
        full[..., self.index] = x
        return full

    def unpack(self, x: ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """MDH tables and frames for a vector (or a swarm) of deltas.

        Parameters
        ----------
        x : array_like, shape (..., size)

        Returns
        -------
        mdh : ndarray, shape (..., 6, 5)
        base2tracker : ndarray, shape (..., 4, 4)
        flange2tool : ndarray, shape (..., 4, 4)
        """
        full = self.expand(x)
        mdh = self.nominal_mdh + full[..., :N_MDH].reshape(full.shape[:-1] + (6, 5))
        b = full[..., N_MDH:TOOL_START]
        delta = frames.transform(rotations.rotations_xyz(b[..., 3:]), b[..., :3])
        base2tracker = self.base0 @ delta
        flange2tool = np.broadcast_to(self.tool0, full.shape[:-1] + (4, 4)).copy()
        flange2tool[..., :3, 3] += full[..., TOOL_START:TOOL_ROTATION_START]
        turn = full[..., TOOL_ROTATION_START:JOINT_TERM_START]
        if np.any(turn):
            flange2tool[..., :3, :3] = self.tool0[:3, :3] @ rotations.rotations_xyz(turn)
        return mdh, base2tracker, flange2tool

    def pack(
        self,
        mdh: ArrayLike | None = None,
        base2tracker: ArrayLike | None = None,
        flange2tool: ArrayLike | None = None,
    ) -> np.ndarray:
        """Inverse of :meth:`unpack` for one parameter set.

        Parameters
        ----------
        mdh : array_like, shape (6, 5), optional
            Defaults to the nominal table.
        base2tracker, flange2tool : array_like, shape (4, 4), optional
            Default to the first guesses.

        Returns
        -------
        ndarray, shape (size,)
            Deltas of the free parameters. Differences in parameters that
            are not free are dropped.
        """
        geometry = all_deltas(
            self.nominal_mdh,
            self.base0,
            self.tool0,
            self.nominal_mdh if mdh is None else kinematics.check_mdh(mdh),
            self.base0 if base2tracker is None else base2tracker,
            self.tool0 if flange2tool is None else flange2tool,
        )
        # Joint terms are not part of an arm's geometry: packed as zero.
        full = np.zeros(len(NAMES_WITH_TERMS))
        full[: len(ALL_NAMES)] = geometry
        # What is not given is exactly the first guess, not its round trip.
        if base2tracker is None:
            full[N_MDH:TOOL_START] = 0.0
        if flange2tool is None:
            full[TOOL_START:JOINT_TERM_START] = 0.0
        return full[self.index]

    def bounds(
        self, mm: float = 2.0, rad: float = 0.04, frame_mm: float = 10.0, frame_rad: float = 0.04
    ) -> tuple[np.ndarray, np.ndarray]:
        """Symmetric search box around zero deltas for the swarm.

        The IPSO paper starts its swarm within +-0.5 mm and +-0.01 rad, just
        covering its injected errors; the box is four times that so that
        particles are not pinned against its walls (pinned particles lose
        their velocity and the swarm stalls). The base frame and tool point
        start from closed-form guesses a few millimetres off.

        Returns
        -------
        lower, upper : ndarray, shape (size,)
        """
        halves = []
        for name in self.free:
            if _INDEX[name] >= JOINT_TERM_START:
                halves.append(4 * plausible_range(name))
                continue
            is_frame = _INDEX[name] >= N_MDH
            if unit(name) == "mm":
                halves.append(frame_mm if is_frame else mm)
            else:
                halves.append(frame_rad if is_frame else rad)
        half = np.array(halves)
        return -half, half


def structural_candidates(
    nominal_mdh: ArrayLike, frame: str, tool_known: bool, orientation: bool = False
) -> tuple[list[str], list[dict]]:
    """Candidate free set before looking at data, and why the rest is left out.

    Hayati's rule: where axes i and i+1 are parallel, ``d_i`` slides along
    both and is replaced by ``beta_i``; elsewhere ``beta_i`` duplicates the
    four DH parameters and is left out. ``beta6`` has no next axis: a turn
    about the flange's y axis belongs to the tool frame.

    With orientation data and an unknown tool, the whole tool frame (point
    and rotation) is identified; everything of joint 6 after its joint
    angle (``theta6, d6, a6, alpha6``) is then a constant transform before
    the tool frame and duplicates it, so those stay nominal. This makes the
    parameterisation unique: joint 6 is the bare rotation ``Rz(q6)``.

    Parameters
    ----------
    nominal_mdh : array_like, shape (6, 5)
    frame : {'base', 'tracker'}
        Whether ``base2tracker`` is identified.
    tool_known : bool
        Whether the tool frame is known (not identified).
    orientation : bool
        Whether orientation rows take part (6-DoF data and ``k > 0``).

    Returns
    -------
    candidates : list of str
    dropped : list of dict
        ``{"name": ..., "reason": ...}`` for every parameter left out.
    """
    parallel = kinematics.parallel_axes(nominal_mdh)
    full_tool = orientation and not tool_known
    candidates, dropped = [], []
    for j in range(6):
        for col in kinematics.COLUMNS:
            name = f"{col}{j + 1}"
            if full_tool and j == 5 and col != "beta":
                dropped.append(
                    _drop(
                        name,
                        "the tool frame (point and rotation) is identified: "
                        "joint 6's constant part belongs to it",
                    )
                )
            elif col == "d" and j < 5 and parallel[j]:
                dropped.append(
                    _drop(
                        name,
                        f"axes {j + 1} and {j + 2} are parallel: "
                        f"beta{j + 1} is identified instead (Hayati)",
                    )
                )
            elif col == "beta" and j == 5:
                dropped.append(
                    _drop(
                        name,
                        "no axis after joint 6: a turn about the "
                        "flange y axis belongs to the tool frame",
                    )
                )
            elif col == "beta" and not parallel[j]:
                dropped.append(
                    _drop(
                        name,
                        f"axes {j + 1} and {j + 2} are not parallel: "
                        "the DH parameters already describe them",
                    )
                )
            else:
                candidates.append(name)
    if frame == "tracker":
        candidates.extend(BASE_NAMES)
    if not tool_known:
        candidates.extend(TOOL_NAMES)
    if full_tool:
        candidates.extend(TOOL_ROTATION_NAMES)
    return candidates, dropped


def _drop(name, reason):
    return {"name": name, "reason": reason}


#: Jacobian column norm, relative to the largest, below which a parameter has no effect.
NEGLIGIBLE_COLUMN = 1e-9


def prune(
    candidates: Sequence[str],
    jacobian: ArrayLike,
    tol: float = 1e-6,
    context: str = "for these poses",
) -> tuple[list[str], list[dict]]:
    """Drop candidates the data cannot separate from the ones kept before them.

    Columns of the Jacobian are scaled to unit length and visited frames
    first (base, then tool), then joint by joint; a column whose component
    outside the span of the kept columns is below ``tol`` is dropped as
    redundant, naming the kept parameters it is a combination of.

    Parameters
    ----------
    candidates : sequence of str
        Names in :data:`ALL_NAMES`.
    jacobian : ndarray, shape (M, len(candidates))
        Residual Jacobian with respect to the candidates, at the first guess.
    tol : float
        Relative size under which a scaled column counts as redundant.
    context : str
        Ends each reason, e.g. whether the redundancy is the model's or the data's.

    Returns
    -------
    kept : list of str
    dropped : list of dict
        ``{"name": ..., "reason": ...}``.
    """
    jacobian = np.asarray(jacobian, dtype=float)
    norms = np.linalg.norm(jacobian, axis=0)
    order = sorted(range(len(candidates)), key=lambda k: _priority(candidates[k]))
    kept: list[str] = []
    dropped: list[dict] = []
    basis = np.zeros((jacobian.shape[0], 0))

    # A column with no real effect comes out as round-off (~1e-13), not exactly 0;
    # any real effect is within a few decades of the largest column.
    negligible = NEGLIGIBLE_COLUMN * norms.max(initial=0.0)
    for k in order:
        name = candidates[k]
        if norms[k] <= negligible:
            dropped.append(_drop(name, "has no effect on any measured pose"))
            continue
        col = jacobian[:, k] / norms[k]
        rest = col - basis @ (basis.T @ col)
        rest -= basis @ (basis.T @ rest)  # second pass keeps Gram-Schmidt orthogonal
        size = np.linalg.norm(rest)
        if size < tol:
            kept_idx = [candidates.index(n) for n in kept]
            lstsq = np.linalg.lstsq(jacobian[:, kept_idx] / norms[kept_idx], col, rcond=None)[0]
            partners = [kept[i] for i in np.argsort(-np.abs(lstsq))[:3] if abs(lstsq[i]) > 1e-3]
            dropped.append(_drop(name, f"redundant with {', '.join(partners)} {context}"))
            continue
        kept.append(name)
        basis = np.column_stack([basis, rest / size])
    kept.sort(key=_INDEX.__getitem__)
    return kept, dropped


def _priority(name):
    # Frames first: a base frame or tool point absorbs what joint 1 and
    # joint 6 duplicate, and the MDH table keeps its nominal meaning there.
    i = _INDEX[name]
    if i >= JOINT_TERM_START:  # joint terms last: geometry keeps what it can explain
        return i
    return i - len(ALL_NAMES) if i >= N_MDH else i


def require_enough(n_residuals: int, n_free: int, what: str = "the poses") -> None:
    """Raise if there are fewer residuals than free parameters."""
    if n_residuals < n_free:
        raise IdentifiabilityError(
            f"{n_residuals} measured values from {what} cannot identify "
            f"{n_free} free parameters; measure more poses"
        )


def all_deltas(
    nominal_mdh: np.ndarray,
    base0: np.ndarray,
    tool0: np.ndarray,
    mdh: ArrayLike,
    base2tracker: ArrayLike,
    flange2tool: ArrayLike,
) -> np.ndarray:
    """The delta of every named parameter from a nominal to an identified arm.

    The one definition of a delta, shared by the solver
    (:meth:`ParameterSpace.pack`), calibration.json's ``parameters``, the
    report and the CSV export:

    * MDH entries: identified minus nominal (mm, rad);
    * ``base_tx..base_rz``: the move of the base frame expressed in the
      nominal (first-guess) base frame, ``inv(base0) @ base2tracker`` as a
      translation (mm) and ``Rx Ry Rz`` angles (rad); for a session in the
      tracker frame this is *not* the difference of tracker-frame
      coordinates, which mixes in the base's orientation;
    * ``tool_x..tool_z``: identified minus nominal tool point, flange frame (mm);
    * ``tool_rx..tool_rz``: ``Rx Ry Rz`` angles of ``R(tool0)^T R(flange2tool)`` (rad).

    Parameters
    ----------
    nominal_mdh, mdh : ndarray, shape (6, 5)
    base0, base2tracker : ndarray, shape (4, 4)
        Nominal and identified robot base in the tracker frame (mm).
    tool0, flange2tool : ndarray, shape (4, 4)
        Nominal and identified tool frame in the flange frame (mm).

    Returns
    -------
    ndarray, shape (len(ALL_NAMES),)
        In the order of :data:`ALL_NAMES`.
    """
    full = np.zeros(len(ALL_NAMES))
    full[:N_MDH] = (np.asarray(mdh, dtype=float) - np.asarray(nominal_mdh, dtype=float)).ravel()
    move = frames.invert(np.asarray(base0, dtype=float)) @ np.asarray(base2tracker, dtype=float)
    full[N_MDH : N_MDH + 3] = move[:3, 3]
    full[N_MDH + 3 : TOOL_START] = rotations.angles_xyz(move[:3, :3])
    tool0 = np.asarray(tool0, dtype=float)
    flange2tool = np.asarray(flange2tool, dtype=float)
    full[TOOL_START:TOOL_ROTATION_START] = flange2tool[:3, 3] - tool0[:3, 3]
    full[TOOL_ROTATION_START:] = rotations.angles_xyz(tool0[:3, :3].T @ flange2tool[:3, :3])
    return full
