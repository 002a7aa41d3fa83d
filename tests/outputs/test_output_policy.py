"""One policy for every output of every command: an existing output is refused
(one line, exit 2, naming the option that gave it) unless ``--force``."""

import pytest
from cli_kit import cli, listing, one_line_error

PLAN = ("--poses", "12", "--candidates", "1500", "--tracker-at", "2500,400,300")
TARGETS = "q1_rad,q2_rad,q3_rad,q4_rad,q5_rad,q6_rad\n0.1,-1.2,1.4,-1.8,-1.5,0.3\n"


@pytest.fixture(scope="module")
def work(tmp_path_factory, simulated_calibration):
    """A session, its calibration (conftest) and a small plan, made once; tests copy them."""
    folder = tmp_path_factory.mktemp("policy")
    for name, data in simulated_calibration.items():
        (folder / name).write_bytes(data)
    made = cli("plan", "-o", "plan.csv", *PLAN, cwd=folder)
    assert made.code == 0, made.stderr
    (folder / "targets.csv").write_text(TARGETS)
    return {p.name: p.read_bytes() for p in folder.iterdir()}


@pytest.fixture
def folder(tmp_path, work):
    for name, data in work.items():
        (tmp_path / name).write_bytes(data)
    return tmp_path


# (command line, the existing output it must not replace, the option naming it)
CASES = [
    (["plan", *PLAN, "-o", "plan.csv"], "plan.csv", "-o"),
    (["identify", "s.parquet", "--method", "lm", "-q", "-o", "c.json"], "c.json", "-o"),
    (["identify", "s.parquet", "--method", "lm", "-q", "-o", "new.json", "--report", "rep"],
     "rep/index.html", "--report"),
    (["report", "c.json", "s.parquet", "-o", "rep"], "rep/index.html", "-o"),
    (["export-params", "c.json", "-o", "p.csv"], "p.csv", "-o"),
    (["compensate", "c.json", "targets.csv", "-o", "out.csv"], "out.csv", "-o"),
    (["simulate", "--poses", "5", "-o", "t.parquet"], "t.parquet", "-o"),
    (["simulate", "--poses", "5", "-o", "t.parquet"], "t.truth.json", "-o"),
    (["program", "plan.csv", "-o", "p.script"], "p.script", "-o"),
    (["analyze", "tolerance", "--model", "ur10e", "--samples", "50", "--json", "t.json"],
     "t.json", "--json"),
    (["measure", "--plan", "plan.csv", "-q", "-o", "m.parquet"], "m.parquet", "-o"),
]  # fmt: skip


@pytest.mark.parametrize(("args", "existing", "option"), CASES)
def test_an_existing_output_is_refused_naming_its_option_and_force_replaces_it(
    folder, args, existing, option
):
    target = folder / existing
    target.parent.mkdir(exist_ok=True)
    target.write_text("earlier work\n")
    before = listing(folder)
    line = one_line_error(cli(*args, cwd=folder))
    assert f"{existing} exists: remove it, choose another {option}," in line
    assert "--force" in line
    assert listing(folder) == before  # nothing written, nothing left behind
    done = cli(*args, "--force", cwd=folder)
    assert done.code == 0, done.stderr
    assert target.read_text(errors="replace") != "earlier work\n"
