"""The one tracker noise model: anisotropic, range-dependent, per reading.

Measurement noise of a Leica-class absolute tracker at the origin of the
tracker frame. Its ISO 10360-10 maximum permissible errors are anisotropic:
along the beam ``10 um + 0.3 um/m``, transverse to it ``15 um + 6 um/m``
(range in metres). The MPE is taken as two standard deviations ("typical
results about half the MPE"), with independent Gaussian errors along the
beam and two transverse axes. Both tracker simulators draw every reading
from it; :func:`calibrator.simulate.tracker_readings` (synthetic
sessions) uses its range-dependent transverse term with the user's
``noise_mm`` as the constant term.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class NoiseModel:
    """Anisotropic, range-dependent tracker noise.

    Attributes
    ----------
    along_mpe_um : tuple of float
        ``(constant_um, um_per_m)`` MPE along the beam.
    transverse_mpe_um : tuple of float
        ``(constant_um, um_per_m)`` MPE per transverse axis.
    rotation_mpe_rad : float
        MPE of each rotation-vector component of a 6-DoF probe, rad
        (0.01 deg, the order of a Leica T-Mac; an assumption, not a datasheet).
    mpe_over_sigma : float
        MPE divided by the standard deviation used for sampling.
    enabled : bool
        False gives exact readings (for deterministic tests).
    """

    along_mpe_um: tuple[float, float] = (10.0, 0.3)
    transverse_mpe_um: tuple[float, float] = (15.0, 6.0)
    rotation_mpe_rad: float = math.radians(0.01)
    mpe_over_sigma: float = 2.0
    enabled: bool = True

    def sigmas_mm(self, point_mm: np.ndarray) -> tuple[float, float]:
        """Standard deviations ``(along, transverse)`` in mm at a target position.

        Parameters
        ----------
        point_mm : numpy.ndarray, shape (3,)
            Target position in the tracker frame, mm.
        """
        range_m = float(np.linalg.norm(point_mm)) / 1000.0
        along_um = self.along_mpe_um[0] + self.along_mpe_um[1] * range_m
        trans_um = self.transverse_mpe_um[0] + self.transverse_mpe_um[1] * range_m
        return along_um / self.mpe_over_sigma / 1000.0, trans_um / self.mpe_over_sigma / 1000.0

    def scale_matrix(self, point_mm: np.ndarray) -> np.ndarray:
        """Rows: the beam and two transverse unit vectors, each times its sigma (mm).

        A reading is ``point_mm + rng.standard_normal(3) @ scale_matrix(point_mm)``.
        Depends only on the target, so callers may cache it (np.cross is slow on 3-vectors).

        Returns
        -------
        numpy.ndarray, shape (3, 3)
        """
        s_along, s_trans = self.sigmas_mm(point_mm)
        return np.array(beam_frame(point_mm)) * np.array([[s_along], [s_trans], [s_trans]])

    def sample_point(
        self, point_mm: np.ndarray, rng: np.random.Generator, scale: np.ndarray | None = None
    ) -> np.ndarray:
        """One noisy reading of a target at ``point_mm`` (shape (3,), mm, tracker frame).

        ``scale`` is :meth:`scale_matrix` of the same point, if the caller cached it.
        """
        point_mm = np.asarray(point_mm, dtype=float)
        if not self.enabled:
            return point_mm.copy()
        if scale is None:
            scale = self.scale_matrix(point_mm)
        return point_mm + rng.standard_normal(3) @ scale

    def sample_rotvec(self, rotvec_rad: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """One noisy probe orientation (rotation vector, shape (3,), rad).

        The error is a small rotation applied on the tracker side of the true one.
        """
        rotvec_rad = np.asarray(rotvec_rad, dtype=float)
        if not self.enabled:
            return rotvec_rad.copy()
        from scipy.spatial.transform import Rotation  # only 6-DoF runs pay for the import

        err = rng.standard_normal(3) * (self.rotation_mpe_rad / self.mpe_over_sigma)
        return (Rotation.from_rotvec(err) * Rotation.from_rotvec(rotvec_rad)).as_rotvec()


def beam_frame(point_mm: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Unit vectors ``(along_beam, transverse_1, transverse_2)`` for a target (tracker at origin).

    Raises
    ------
    ValueError
        For a target at the tracker's own origin, where the beam has no direction.
    """
    r = float(np.linalg.norm(point_mm))
    if r == 0.0:
        raise ValueError("target at the tracker origin has no beam direction")
    beam = np.asarray(point_mm, dtype=float) / r
    # Any axis not parallel to the beam gives a valid transverse pair.
    helper = np.array([0.0, 0.0, 1.0]) if abs(beam[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    side1 = np.cross(beam, helper)
    side1 /= np.linalg.norm(side1)
    return beam, side1, np.cross(beam, side1)


#: The tracker noise of every simulation (the simulators' default).
TRACKER_NOISE = NoiseModel()
