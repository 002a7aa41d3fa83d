"""The masses of an arm by name: its robot description's, or a mass-model YAML file.

The :class:`~calibrator.model.mass_models.MassModel` type and its file reader
are in the model; looking an arm up by name is here, beside the descriptions.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from calibrator import robots
from calibrator.errors import CalibrationError
from calibrator.model.mass_models import MassModel, load

if TYPE_CHECKING:
    from calibrator.model.joint_terms import JointTerms


def names() -> tuple[str, ...]:
    """Named arms whose description carries masses."""
    return tuple(n for n in robots.names() if robots.get(n).has_masses)


def get(name: str) -> MassModel:
    """The published mass model of a named arm (from its robot description).

    Raises
    ------
    CalibrationError
        If the arm has no published mass model (give a YAML file instead).
    """
    try:
        description = robots.get(name)
    except robots.DescriptionError:
        description = None
    if description is None or description.mass_kg is None or description.com_mm is None:
        raise CalibrationError(
            f"no published mass model for {name!r} (known: {', '.join(names())}); "
            "give a mass-model YAML file"
        )
    return MassModel(description.name, description.mass_kg, description.com_mm)


def resolve(source: str | Path) -> MassModel:
    """A named arm's masses, a robot description's, or the mass-model YAML at ``source``."""
    text = str(source)
    if text.lower().endswith((".yaml", ".yml")) and not robots.files.is_description(text):
        return load(text)
    return get(text)


def for_terms(terms: JointTerms) -> MassModel | None:
    """The masses joint terms' compliance needs (None when they have no compliance)."""
    if not terms.needs_torque:
        return None
    if not terms.mass_model:
        raise CalibrationError("the compliance terms name no mass model")
    return resolve(terms.mass_model)
