"""Link masses and centres of mass of an arm, for gravity torques and deflection.

A :class:`MassModel` gives, for each link ``i`` (1..6), its mass and the
position of its centre of mass in link frame ``i``, the frame at the end of
``A_1 ... A_i`` in :func:`calibrator.kinematics.chain` (for the UR arms,
whose tables are standard DH, this is exactly the manufacturer's DH frame).

Sources
-------
``ur5e``, ``ur10e``, ``ur10``
    Universal Robots' published "DH parameters for calculations of
    kinematics and dynamics" tables (mass and centre of mass per link, in the
    DH frame of the link). No inertia tensors are published there; they are
    zero here (only gravity uses them in this project).
Other arms (``er10l-c10`` has no published mass data)
    A YAML file read by :func:`load`::

        links:
          - {mass_kg: 7.4, com_mm: [21, 0, 27]}
          ... six entries, com in link frame i (mm)
"""

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from calibrator.errors import CalibrationError
from calibrator.strict import Rule

#: Standard gravity, mm/s^2.
GRAVITY_MM_S2 = 9810.0
#: What a link of a mass-model file may be: a robot link, not 1e308 kg (its
#: torques overflow to nan) nor a string read as a number.
LINK_RULES = {
    "mass_kg": Rule("mass_kg", float, 0.0, 2_000.0, unit="kg", meaning="mass of a link"),
    "com_mm": Rule("com_mm", tuple, high=5_000.0, unit="mm", meaning="centre of mass, link frame"),
}


@dataclass(frozen=True)
class MassModel:
    """Masses and centres of mass of the six links.

    Attributes
    ----------
    name : str
    mass_kg : ndarray, shape (6,)
    com_mm : ndarray, shape (6, 3)
        Centre of mass of link ``i`` in link frame ``i`` (mm).
    """

    name: str
    mass_kg: np.ndarray
    com_mm: np.ndarray

    def __post_init__(self) -> None:
        mass = np.array(self.mass_kg, dtype=float)
        com = np.array(self.com_mm, dtype=float)
        if mass.shape != (6,) or com.shape != (6, 3):
            raise CalibrationError(
                f"mass model {self.name}: needs 6 masses and 6 centres of mass (x, y, z mm)"
            )
        if not (np.all(np.isfinite(mass)) and np.all(np.isfinite(com))) or np.any(mass < 0):
            raise CalibrationError(
                f"mass model {self.name}: masses must be finite and >= 0, centres finite"
            )
        for field, value in (("mass_kg", mass), ("com_mm", com)):
            value.setflags(write=False)
            object.__setattr__(self, field, value)


# UR publishes the same centres of mass for the UR10 and the UR10e (m, DH frame of the link).
_UR10_COM_M = [
    [0.021, 0.0, 0.027],
    [0.38, 0.0, 0.158],
    [0.24, 0.0, 0.068],
    [0.0, 0.007, 0.018],
    [0.0, 0.007, 0.018],
    [0.0, 0.0, -0.026],
]

# Universal Robots' published tables (kg; centre of mass in m, DH frame of the link).
_UR_PUBLISHED = {
    "ur5e": (
        [3.761, 8.058, 2.846, 1.37, 1.3, 0.365],
        [
            [0.0, -0.02561, 0.00193],
            [0.2125, 0.0, 0.11336],
            [0.15, 0.0, 0.0265],
            [0.0, -0.0018, 0.01634],
            [0.0, 0.0018, 0.01634],
            [0.0, 0.0, -0.001159],
        ],
    ),
    "ur10e": (
        [7.369, 13.051, 3.989, 2.1, 1.98, 0.615],
        _UR10_COM_M,
    ),
    "ur10": (
        [7.1, 12.7, 4.27, 2.0, 2.0, 0.365],
        _UR10_COM_M,
    ),
}

#: Named arms that carry a published mass model.
NAMES = tuple(sorted(_UR_PUBLISHED))


def get(name: str) -> MassModel:
    """The published mass model of a named arm.

    Raises
    ------
    CalibrationError
        If the arm has no published mass model (give a YAML file instead).
    """
    key = str(name).strip().lower()
    if key not in _UR_PUBLISHED:
        raise CalibrationError(
            f"no published mass model for {name!r} (known: {', '.join(NAMES)}); "
            "give a mass-model YAML file"
        )
    mass, com_m = _UR_PUBLISHED[key]
    return MassModel(key, np.array(mass), np.array(com_m) * 1000.0)


def load(path: Path | str) -> MassModel:
    """Read a mass-model YAML file (see the module docstring).

    Raises
    ------
    CalibrationError
        Naming the file and what is wrong in it.
    """
    from calibrator import yamlfile

    path = Path(path)
    doc = yamlfile.read(path, "a mass-model file", 2**20)
    links = doc.get("links") if isinstance(doc, dict) else None
    if not isinstance(links, list) or len(links) != 6:
        raise CalibrationError(f"{path}: needs a 'links' list of 6 entries")
    mass, com = [], []
    for i, link in enumerate(links):
        if not isinstance(link, dict) or set(link) != {"mass_kg", "com_mm"}:
            raise CalibrationError(
                f"{path}: link {i + 1} needs exactly mass_kg (number) and com_mm ([x, y, z] mm)"
            )
        mass.append(LINK_RULES["mass_kg"].check(link["mass_kg"], f"{path}: link {i + 1} mass_kg"))
        com.append(LINK_RULES["com_mm"].check(link["com_mm"], f"{path}: link {i + 1} com_mm"))
    try:
        return MassModel(path.name, np.array(mass), np.array(com))
    except CalibrationError as exc:
        raise CalibrationError(f"{path}: {exc}") from None


def resolve(source: str | Path) -> MassModel:
    """A named arm's published model, or the YAML file at ``source``."""
    text = str(source)
    if text.lower().endswith((".yaml", ".yml")):
        return load(text)
    return get(text)
