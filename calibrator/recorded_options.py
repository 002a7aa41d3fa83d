"""identify's options, each declared once: its default, its rule and its meaning.

:class:`Options` (the pipeline's settings) and :class:`JointTermOptions`
(the joint terms asked for and their payload) are the only declaration of
each option of ``calibrator identify``. A field's default is the command's
default; its :class:`calibrator.inputs.rules.Rule` (type, bounds, budget,
meaning, flag) checks

- the value typed on the command line (a typer callback,
  :func:`calibrator.cli._checks.rule`, whose default is the field's),
- the value a script hands to :func:`calibrator.identify.pipeline.identify`
  (:meth:`Options.check`),
- the value recorded in a calibration file and re-used by ``identify
  --like`` (:meth:`Options.like`),

so a hand-edited ``generations: 1000000000`` is refused in one line exactly
as ``--generations 1000000000`` is. A calibration's
:class:`calibrator.calibration.Provenance` nests both records; their field
names are the keys of calibration.json. The module sits beside the
documents that record the options, below ``identify``, which reads it too.

Use::

    from calibrator.recorded_options import Options, RULES

    Options(particles=-5).check()            # StrictError: particles: must be ...
    Options.like({"seed": 3, "loss": "huber"}, {"seed": 4})   # loss huber, seed 4
    RULES["particles"].bounds                # '2..1000 particles'
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, fields, replace
from typing import Any, Self

from calibrator.errors import CalibrationError
from calibrator.inputs.grammar import MAX_INT
from calibrator.inputs.rules import Rule
from calibrator.model import joint_terms

__all__ = [
    "JOINT",
    "LOSSES",
    "METHODS",
    "PIPELINE",
    "RULES",
    "JointTermOptions",
    "Options",
]

METHODS = ("hybrid", "pso", "lm")
LOSSES = ("lsq", "huber", "trimmed", "minimax")
#: Largest session identify takes (poses): also the most the swarm can see.
MAX_POSES = 50_000
#: Orientation weight (mm^2/rad^2) when none is given and the session has
#: orientations: 1 mrad weighs as 0.1 mm, about the ratio of a 6-DoF probe's
#: angular noise to a tracker's point noise.
DEFAULT_K = 1.0e4


def _option(default: Any, rule: Rule) -> Any:
    """A field with its default and its rule (``rule.key`` is the field's name)."""
    return field(default=default, metadata={"rule": rule})


def _groups(text: str) -> str:
    if text:  # "" is recorded when no joint terms were asked for
        try:
            joint_terms.parse_groups(text)
        except CalibrationError as exc:
            raise CalibrationError(str(exc).removeprefix("--joint-terms: ")) from None
    return text


def _mass_model(text: str) -> str:
    """A named arm with a published mass model, or a mass-model YAML that reads."""
    from calibrator.model import mass_models
    from calibrator.robots import masses

    if text.strip().lower() in masses.names():
        return text
    if text.lower().endswith((".yaml", ".yml")):
        mass_models.load(text)
        return text
    raise CalibrationError(
        f"{text!r:.60} is neither a named arm ({', '.join(masses.names())}) "
        "nor a mass-model YAML file (.yaml)"
    )


class _Declared:
    """What both option records share: their rules, a check, and ``like``."""

    @classmethod
    def rules(cls) -> dict[str, Rule]:
        """The rule of each field, by its name (the key calibration.json records)."""
        return {f.name: f.metadata["rule"] for f in fields(cls)}  # type: ignore[arg-type]

    def recorded(self) -> dict[str, Any]:
        """``{key: value}`` as calibration.json records it (``None`` left out)."""
        out = {}
        for key, rule in self.rules().items():
            value = getattr(self, key)
            if value is not None:
                out[key] = _to_record(rule, value)
        return out

    @classmethod
    def from_record(cls, values: Mapping[str, Any]) -> Self:
        """The record of ``values`` (keys of calibration.json; missing ones: defaults).

        Values are taken as they are (a file's JSON types are checked by its
        reader); :meth:`check` applies the rules.
        """
        rules = cls.rules()
        return cls(**{k: _from_record(rules[k], v) for k, v in values.items() if k in rules})

    def check(self, where: str = "") -> None:
        """Check every field against its rule.

        Raises
        ------
        calibrator.inputs.errors.StrictError
            Naming the option: ``particles: must be a whole number >= 2, got -5``.
        """
        for key, rule in self.rules().items():
            value = getattr(self, key)
            rule.check(_to_record(rule, value), f"{where}: {key}" if where else key)

    @classmethod
    def like(cls, recorded: Mapping[str, Any], given: Mapping[str, Any], where: str = "") -> Self:
        """The options of a re-run: each one given wins, else the recorded one, else the default.

        What ``identify --like CALIBRATION`` does, for scripts as for the command.

        Parameters
        ----------
        recorded : mapping
            What a calibration records, ``{key: value}`` as in calibration.json
            (:meth:`calibrator.calibration.Provenance.recorded`); other keys
            are ignored.
        given : mapping
            The options set explicitly (field values, ``{key: value}``).
        where : str
            Names the record in messages (``"--like cal.json"``).

        Raises
        ------
        calibrator.inputs.errors.StrictError
            A recorded value its rule refuses (one that is given is not checked here).
        """
        rules = cls.rules()
        taken = {}
        for key, value in recorded.items():
            if key in rules and key not in given and value is not None:
                rule = rules[key]
                checked = rule.check(value, f"{where}: {key}" if where else key)
                taken[key] = _from_record(rule, checked)
        return cls(**{**taken, **{k: v for k, v in given.items() if k in rules}})

    def normalised(self) -> Self:
        """The same options with each number of its rule's type (an int seed, a float k)."""
        out = {}
        for key, rule in self.rules().items():
            value = getattr(self, key)
            if value is not None and rule.kind in (int, float, bool):
                out[key] = rule.kind(value)
        return replace(self, **out)  # type: ignore[type-var]


def _to_record(rule: Rule, value: Any) -> Any:
    if rule.key == "joint_term_groups":
        return ",".join(value)
    if rule.kind is tuple and isinstance(value, tuple):
        return list(value)
    return value


def _from_record(rule: Rule, value: Any) -> Any:
    if rule.key == "joint_term_groups" and isinstance(value, str):
        # Split, not parsed: a recorded "bogus" is refused by the rule, in one line.
        return tuple(value.split(",")) if value else ()
    if rule.kind is tuple and isinstance(value, list):
        return tuple(value)
    return value


@dataclass(frozen=True, kw_only=True)
class Options(_Declared):
    """Settings of one identification (the options of ``calibrator identify``).

    Each field holds its default and, in its metadata, its rule
    (:meth:`rules`); the order of the fields is the order calibration.json
    records them in.

    Attributes
    ----------
    method : {'hybrid', 'pso', 'lm'}
        Swarm then least squares, swarm only, or least squares only.
    loss : {'lsq', 'huber', 'trimmed', 'minimax'}
    seed : int
        Seed of the hold-out split and the swarm.
    validation_fraction : float
        Share of the poses held out, in [0, 1).
    k : float or None
        Orientation weight (mm^2/rad^2); ``None``: :data:`DEFAULT_K` with
        orientation data (0 without). Recorded resolved.
    noise_mm : float
        Measurement noise assumed when deciding what these poses can identify
        (one residual row, mm; orientation rows count in ``sqrt(k)`` units).
    tool_known : bool or None
        Tool frame fixed or identified; ``None``: as the session says.
        Recorded resolved.
    particles, generations : int
        Swarm size and generations.
    swarm_poses : int
        Most fitting poses the swarm sees.
    """

    # fmt: off
    method: str = _option("hybrid", Rule(
        "method", str, choices=METHODS, flag="--method", group="pipeline",
        meaning="fitter: swarm then least squares, swarm only, or least squares only"))
    loss: str = _option("lsq", Rule(
        "loss", str, choices=LOSSES, flag="--loss", group="pipeline", meaning="loss of the fit"))
    seed: int = _option(0, Rule(
        "seed", int, 0, MAX_INT, flag="--seed", group="pipeline",
        meaning="seed of the hold-out split and the swarm"))
    validation_fraction: float = _option(0.2, Rule(
        "validation_fraction", float, 0.0, 1.0, open_high=True, flag="--validation-fraction",
        group="pipeline", meaning="share of the poses held out for checking"))
    k: float | None = _option(None, Rule(
        "k", float, 0.0, 1e12, unit="mm^2/rad^2", flag="--orientation-weight",
        group="pipeline", meaning="weight of orientation errors"))
    # Far below any instrument (1e-300 mm) the information matrix overflows its eigensolver.
    noise_mm: float = _option(0.05, Rule(
        "noise_mm", float, 1e-9, 100.0, unit="mm", flag="--noise-mm", group="pipeline",
        meaning="measurement noise assumed when choosing the free parameters"))
    tool_known: bool | None = _option(None, Rule(
        "tool_known", bool, flag="--tool-known", group="pipeline",
        meaning="tool frame fixed (true) or identified (false)"))
    particles: int = _option(20, Rule(
        "particles", int, 2, 1_000, unit="particles", flag="--particles", group="pipeline",
        meaning="swarm size; the swarm holds particles x parameters"))
    generations: int = _option(2000, Rule(
        "generations", int, 0, 100_000, unit="generations", flag="--generations",
        group="pipeline", meaning="swarm generations (2,000 of 20 particles take seconds)"))
    swarm_poses: int = _option(32, Rule(
        "swarm_poses", int, 1, MAX_POSES, unit="poses", group="pipeline",
        meaning="most fitting poses the swarm sees"))
    # fmt: on


@dataclass(frozen=True, kw_only=True)
class JointTermOptions(_Declared):
    """The joint terms asked for and their payload (``identify --joint-terms`` and companions).

    Attributes
    ----------
    joint_term_groups : tuple of str
        Any of ``scale``, ``harmonic``, ``compliance`` (empty: none);
        recorded comma-separated.
    mass_model : str or None
        A named arm or a mass-model YAML (compliance); ``None``: the model's.
    payload_kg : float or None
        Payload of sessions that record none (kg); ``None``: 0.
    payload_com_mm : tuple of 3 float
        Payload centre of mass in the flange frame (mm).
    """

    # fmt: off
    joint_term_groups: tuple[str, ...] = _option((), Rule(
        "joint_term_groups", str, parse=_groups, flag="--joint-terms", group="joint",
        meaning="joint terms asked for: any of scale,harmonic,compliance"))
    mass_model: str | None = _option(None, Rule(
        "mass_model", str, parse=_mass_model, flag="--mass-model", group="joint",
        meaning="mass model for compliance: a named arm or a YAML file"))
    # Declared with the joint terms, whose files hold them too.
    payload_kg: float | None = _option(None, joint_terms.PAYLOAD_KG)
    payload_com_mm: tuple[float, float, float] = _option(
        (0.0, 0.0, 0.0), joint_terms.PAYLOAD_COM_MM)
    # fmt: on


#: Rule of each option, by its recorded key.
RULES: dict[str, Rule] = {**Options.rules(), **JointTermOptions.rules()}
#: Keys of the options that decide the identified parameters.
PIPELINE = tuple(Options.rules())
#: Keys of the joint-term options (``--joint-terms`` and its companions).
JOINT = tuple(JointTermOptions.rules())
