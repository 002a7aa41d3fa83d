"""Link masses and centres of mass of an arm, for gravity torques and deflection.

A :class:`MassModel` gives, for each link ``i`` (1..6), its mass and the
position of its centre of mass in link frame ``i``, the frame at the end of
``A_1 ... A_i`` in :func:`calibrator.model.kinematics.chain` (for the UR arms,
whose tables are standard DH, this is exactly the manufacturer's DH frame).

Sources
-------
Named arms
    The masses of the arm's description, looked up by
    :mod:`calibrator.robots.masses` (each robot module names its source). No
    inertia tensors: only gravity uses them.
Other arms (those whose description has no masses)
    A YAML file read by :func:`load`::

        links:
          - {mass_kg: 7.4, com_mm: [21, 0, 27]}
          ... six entries, com in link frame i (mm)
"""

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from calibrator.errors import CalibrationError
from calibrator.inputs.rules import Rule

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


def load(path: Path | str) -> MassModel:
    """Read a mass-model YAML file (see the module docstring).

    Raises
    ------
    CalibrationError
        Naming the file and what is wrong in it.
    """
    from calibrator.inputs import yamlfile

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
