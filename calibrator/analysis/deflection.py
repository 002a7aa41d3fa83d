"""Hand error from link deflection, by kinetostatics (the deflection paper, eqs. 42-51).

Method
------
Each flexible link ``i`` is a straight cantilever clamped at its joint frame:
it runs from the origin of frame ``i-1`` (on joint ``i``'s axis) to the
origin of frame ``i``, with a circular (solid or hollow) section. Its loads:

- the weight and d'Alembert inertia of everything beyond it (links ``i+1..n``
  and the payload), reduced to one force and one moment at its tip;
- its own weight and inertia, spread evenly along the beam (a rod's weight is
  distributed; the deflection paper lumps it at the centre of mass), plus the moment of
  its centre of mass's offset from the beam axis, applied at the station of
  the centre of mass.

Beam theory (Euler-Bernoulli, no shear) gives the tip's small rotation
``phi`` and translation ``delta`` from these loads (the influence
coefficients of the deflection paper's eq. 48). Each tip deformation moves everything
beyond it rigidly, so the hand moves by ``delta + phi x (p_hand - p_tip)``
and turns by ``phi``; the contributions of all flexible links are expressed
in the hand frame and summed (eqs. 49-51).

Along a trajectory the inertia loads come from the link frames' second time
differences (``numpy.gradient``, second order): no dynamic model beyond the
masses, centres of mass and inertia tensors is needed.

Units: mm, s, kg, N, N mm, N/mm^2 (MPa); gravity is ``-z`` of the base frame.
Arrays are batched over poses: frames ``(N, n+1, 4, 4)``, results ``(N, ...)``.
"""

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from calibrator.errors import CalibrationError
from calibrator.inputs.messages import shown
from calibrator.inputs.rules import Rule
from calibrator.model import conventions, kinematics
from calibrator.model.mass_models import GRAVITY_MM_S2
from calibrator.robots import deflection_paper

#: What each value of a section may be: a robot link, not 1e-300 mm (its
#: stiffness underflows to nan) nor 1e308 mm (its D^4 overflows).
SECTION_RULES = {
    "outer_mm": Rule("outer_mm", float, 1.0, 2_000.0, unit="mm", meaning="outer diameter"),
    "inner_mm": Rule("inner_mm", float, 0.0, 2_000.0, unit="mm", meaning="inner diameter"),
    "e_mpa": Rule("e_mpa", float, 100.0, 1e6, unit="MPa", meaning="Young's modulus"),
    "poisson": Rule("poisson", float, 0.0, 0.5, open_high=True, meaning="Poisson's ratio"),
}


@dataclass(frozen=True)
class Section:
    """A circular beam section, solid (``inner_mm = 0``) or hollow, and its material.

    Attributes
    ----------
    outer_mm, inner_mm : float
        Outer and inner diameters (mm).
    e_mpa : float
        Young's modulus (N/mm^2); steel 2.1e5.
    poisson : float
        Poisson's ratio, for the shear modulus ``G = E / (2 (1 + nu))``.
    """

    outer_mm: float
    inner_mm: float = 0.0
    e_mpa: float = 2.1e5
    poisson: float = 0.3

    def __post_init__(self) -> None:
        for name, rule in SECTION_RULES.items():
            rule.check(getattr(self, name), name)
        if not (self.outer_mm > 0 and 0 <= self.inner_mm < self.outer_mm):
            raise CalibrationError(
                f"section needs outer diameter > inner >= 0, got {self.outer_mm}, {self.inner_mm}"
            )
        if not (self.e_mpa > 0 and 0 <= self.poisson < 0.5):
            raise CalibrationError("section needs E > 0 and 0 <= poisson < 0.5")

    @property
    def area_mm2(self) -> float:
        return np.pi / 4 * (self.outer_mm**2 - self.inner_mm**2)

    @property
    def bending_mm4(self) -> float:
        """Second moment of area about a diameter, ``pi (D^4 - d^4) / 64``."""
        return np.pi / 64 * (self.outer_mm**4 - self.inner_mm**4)

    @property
    def polar_mm4(self) -> float:
        """Polar moment (torsion constant of a circular section), ``2 I``."""
        return 2 * self.bending_mm4

    @property
    def shear_mpa(self) -> float:
        return self.e_mpa / (2 * (1 + self.poisson))


@dataclass(frozen=True)
class FlexArm:
    """An arm for the deflection analysis.

    Attributes
    ----------
    name : str
    frames : callable
        ``frames(q)`` with ``q`` shape ``(N, n)`` returns base2frame_i, shape
        ``(N, n+1, 4, 4)`` (mm); index 0 the base, ``n`` the hand.
    mass_kg : ndarray, shape (n,)
    com_mm : ndarray, shape (n, 3)
        Centre of mass of link ``i`` in frame ``i`` (mm).
    inertia_kg_mm2 : ndarray, shape (n, 3, 3)
        Inertia tensor of link ``i`` about its centre of mass, in frame ``i``.
    sections : dict of int to Section
        The flexible links (1-based index) and their sections; the others are rigid.
    """

    name: str
    frames: Callable[[np.ndarray], np.ndarray]
    mass_kg: np.ndarray
    com_mm: np.ndarray
    inertia_kg_mm2: np.ndarray
    sections: dict[int, Section] = field(default_factory=dict)

    @property
    def n(self) -> int:
        return len(self.mass_kg)


@dataclass(frozen=True)
class Deflection:
    """Hand deformation and each flexible link's share.

    Attributes
    ----------
    hand_rot_rad, hand_mm : ndarray, shape (N, 3)
        Small rotation and translation of the hand, in the hand frame.
    links : dict of int to dict
        Per flexible link: ``tip_rot_rad``, ``tip_mm`` (N, 3), its tip's own
        deformation in the base frame, and ``hand_rot_rad``, ``hand_mm``
        (N, 3), its share of the hand's, in the hand frame.
    """

    hand_rot_rad: np.ndarray
    hand_mm: np.ndarray
    links: dict[int, dict[str, np.ndarray]]


def cantilever_tip(
    axis: np.ndarray,
    length_mm: np.ndarray,
    section: Section,
    tip_force: np.ndarray,
    tip_moment: np.ndarray,
    spread_force: np.ndarray,
    station_mm: np.ndarray,
    station_moment: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Tip rotation and translation of a clamped straight beam (influence coefficients).

    Parameters
    ----------
    axis : ndarray, shape (N, 3)
        Unit vector root -> tip.
    length_mm : ndarray, shape (N,)
    section : Section
    tip_force, tip_moment : ndarray, shape (N, 3)
        Force (N) and moment (N mm) applied at the tip.
    spread_force : ndarray, shape (N, 3)
        Total of a load spread evenly over the length (N).
    station_mm : ndarray, shape (N,)
        Distance from the root of a point moment ``station_moment`` (N mm).

    Returns
    -------
    rot_rad, disp_mm : ndarray, shape (N, 3)
        Tip rotation and translation, in the frame of the inputs.

    Notes
    -----
    With ``u`` the axis, ``L`` the length, bending stiffness ``EI``: a tip
    force ``F`` across gives ``F L^3 / 3EI`` and a rotation ``F L^2 / 2EI``;
    a tip moment ``M`` gives ``M L^2 / 2EI`` and ``M L / EI``; a spread load
    ``w = W / L`` gives ``w L^4 / 8EI`` and ``w L^3 / 6EI``; a moment at
    station ``a`` gives ``M a (2L - a) / 2EI`` and ``M a / EI``; axial force
    ``F L / EA`` (spread: ``W L / 2EA``); torsion ``T L / GJ``.
    """
    u = axis
    L = np.asarray(length_mm, dtype=float)[:, None]
    a = np.asarray(station_mm, dtype=float)[:, None]
    ei, ea = section.e_mpa * section.bending_mm4, section.e_mpa * section.area_mm2
    gj = section.shear_mpa * section.polar_mm4

    def split(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        along = np.sum(v * u, axis=-1, keepdims=True) * u
        return along, v - along

    f_ax, f_t = split(tip_force)
    m_ax, m_b = split(tip_moment)
    w_ax, w_t = split(spread_force)
    s_ax, s_b = split(station_moment)
    disp = (
        f_ax * L / ea
        + f_t * L**3 / (3 * ei)
        + np.cross(m_b, u) * L**2 / (2 * ei)
        + w_ax * L / (2 * ea)
        + w_t * L**3 / (8 * ei)
        + np.cross(s_b, u) * a * (2 * L - a) / (2 * ei)
    )
    rot = (
        np.cross(u, f_t) * L**2 / (2 * ei)
        + m_b * L / ei
        + m_ax * L / gj
        + np.cross(u, w_t) * L**2 / (6 * ei)
        + s_b * a / ei
        + s_ax * a / gj
    )
    return rot, disp


def _time_derivatives(x: np.ndarray, dt: float | None) -> tuple[np.ndarray, np.ndarray]:
    """First and second time derivatives along axis 0 (zeros when static)."""
    if dt is None or len(x) < 3:
        return np.zeros_like(x), np.zeros_like(x)
    v = np.gradient(x, dt, axis=0, edge_order=2)
    return v, np.gradient(v, dt, axis=0, edge_order=2)


def link_loads(
    arm: FlexArm,
    frames: np.ndarray,
    dt: float | None = None,
    payload_kg: float = 0.0,
    payload_com_mm: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Gravity plus d'Alembert loads of every link, at its centre of mass, base frame.

    Parameters
    ----------
    frames : ndarray, shape (N, n+1, 4, 4)
        base2frame_i at each sample (mm).
    dt : float, optional
        Sample spacing (s) of a trajectory; ``None`` for static poses (no inertia).
    payload_kg, payload_com_mm
        A point mass at ``payload_com_mm`` in the hand frame, added to link n.

    Returns
    -------
    com : ndarray, shape (N, n, 3)
        Centres of mass (mm, base frame).
    force : ndarray, shape (N, n, 3)
        Load on each link (N).
    moment : ndarray, shape (N, n, 3)
        Load moment about each centre of mass (N mm).
    """
    mass = np.array(arm.mass_kg, dtype=float)
    com_local = np.array(arm.com_mm, dtype=float)
    inertia = np.array(arm.inertia_kg_mm2, dtype=float)
    if payload_kg:
        # Lump the payload into link n (parallel-axis term for its inertia).
        p = np.zeros(3) if payload_com_mm is None else np.asarray(payload_com_mm, dtype=float)
        total = mass[-1] + payload_kg
        c = (mass[-1] * com_local[-1] + payload_kg * p) / total
        r1, r2 = com_local[-1] - c, p - c
        shift = mass[-1] * (r1 @ r1 * np.eye(3) - np.outer(r1, r1))
        shift += payload_kg * (r2 @ r2 * np.eye(3) - np.outer(r2, r2))
        mass, com_local, inertia = mass.copy(), com_local.copy(), inertia.copy()
        mass[-1], com_local[-1], inertia[-1] = total, c, inertia[-1] + shift
    rot = frames[:, 1:, :3, :3]
    com = np.einsum("tnij,nj->tni", rot, com_local) + frames[:, 1:, :3, 3]
    gravity = np.array([0.0, 0.0, -GRAVITY_MM_S2])
    _, acc = _time_derivatives(com, dt)
    # kg * mm/s^2 = 1e-3 N
    force = 1e-3 * mass[:, None] * (gravity - acc)
    moment = np.zeros_like(force)
    if dt is not None and len(frames) >= 3:
        rdot, _ = _time_derivatives(rot, dt)
        omega_hat = rdot @ np.swapaxes(rot, -1, -2)
        omega = np.stack(
            [omega_hat[..., 2, 1], omega_hat[..., 0, 2], omega_hat[..., 1, 0]], axis=-1
        )
        _, alpha = _time_derivatives(omega, dt)
        world_inertia = rot @ inertia @ np.swapaxes(rot, -1, -2)
        h = np.einsum("tnij,tnj->tni", world_inertia, omega)
        # kg mm^2 / s^2 = 1e-3 N mm
        moment = -1e-3 * (np.einsum("tnij,tnj->tni", world_inertia, alpha) + np.cross(omega, h))
    return com, force, moment


def deflect(
    arm: FlexArm,
    q: np.ndarray,
    dt: float | None = None,
    payload_kg: float = 0.0,
    payload_com_mm: np.ndarray | None = None,
) -> Deflection:
    """Hand deformation at poses (static) or along a sampled trajectory.

    Parameters
    ----------
    arm : FlexArm
    q : ndarray, shape (N, n)
        Joint coordinates (rad, or mm for prismatic joints).
    dt : float, optional
        Time between consecutive rows of ``q`` (s); adds inertia loads.
    payload_kg, payload_com_mm
        Point payload at the hand (kg; mm in the hand frame).

    Returns
    -------
    Deflection
    """
    q = np.atleast_2d(np.asarray(q, dtype=float))
    frames = arm.frames(q)
    com, force, moment = link_loads(arm, frames, dt, payload_kg, payload_com_mm)
    origins = frames[:, :, :3, 3]
    hand_rot = frames[:, -1, :3, :3]
    hand_p = origins[:, -1]
    total_rot = np.zeros((len(q), 3))
    total_disp = np.zeros((len(q), 3))
    links = {}
    for i, section in sorted(arm.sections.items()):
        root, tip = origins[:, i - 1], origins[:, i]
        span = tip - root
        length = np.linalg.norm(span, axis=-1)
        if np.any(length < 1e-9):
            raise CalibrationError(f"link {i} has no length between its joint frames")
        u = span / length[:, None]
        # Everything beyond link i, reduced to its tip.
        f_out = force[:, i:].sum(axis=1)
        m_out = (np.cross(com[:, i:] - tip[:, None], force[:, i:]) + moment[:, i:]).sum(axis=1)
        # Its own load: spread along it, plus the centre of mass's offset moment.
        own_f, own_c = force[:, i - 1], com[:, i - 1]
        station = np.clip(np.sum((own_c - root) * u, axis=-1), 0.0, length)
        on_axis = root + station[:, None] * u
        own_m = np.cross(own_c - on_axis, own_f) + moment[:, i - 1]
        rot, disp = cantilever_tip(u, length, section, f_out, m_out, own_f, station, own_m)
        hand_disp = disp + np.cross(rot, hand_p - tip)
        to_hand = np.swapaxes(hand_rot, -1, -2)
        share_rot = np.einsum("tij,tj->ti", to_hand, rot)
        share_disp = np.einsum("tij,tj->ti", to_hand, hand_disp)
        links[i] = {
            "tip_rot_rad": rot,
            "tip_mm": disp,
            "hand_rot_rad": share_rot,
            "hand_mm": share_disp,
        }
        total_rot += share_rot
        total_disp += share_disp
    return Deflection(total_rot, total_disp, links)


# --- trajectories ---------------------------------------------------------------


def trapezoid(
    start: np.ndarray, end: np.ndarray, duration_s: float, samples: int, ramp: float = 0.25
) -> tuple[np.ndarray, float]:
    """Joint path with a trapezoidal velocity law (same timing on every joint).

    Parameters
    ----------
    start, end : ndarray, shape (n,)
    duration_s : float
    samples : int
        Number of samples, including both ends (>= 3).
    ramp : float
        Fraction of the duration spent accelerating (and again decelerating),
        in (0, 0.5].

    Returns
    -------
    q : ndarray, shape (samples, n)
    dt : float
        Time between samples (s).
    """
    if not (0 < ramp <= 0.5) or samples < 3 or not duration_s > 0:
        raise CalibrationError("trajectory needs duration > 0, >= 3 samples, 0 < ramp <= 0.5")
    tau = np.linspace(0.0, 1.0, samples)
    # Normalised position s(tau) of a trapezoid with peak speed 1 / (1 - ramp).
    vmax = 1.0 / (1.0 - ramp)
    acc = vmax / ramp
    s = np.where(
        tau < ramp,
        0.5 * acc * tau**2,
        np.where(
            tau <= 1 - ramp,
            0.5 * acc * ramp**2 + vmax * (tau - ramp),
            1.0 - 0.5 * acc * (1.0 - tau) ** 2,
        ),
    )
    start, end = np.asarray(start, dtype=float), np.asarray(end, dtype=float)
    return start + s[:, None] * (end - start), duration_s / (samples - 1)


# --- arms ----------------------------------------------------------------------


def standard_dh_frames(table: np.ndarray, prismatic: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Standard-DH frames, the deflection paper's ``M_i = Rz(theta) Tz(s) Tx(h) Rx(alpha)``.

    The model's own forward kinematics (:func:`calibrator.model.kinematics.chain`)
    of the table converted to MDH (:func:`calibrator.model.conventions.standard_dh_to_mdh`);
    a sliding joint's coordinate goes into its table's ``s``, so each pose has
    its own table.

    Parameters
    ----------
    table : ndarray, shape (n, 4), n <= 6
        Rows ``[theta_offset (rad), s (mm), h (mm), alpha (rad)]``.
    prismatic : ndarray of bool, shape (n,)
        Joints whose coordinate adds to ``s`` (mm) instead of ``theta`` (rad).
    q : ndarray, shape (N, n)

    Returns
    -------
    ndarray, shape (N, n+1, 4, 4)
        Base to frame i (mm); index 0 the base.
    """
    q = np.atleast_2d(np.asarray(q, dtype=float))
    n = len(table)
    posed = np.repeat(np.asarray(table, dtype=float)[np.newaxis], len(q), axis=0)
    posed[..., 0] += np.where(prismatic, 0.0, q)
    posed[..., 1] += np.where(prismatic, q, 0.0)
    mdh = conventions.standard_dh_to_mdh(posed)
    _, frames = kinematics.chain(mdh, np.zeros((1, 6)), all_frames=True)
    return frames[:, 0, : n + 1]


_DEG = np.pi / 180.0

#: The deflection paper's example (Chen and Zhang's arm): its data live in
#: :mod:`calibrator.robots.deflection_paper`, which says how the table was read.
#: Rows ``[theta_offset, s, h, alpha]`` (rad, mm).
PAPER_TABLE = deflection_paper.TABLE
PAPER_PRISMATIC = deflection_paper.PRISMATIC
#: The deflection paper's mass table: masses (kg, link 5 includes the 5 kg workpiece),
#: centres of mass (mm) and principal inertias (kg m^2).
PAPER_MASS_KG = deflection_paper.MASS_KG
PAPER_COM_MM = deflection_paper.COM_MM
PAPER_INERTIA_KG_M2 = deflection_paper.INERTIA_KG_M2
#: Link 3, the piston rod: hollow steel, E = 2.1e11 Pa, D = 0.05 m, d = 0.03 m.
PAPER_ROD = Section(
    outer_mm=deflection_paper.ROD_OUTER_MM,
    inner_mm=deflection_paper.ROD_INNER_MM,
    e_mpa=deflection_paper.ROD_E_MPA,
)
#: The deflection paper's task: the hand's origin on a straight line while x5 turns from 0
#: to 45 deg with theta_1, in 1 s.
PAPER_DURATION_S = deflection_paper.DURATION_S
_PAPER_LINE_X_MM = deflection_paper.LINE_X_MM
#: Joint ranges taken for the example (rad; joint 3 in mm): the text gives
#: none, so half a turn either way for the revolute joints and the rod out
#: between 0 and 1,500 mm (2.5 times its 600 mm at the task's end).
PAPER_LIMITS = np.array(
    [[-np.pi, np.pi], [-np.pi, np.pi], [0.0, 1500.0], [-np.pi, np.pi], [-np.pi, np.pi]]
)


def paper_arm() -> FlexArm:
    """The deflection paper's five-axis example, link 3 (the rod) flexible, the others rigid."""
    return FlexArm(
        name=deflection_paper.TITLE,
        frames=lambda q: standard_dh_frames(PAPER_TABLE, PAPER_PRISMATIC, q),
        mass_kg=PAPER_MASS_KG,
        com_mm=PAPER_COM_MM,
        inertia_kg_mm2=np.array([np.diag(v) for v in PAPER_INERTIA_KG_M2]) * 1e6,
        sections={deflection_paper.ROD_LINK: PAPER_ROD},
    )


def paper_trajectory(samples: int = 201, ramp: float = 0.25) -> tuple[np.ndarray, float]:
    """The deflection paper's task: theta_1 0 -> 45 deg in 1 s (trapezoidal law), hand on a line.

    The paper's own velocity law is in its Fig. 6, missing from the text; a
    trapezoid with ``ramp`` of the time accelerating and decelerating stands in.
    Joint 3 follows ``s3 = x / cos(theta_1)`` so the hand's origin stays on the
    line; joints 2, 4, 5 stay at zero (z5 keeps its direction, x5 turns with theta_1).

    Returns
    -------
    q : ndarray, shape (samples, 5)
        Joint coordinates (rad; joint 3 in mm).
    dt : float
    """
    theta, dt = trapezoid(np.zeros(1), np.array([45 * _DEG]), PAPER_DURATION_S, samples, ramp)
    q = np.zeros((samples, 5))
    q[:, 0] = theta[:, 0]
    q[:, 2] = _PAPER_LINE_X_MM / np.cos(theta[:, 0])
    return q, dt


def named_arm(model: str, sections: dict[int, Section], masses: object = None) -> FlexArm:
    """A named model (MDH table of :mod:`calibrator.robots`) with flexible links.

    Parameters
    ----------
    model : str
        A name known to :func:`calibrator.robots.get`.
    sections : dict of int to Section
        Flexible links (1..6).
    masses : MassModel, optional
        Defaults to the model's published mass model.
    """
    from calibrator import robots
    from calibrator.robots import masses as arm_masses

    m = robots.get(model)
    mm = arm_masses.get(m.name) if masses is None else masses
    mdh = np.array(m.mdh)

    def frames(q: np.ndarray) -> np.ndarray:
        return kinematics.chain(mdh, q, all_frames=True)[1]

    return FlexArm(
        name=m.name,
        frames=frames,
        mass_kg=np.array(mm.mass_kg),  # type: ignore[attr-defined]
        com_mm=np.array(mm.com_mm),  # type: ignore[attr-defined]
        inertia_kg_mm2=np.zeros((6, 3, 3)),
        sections=dict(sections),
    )


def load_sections(path: object) -> tuple[dict[int, Section], str | None]:
    """Read a link-section YAML file.

    Format::

        mass_model: ur10e        # optional: a named arm or a mass-model YAML path
        links:
          2: {outer_mm: 120, inner_mm: 100, e_mpa: 70000}   # aluminium tube
          3: {outer_mm: 90, inner_mm: 74, e_mpa: 70000, poisson: 0.33}

    Returns
    -------
    sections : dict of int to Section
    mass_model : str or None
    """
    from pathlib import Path

    from calibrator.inputs import yamlfile

    path = Path(str(path))
    doc = yamlfile.read(path, "a link-section file", 2**20)
    links = doc.get("links") if isinstance(doc, dict) else None
    if not isinstance(links, dict) or not links:
        raise CalibrationError(f"{path}: needs a 'links' mapping, link number -> section")
    sections = {}
    for key, spec in links.items():
        if not (type(key) is int and 1 <= key <= 6 and isinstance(spec, dict)):
            raise CalibrationError(f"{path}: link {shown(key)}: keys are link numbers 1..6")
        unknown = set(spec) - {"outer_mm", "inner_mm", "e_mpa", "poisson"}
        if unknown or "outer_mm" not in spec:
            raise CalibrationError(
                f"{path}: link {key}: needs outer_mm, may give inner_mm, e_mpa, poisson"
                + (f"; unknown {', '.join(sorted(map(shown, unknown))[:5])}" if unknown else "")
            )
        try:
            sections[key] = Section(**{k: SECTION_RULES[k].check(v, k) for k, v in spec.items()})
        except CalibrationError as exc:
            raise CalibrationError(f"{path}: link {key}: {exc}") from None
    model = doc.get("mass_model")
    if model is not None and not isinstance(model, str):
        raise CalibrationError(f"{path}: mass_model must be a named arm or a YAML path (text)")
    return sections, model
