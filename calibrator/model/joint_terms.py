"""Joint error terms: what the joint really turns to, from what the controller reads.

The geometric model takes the joint angles the robot reports. Three kinds of
non-geometric error act on the angle itself, and are modelled as an effective
angle fed to the same MDH chain::

    q_eff_j = q_j (1 + s_j)                      scale (gear-ratio error)
            + c_j cos q_j + d_j sin q_j          first harmonic (eccentric gear, encoder)
            + k_j tau_j                          compliance under gravity torque

``tau_j`` is the gravity torque about joint ``j`` (N m) from a mass model
(:mod:`calibrator.model.mass_models`) and the payload, computed with the nominal
geometry (a sub-millimetre geometric error changes it by a fraction of a
per cent). ``s`` is dimensionless, ``c``, ``d`` rad, ``k`` rad/(N m).

Parameter names (in :data:`calibrator.model.parameters.ALL_NAMES` when wired):
``scale1..6``, ``hcos1..6``, ``hsin1..6``, ``comp1..6``. Every function is
vectorized over poses (and over a leading batch of term sets).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from calibrator.errors import CalibrationError
from calibrator.inputs.rules import Rule
from calibrator.model import kinematics
from calibrator.model.mass_models import GRAVITY_MM_S2, MassModel

#: The term groups ``--joint-terms`` accepts, and their parameter name prefixes.
GROUPS = {"scale": ("scale",), "harmonic": ("hcos", "hsin"), "compliance": ("comp",)}
PREFIXES = ("scale", "hcos", "hsin", "comp")
NAMES = tuple(f"{p}{j + 1}" for p in PREFIXES for j in range(6))
#: Units of each prefix.
UNITS = {"scale": "1", "hcos": "rad", "hsin": "rad", "comp": "rad/Nm"}
#: Plausible size (one prior standard deviation) of each prefix's term: gear
#: ratios are good to about 1e-3, harmonic errors about 1 mrad, joint
#: compliance of a 10 kg-class arm a few 1e-6 rad/(N m).
PLAUSIBLE = {"scale": 1e-3, "hcos": 1e-3, "hsin": 1e-3, "comp": 5e-6}
#: Heaviest payload taken (kg): above the rating of every arm of the catalogue
#: (30 kg), below what a typo (1e308, 1000000) gives.
MAX_PAYLOAD_KG = 100.0
#: Farthest payload centre of mass from the flange (mm): the tool budget of the CLI.
MAX_PAYLOAD_COM_MM = 2_000.0
#: The payload options (``--payload-kg``, ``--payload-com-mm``), one of
#: :data:`calibrator.recorded_options.RULES` each: the same rules check
#: the payload a calibration's ``joint_terms`` records.
PAYLOAD_KG = Rule(
    "payload_kg",
    float,
    0.0,
    MAX_PAYLOAD_KG,
    unit="kg",
    flag="--payload-kg",
    group="joint",
    meaning="payload of sessions that record none",
)
PAYLOAD_COM_MM = Rule(
    "payload_com_mm",
    tuple,
    high=MAX_PAYLOAD_COM_MM,
    unit="mm",
    size=3,
    flag="--payload-com-mm",
    group="joint",
    meaning="payload centre of mass in the flange frame, x,y,z",
)


def parse_groups(text: str) -> tuple[str, ...]:
    """``'scale,harmonic'`` -> ``('scale', 'harmonic')``; one line naming a bad one."""
    items = str(text).split(",")
    if len(items) > 1 and any(not g.strip() for g in items):
        # ``scale,,harmonic`` or ``scale,``: a term left out by a typo, never skipped.
        raise CalibrationError(f"--joint-terms: {text!r:.60} has an empty item")
    groups = tuple(dict.fromkeys(g.strip().lower() for g in str(text).split(",") if g.strip()))
    bad = [g for g in groups if g not in GROUPS]
    if bad or not groups:
        from calibrator.inputs.messages import shown

        named = ", ".join(shown(b, 30).strip("'") for b in bad[:5]) or shown(text, 30)
        raise CalibrationError(
            f"--joint-terms: unknown term {named}; use any of {', '.join(GROUPS)}"
        )
    return groups


def names_of(groups: tuple[str, ...]) -> tuple[str, ...]:
    """Parameter names of term groups, in :data:`NAMES` order."""
    prefixes = {p for g in groups for p in GROUPS[g]}
    return tuple(n for n in NAMES if n.rstrip("0123456789") in prefixes)


def prefix(name: str) -> str:
    """``'hcos3'`` -> ``'hcos'``."""
    return name.rstrip("0123456789")


@dataclass(frozen=True)
class JointTerms:
    """Values of every joint term (zeros where not used).

    Attributes
    ----------
    scale, cos, sin, compliance : ndarray, shape (6,)
        ``s`` (1), ``c`` (rad), ``d`` (rad), ``k`` (rad/(N m)).
    payload_kg : float
        Payload of the calibration the compliance was fitted at.
    payload_com_mm : ndarray, shape (3,)
        Payload centre of mass in the flange frame (mm).
    mass_model : str
        Name of the mass model the torques come from ('' when unused).
    """

    scale: np.ndarray
    cos: np.ndarray
    sin: np.ndarray
    compliance: np.ndarray
    payload_kg: float = 0.0
    payload_com_mm: np.ndarray = field(default_factory=lambda: np.zeros(3))
    mass_model: str = ""

    @classmethod
    def zero(cls) -> JointTerms:
        return cls(np.zeros(6), np.zeros(6), np.zeros(6), np.zeros(6))

    @classmethod
    def from_vector(cls, full: np.ndarray, **extra: object) -> JointTerms:
        """From the 24 values in :data:`NAMES` order."""
        full = np.asarray(full, dtype=float).reshape(4, 6)
        return cls(*full, **extra)  # type: ignore[arg-type]

    def vector(self) -> np.ndarray:
        """The 24 values in :data:`NAMES` order."""
        return np.concatenate([self.scale, self.cos, self.sin, self.compliance])

    @property
    def used(self) -> bool:
        return bool(np.any(self.vector() != 0))

    @property
    def needs_torque(self) -> bool:
        return bool(np.any(self.compliance != 0))

    def to_json(self) -> dict:
        """The ``"joint_terms"`` entry of calibration.json."""
        return {
            "scale": self.scale.tolist(),
            "harmonic": {"cos": self.cos.tolist(), "sin": self.sin.tolist()},
            "compliance": {
                "rad_per_Nm": self.compliance.tolist(),
                "payload_kg": float(self.payload_kg),
                "payload_com_mm": np.asarray(self.payload_com_mm, dtype=float).tolist(),
                "mass_model": self.mass_model,
            },
        }

    @classmethod
    def from_json(cls, doc: object) -> JointTerms:
        """Read the ``"joint_terms"`` entry; absent parts are zero.

        Raises
        ------
        CalibrationError
            Naming the entry that is malformed.
        """
        if doc is None:
            return cls.zero()
        if not isinstance(doc, dict):
            raise CalibrationError("joint_terms must be an object")

        def six(value: object, what: str) -> np.ndarray:
            if value is None:
                return np.zeros(6)
            try:
                arr = np.array(value, dtype=float)
            except (TypeError, ValueError):
                arr = np.zeros(0)
            if arr.shape != (6,) or not np.all(np.isfinite(arr)):
                raise CalibrationError(f"joint_terms {what} must be 6 finite numbers")
            return arr

        harmonic = doc.get("harmonic") or {}
        comp = doc.get("compliance") or {}
        if not isinstance(harmonic, dict) or not isinstance(comp, dict):
            raise CalibrationError("joint_terms harmonic and compliance must be objects")
        # The rules of identify's --payload-kg and --payload-com-mm: a file
        # cannot hold what the command line refuses.
        payload = PAYLOAD_KG.check(comp.get("payload_kg", 0.0), "joint_terms payload_kg")
        com = np.array(
            PAYLOAD_COM_MM.check(
                comp.get("payload_com_mm", [0.0, 0.0, 0.0]), "joint_terms payload_com_mm"
            )
        )
        mass_model = comp.get("mass_model", "")
        if not isinstance(mass_model, str):
            raise CalibrationError("joint_terms mass_model must be text (a named arm or a YAML)")
        return cls(
            six(doc.get("scale"), "scale"),
            six(harmonic.get("cos"), "harmonic cos"),
            six(harmonic.get("sin"), "harmonic sin"),
            six(comp.get("rad_per_Nm"), "compliance rad_per_Nm"),
            payload,
            com,
            mass_model,
        )


def effective(q: np.ndarray, terms: np.ndarray, torque: np.ndarray | None = None) -> np.ndarray:
    """Effective joint angles.

    Parameters
    ----------
    q : ndarray, shape (N, 6)
        Joint angles read back (rad).
    terms : ndarray, shape (..., 24)
        Term values in :data:`NAMES` order (a batch of sets allowed).
    torque : ndarray, shape (N, 6), optional
        Gravity torques (N m); required when any compliance term is nonzero.

    Returns
    -------
    ndarray, shape (..., N, 6)
    """
    q = np.asarray(q, dtype=float)
    t = np.asarray(terms, dtype=float)
    t = t.reshape(t.shape[:-1] + (4, 6))[..., None, :, :]  # (..., 1, 4, 6)
    out = q * (1.0 + t[..., 0, :]) + t[..., 1, :] * np.cos(q) + t[..., 2, :] * np.sin(q)
    if np.any(t[..., 3, :]):
        if torque is None:
            raise CalibrationError("compliance terms need the gravity torque at every pose")
        out = out + t[..., 3, :] * np.asarray(torque, dtype=float)
    return out


def derivatives(q: np.ndarray, torque: np.ndarray | None = None) -> np.ndarray:
    """``d q_eff_j / d term`` for every term, shape (N, 24) (term j acts on joint j only)."""
    q = np.asarray(q, dtype=float)
    tau = np.zeros_like(q) if torque is None else np.asarray(torque, dtype=float)
    return np.concatenate([q, np.cos(q), np.sin(q), tau], axis=-1)


def gravity_torques(
    mdh: np.ndarray,
    q: np.ndarray,
    masses: MassModel,
    payload_kg: np.ndarray | float = 0.0,
    payload_com_mm: np.ndarray | None = None,
    gravity_base: np.ndarray | None = None,
) -> np.ndarray:
    """Gravity torque about each joint axis at each pose (N m).

    ``tau_j = z_{j-1} . sum_{i >= j} (c_i - o_{j-1}) x (m_i g)``, with ``z``,
    ``o`` the axis and origin of joint ``j`` (the frame before ``Rz(q_j)`` in
    the MDH chain) and ``c_i`` the centres of mass, the payload a point mass
    on link 6. Sign: the torque the load exerts on the joint, positive about
    the joint axis.

    Parameters
    ----------
    mdh : ndarray, shape (6, 5)
        Table (nominal); mm, rad.
    q : ndarray, shape (N, 6)
    masses : MassModel
    payload_kg : float or ndarray, shape (N,)
        Payload per pose (kg).
    payload_com_mm : ndarray, shape (3,), optional
        Payload centre of mass in the flange frame (mm).
    gravity_base : ndarray, shape (3,), optional
        Unit gravity direction in the robot base frame; default ``-z``.

    Returns
    -------
    ndarray, shape (N, 6)
    """
    q = kinematics.check_joints(q)
    n = len(q)
    _, frames = kinematics.chain(mdh, q, all_frames=True)  # (N, 7, 4, 4)
    g_dir = np.array([0.0, 0.0, -1.0]) if gravity_base is None else np.asarray(gravity_base)
    g = g_dir * GRAVITY_MM_S2 * 1e-3  # N per kg
    rot, origin = frames[:, 1:, :3, :3], frames[:, 1:, :3, 3]
    com = np.einsum("nkij,kj->nki", rot, masses.com_mm) + origin  # (N, 6, 3)
    force = masses.mass_kg[None, :, None] * g  # (1, 6, 3)
    force = np.broadcast_to(force, (n, 6, 3))
    pay = np.broadcast_to(np.asarray(payload_kg, dtype=float), (n,))
    p_com = np.zeros(3) if payload_com_mm is None else np.asarray(payload_com_mm, dtype=float)
    pay_c = frames[:, 6, :3, :3] @ p_com + frames[:, 6, :3, 3]
    pay_f = pay[:, None] * g
    # Joint j's axis: z of the frame A_1..A_{j-1} (index j-1), origin likewise.
    axes, orig = frames[:, :6, :3, 2], frames[:, :6, :3, 3]
    tau = np.zeros((n, 6))
    for j in range(6):
        arm = com[:, j:] - orig[:, j, None]
        moment = np.cross(arm, force[:, j:]).sum(axis=1)
        moment += np.cross(pay_c - orig[:, j], pay_f)
        tau[:, j] = np.einsum("ni,ni->n", moment, axes[:, j])
    return tau * 1e-3  # N mm -> N m


def torque_function(
    terms: JointTerms,
    nominal_mdh: np.ndarray,
    masses: MassModel | None,
    payload_kg: float | None = None,
) -> Callable[[np.ndarray], np.ndarray] | None:
    """``tau(q)`` for the compliance terms at a payload (default: the calibration's).

    ``masses`` are the arm's (:func:`calibrator.robots.masses.for_terms`).
    Returns None when the terms have no compliance.
    """
    if not terms.needs_torque:
        return None
    if masses is None:
        raise CalibrationError("the compliance terms need the arm's masses")
    kg = terms.payload_kg if payload_kg is None else float(payload_kg)

    def tau(q: np.ndarray) -> np.ndarray:
        return gravity_torques(nominal_mdh, q, masses, kg, terms.payload_com_mm)

    return tau


def invert(
    q_eff: np.ndarray,
    terms: JointTerms,
    torque: Callable[[np.ndarray], np.ndarray] | None = None,
    iterations: int = 20,
) -> np.ndarray:
    """Read-back angles whose effective angles are ``q_eff`` (what to command).

    Newton steps per joint on ``q (1 + s) + c cos q + d sin q + k tau(q) = q_eff``;
    the torque's dependence on ``q`` is left out of the derivative (``k dtau/dq``
    is about 1e-4) and re-evaluated every step.

    Parameters
    ----------
    q_eff : ndarray, shape (N, 6)
    terms : JointTerms
    torque : callable, optional
        ``torque(q) -> (N, 6)`` N m; needed with compliance terms.

    Returns
    -------
    ndarray, shape (N, 6)
    """
    target = np.asarray(q_eff, dtype=float)
    vec = terms.vector()
    s, c, d, _ = vec.reshape(4, 6)
    q = target.copy()
    for _ in range(iterations):
        tau = None if torque is None else torque(q)
        f = effective(q, vec, tau) - target
        q = q - f / (1.0 + s - c * np.sin(q) + d * np.cos(q))
        if np.max(np.abs(f), initial=0.0) < 1e-13:
            break
    return q


def loss_note(terms: JointTerms) -> str | None:
    """What an export that cannot hold the joint terms loses, or None when they are zero.

    The size given is the largest angle change the scale and harmonic terms
    make over +-pi, per joint that has them (compliance depends on the load).
    """
    if not terms.used:
        return None
    kinds = [
        name
        for name, values in (
            ("scale", terms.scale),
            ("harmonic", np.r_[terms.cos, terms.sin]),
            ("compliance", terms.compliance),
        )
        if np.any(values != 0)
    ]
    size = np.abs(terms.scale) * np.pi + np.hypot(terms.cos, terms.sin)
    joints = ", ".join(f"q{j + 1} {1e3 * size[j]:.3g}" for j in range(6) if size[j] > 0)
    text = f"cannot hold the joint terms ({', '.join(kinds)})"
    if joints:
        text += f": up to {joints} mrad over +-pi is lost"
    if terms.needs_torque:
        text += "; compliance k tau is lost"
    return text + " (calibrator compensate applies them)"
