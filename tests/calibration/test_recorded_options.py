"""identify's options: one table of rules for the command line, provenance and ``--like``."""

import dataclasses
import json

import pytest
import typer.main
from cli_kit import cli, listing, one_line_error
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from calibrator import calibration, recorded_options
from calibrator.cli import _app


@pytest.fixture(scope="module")
def made(tmp_path_factory):
    """A session and the calibration identify wrote from it (least squares: fast)."""
    folder = tmp_path_factory.mktemp("like")
    done = cli("simulate", "--model", "ur10e", "--poses", "30", "-o", "s.parquet", cwd=folder)
    assert done.code == 0, done.stderr
    done = cli("identify", "s.parquet", "--method", "lm", "-o", "cal.json", "-q", cwd=folder)
    assert done.code == 0, done.stderr
    return folder


# Each hand edit the red team made, and what the refusal names.
BAD_RECORDED = [
    ({"generations": 1_000_000_000, "method": "hybrid"}, "generations: 1000000000 generations"),
    ({"particles": -5, "method": "hybrid"}, "particles: must be a whole number >= 2, got -5"),
    ({"particles": 1, "method": "hybrid"}, "particles: must be a whole number >= 2, got 1"),
    ({"seed": -1}, "seed: must be a whole number >= 0, got -1"),
    ({"swarm_poses": 1_000_000_000}, "swarm_poses: 1000000000 poses is more than the limit"),
    ({"payload_kg": -5}, "payload_kg: must be a number >= 0, got -5"),
    ({"payload_kg": 1e308}, "payload_kg: 1e+308 kg is more than the limit of 100 kg"),
    ({"payload_com_mm": [1e308, 0, 0]}, "payload_com_mm: 1e+308 mm is beyond +-2000 mm"),
    ({"mass_model": "/etc/passwd"}, "mass_model: '/etc/passwd' is neither a named arm"),
    ({"noise_mm": 1e300}, "noise_mm: 1e+300 mm is more than the limit of 100 mm"),
    ({"validation_fraction": 1.5}, "validation_fraction: must be in [0, 1), got 1.5"),
    ({"k": -1.0}, "k: must be a number >= 0, got -1"),
    ({"method": "newton"}, "method: 'newton' is not one of 'hybrid', 'pso', 'lm'"),
    ({"joint_term_groups": "bogus"}, "joint_term_groups: unknown term bogus"),
    ({"joint_term_groups": "x" * 5000}, "joint_term_groups: unknown term xxxxxxxxxxxx...x"),
]


@pytest.mark.parametrize(("edit", "says"), BAD_RECORDED)
def test_a_bad_recorded_option_is_refused_as_the_typed_one_is(made, edit, says):
    doc = json.loads((made / "cal.json").read_text())
    doc.update(edit)
    (made / "bad.json").write_text(json.dumps(doc))
    before = listing(made)
    line = one_line_error(
        cli("identify", "s.parquet", "--like", "bad.json", "-o", "out.json", "-q", cwd=made)
    )
    assert line.startswith("calibrator: error: --like bad.json: ")
    assert says in line and len(line) < 200
    assert listing(made) == before  # nothing written


@pytest.mark.parametrize(
    ("args", "says"),
    [
        (["--payload-kg", "1e308"], "--payload-kg: 1e+308 kg is more than the limit of 100 kg"),
        (["--payload-kg", "1000000"], "--payload-kg: 1e+06 kg is more than the limit"),
        (["--payload-com-mm", "0,0,1e7"], "--payload-com-mm: 1e+07 mm is beyond +-2000 mm"),
        (["--mass-model", "/etc/passwd"], "--mass-model: '/etc/passwd' is neither"),
        (["--noise-mm", "1e9"], "--noise-mm: 1e+09 mm is more than the limit of 100 mm"),
    ],
)
def test_the_typed_option_meets_the_same_rule(made, args, says):
    before = listing(made)
    line = one_line_error(cli("identify", "s.parquet", "-o", "out.json", *args, cwd=made))
    assert says in line
    assert listing(made) == before


def test_a_typed_option_overrides_a_bad_recorded_one(made):
    doc = json.loads((made / "cal.json").read_text())
    doc["seed"] = -1
    (made / "bad.json").write_text(json.dumps(doc))
    done = cli(
        "identify", "s.parquet", "--like", "bad.json", "--seed", "4", "-o", "o.json", "-q",
        cwd=made,
    )  # fmt: skip
    assert done.code == 0, done.stderr
    assert json.loads((made / "o.json").read_text())["seed"] == 4
    (made / "o.json").unlink()


def test_every_rule_is_a_field_of_the_options_provenance_nests_and_every_flag_an_option():
    options, joint = recorded_options.Options, recorded_options.JointTermOptions
    names = [f.name for f in dataclasses.fields(options) + dataclasses.fields(joint)]
    assert names == list(recorded_options.RULES)  # one rule per field, in file order
    assert all(f.metadata["rule"].key == f.name for f in dataclasses.fields(options))
    nested = {f.name: f.type for f in dataclasses.fields(calibration.Provenance)}
    assert "Options" in str(nested["options"]) and "JointTermOptions" in str(nested["joint"])
    assert recorded_options.PIPELINE + recorded_options.JOINT == tuple(recorded_options.RULES)
    assert set(recorded_options.RULES) <= set(calibration.Provenance.KEYS)
    command = typer.main.get_command(_app.app).commands["identify"]  # type: ignore[attr-defined]
    flags = {o for p in command.params for o in p.opts}
    for rule in recorded_options.RULES.values():
        assert rule.flag is None or rule.flag in flags, rule.key
        assert rule.meaning
    helps = {o: p.help for p in command.params for o in p.opts}
    for key in ("particles", "generations", "k", "validation_fraction", "noise_mm", "payload_kg"):
        rule = recorded_options.RULES[key]
        assert rule.bounds in " ".join(helps[rule.flag].split()), (key, helps[rule.flag])


def test_the_limits_themselves_pass():
    for key, value in [
        ("particles", 1000),
        ("generations", 100_000),
        ("swarm_poses", 50_000),
        ("payload_kg", 100.0),
        ("payload_com_mm", [2000, -2000, 0]),
        ("mass_model", "UR10e"),
        ("joint_term_groups", ""),
    ]:
        recorded_options.RULES[key].check(value)


# Fuzz: any recorded value is either taken (then its rule passes) or refused in one line.
_VALUES = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-(2**70), 2**70),
    st.floats(allow_nan=False, allow_infinity=False),
    st.sampled_from(["", "lm", "huber", "ur10e", "UR10E", "/etc/passwd", "scale", "x" * 3000]),
    st.lists(st.floats(-1e308, 1e308), max_size=4),
    st.dictionaries(st.text(max_size=3), st.integers(), max_size=2),
)
_KEYS = st.sampled_from([*recorded_options.RULES, "model", "frame", "nominal_source", "created"])


@settings(
    max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(edits=st.dictionaries(_KEYS, _VALUES, min_size=1, max_size=3))
def test_fuzz_recorded_options(made, edits):
    doc = json.loads((made / "cal.json").read_text())
    doc.update(edits)
    if "method" not in edits:
        doc["method"] = "lm"  # keep the runs short; a recorded swarm is fuzzed through "method"
    if doc.get("method") != "lm":
        doc["generations"] = 3
        edits.pop("generations", None)
    (made / "fuzz.json").write_text(json.dumps(doc))
    before = listing(made)
    result = cli("identify", "s.parquet", "--like", "fuzz.json", "-o", "fz.json", "-q", cwd=made)
    if result.code == 2:
        line = one_line_error(result)
        assert len(line) < 300, line
        assert listing(made) == before
        return
    assert result.code == 0, result.stderr
    for key, value in edits.items():
        if key in recorded_options.RULES:
            recorded_options.RULES[key].check(value)  # only what its rule allows was taken
    (made / "fz.json").unlink()


def test_a_recorded_nominal_source_is_one_of_three(made):
    doc = json.loads((made / "cal.json").read_text())
    doc["nominal_source"] = "elsewhere"
    (made / "bad.json").write_text(json.dumps(doc))
    line = one_line_error(
        cli("identify", "s.parquet", "--like", "bad.json", "-o", "out.json", "-q", cwd=made)
    )
    assert "bad.json: 'nominal_source' must be one of session, model, file" in line


# --- the options as a Python API: declared once, --like without the command line ---------


def test_options_like_takes_a_recorded_value_unless_it_is_given():
    recorded = {"seed": 3, "loss": "huber", "particles": -5, "payload_kg": 2.0}
    got = recorded_options.Options.like(recorded, {"particles": 10})
    # The bad recorded particles is not used (given wins); the rest is the file's or the default.
    assert got == recorded_options.Options(seed=3, loss="huber", particles=10)
    with pytest.raises(calibration.CalibrationError, match=r"^cal.json: particles: must be"):
        recorded_options.Options.like(recorded, {}, "cal.json")
    joint = recorded_options.JointTermOptions.like(
        {**recorded, "joint_term_groups": "scale", "payload_com_mm": [1, 2, 3]}, {}
    )
    assert joint == recorded_options.JointTermOptions(
        joint_term_groups=("scale",), payload_kg=2.0, payload_com_mm=(1.0, 2.0, 3.0)
    )


def test_a_script_does_what_like_does_to_the_byte(made, monkeypatch):
    from calibrator.identify.calibrate import recall, run

    monkeypatch.setenv("SOURCE_DATE_EPOCH", "1700000000")  # the one field that differs by nature
    done = cli(
        "identify", "s.parquet", "--like", "cal.json", "--seed", "4", "-o", "by_cli.json", "-q",
        cwd=made,
    )  # fmt: skip
    assert done.code == 0, done.stderr
    monkeypatch.chdir(made)  # the file records the session's path as given
    again = recall("cal.json", "s.parquet", {"seed": 4})
    assert again.options.method == "lm" and again.options.seed == 4 and again.notes == []
    run(
        ["s.parquet"], "by_script.json", again.options, joint=again.joint, model=again.model,
        nominal_file=again.nominal_file,
    )  # fmt: skip
    assert (made / "by_script.json").read_bytes() == (made / "by_cli.json").read_bytes()
    for name in ("by_cli.json", "by_script.json"):
        (made / name).unlink()


def test_the_command_reads_its_defaults_from_the_options():
    command = typer.main.get_command(_app.app).commands["identify"]  # type: ignore[attr-defined]
    defaults = {p.name: p.default for p in command.params}
    ran, joint = recorded_options.Options(), recorded_options.JointTermOptions()
    for name in ("particles", "generations", "validation_fraction", "seed", "noise_mm"):
        assert defaults[name] == getattr(ran, name), name
    assert defaults["method"] == ran.method and defaults["loss"] == ran.loss
    assert defaults["tool_known"] is ran.tool_known is None
    assert defaults["orientation_weight"] is ran.k is None
    assert (defaults["mass_model"], defaults["payload_kg"]) == (joint.mass_model, joint.payload_kg)
    assert tuple(map(float, defaults["payload_com_mm"].split(","))) == joint.payload_com_mm


def test_an_older_file_writes_back_only_what_it_records():
    doc = {"method": "lm", "seed": 2, "loss": "lsq", "validation_fraction": 0.2, "k": 0.0}
    origin = calibration.Provenance.from_json(doc)
    assert origin.options is not None and origin.options.particles == 20  # the default
    assert "particles" in origin.unrecorded and origin.joint is None
    assert origin.to_json() == doc and origin.recorded() == doc
