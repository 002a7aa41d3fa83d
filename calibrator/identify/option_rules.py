"""What each option of ``identify`` may be: one table for the CLI, provenance and ``--like``.

Every option that changes an identification is declared here once, as a
:class:`calibrator.inputs.rules.Rule` (type, bounds, budget, meaning, flag). The
same rule checks

- the value typed on the command line (a typer callback,
  :func:`calibrator.cli._checks.rule`),
- the value :class:`calibrator.identify.pipeline.Options` is given
  (:func:`check_settings`),
- the value recorded in a calibration file and re-used by
  ``identify --like`` (:meth:`calibrator.calibration.Provenance.checked_options`),

so a hand-edited ``generations: 1000000000`` is refused in one line exactly
as ``--generations 1000000000`` is. The recorded key of each rule is a field
of :class:`calibrator.calibration.Provenance`.

Use::

    from calibrator.identify import option_rules

    option_rules.RULES["particles"].check(-5, "cal.json: particles")  # StrictError
    option_rules.PIPELINE        # keys of the pipeline's options, in file order
    option_rules.JOINT           # keys of the joint-term options
"""

from __future__ import annotations

from calibrator.errors import CalibrationError
from calibrator.inputs.grammar import MAX_INT
from calibrator.inputs.rules import Rule
from calibrator.model import joint_terms

__all__ = ["JOINT", "LOSSES", "METHODS", "PIPELINE", "RULES", "check_settings"]

METHODS = ("hybrid", "pso", "lm")
LOSSES = ("lsq", "huber", "trimmed", "minimax")
#: Largest session identify takes (poses): also the most the swarm can see.
MAX_POSES = 50_000


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


_TABLE = (
    Rule("method", str, choices=METHODS, flag="--method", group="pipeline",
         meaning="fitter: swarm then least squares, swarm only, or least squares only"),
    Rule("loss", str, choices=LOSSES, flag="--loss", group="pipeline",
         meaning="loss of the fit"),
    Rule("seed", int, 0, MAX_INT, flag="--seed", group="pipeline",
         meaning="seed of the hold-out split and the swarm"),
    Rule("validation_fraction", float, 0.0, 1.0, open_high=True, flag="--validation-fraction",
         group="pipeline", meaning="share of the poses held out for checking"),
    Rule("k", float, 0.0, 1e12, unit="mm^2/rad^2", flag="--orientation-weight",
         group="pipeline", meaning="weight of orientation errors"),
    # Far below any instrument (1e-300 mm) the information matrix overflows its eigensolver.
    Rule("noise_mm", float, 1e-9, 100.0, unit="mm", flag="--noise-mm", group="pipeline",
         meaning="measurement noise assumed when choosing the free parameters"),
    Rule("tool_known", bool, flag="--tool-known", group="pipeline",
         meaning="tool frame fixed (true) or identified (false)"),
    Rule("particles", int, 2, 1_000, unit="particles", flag="--particles", group="pipeline",
         meaning="swarm size; the swarm holds particles x parameters"),
    Rule("generations", int, 0, 100_000, unit="generations", flag="--generations",
         group="pipeline", meaning="swarm generations (2,000 of 20 particles take seconds)"),
    Rule("swarm_poses", int, 1, MAX_POSES, unit="poses", group="pipeline",
         meaning="most fitting poses the swarm sees"),
    Rule("joint_term_groups", str, parse=_groups, flag="--joint-terms", group="joint",
         meaning="joint terms asked for: any of scale,harmonic,compliance"),
    Rule("mass_model", str, parse=_mass_model, flag="--mass-model", group="joint",
         meaning="mass model for compliance: a named arm or a YAML file"),
    # Declared with the joint terms, whose files hold them too.
    joint_terms.PAYLOAD_KG,
    joint_terms.PAYLOAD_COM_MM,
)  # fmt: skip

#: Rule of each option, by its recorded key.
RULES: dict[str, Rule] = {rule.key: rule for rule in _TABLE}
#: Keys of the options that decide the identified parameters.
PIPELINE = tuple(rule.key for rule in _TABLE if rule.group == "pipeline")
#: Keys of the joint-term options (``--joint-terms`` and its companions).
JOINT = tuple(rule.key for rule in _TABLE if rule.group == "joint")


def check_settings(settings: object, keys: tuple[str, ...] = PIPELINE) -> None:
    """Check the attributes ``keys`` of ``settings`` against their rules.

    Raises
    ------
    calibrator.inputs.errors.StrictError
        Naming the option: ``particles: must be a whole number >= 2, got -5``.
    """
    for key in keys:
        RULES[key].check(getattr(settings, key), key)
