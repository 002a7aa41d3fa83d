"""Every option that takes a comma-separated list of numbers reads them by the strict grammar.

Python's ``float`` reads ``0_5`` as 5, and ``nan`` and ``inf`` as numbers; a
home position, a pose or a payload centre given that way must be refused in
one line (exit 2), never run with a value the user did not write.
"""

import pytest
from cli_kit import cli, one_line_error


@pytest.fixture(scope="module")
def inputs(tmp_path_factory, checked_plan):
    """A plan and a session for the commands that need one before they read the option."""
    from calibrator import planning

    folder = tmp_path_factory.mktemp("inputs")
    # The commands only need a valid plan: the session's shared one.
    planning.write_plan(folder / "plan.csv", checked_plan)
    assert cli("simulate", "-o", "s.parquet", "--poses", "12", cwd=folder).code == 0
    return folder


def _value(template, inputs):
    """``{last_pose}``: the plan's last pose J1..J5 (deg), so a home differing in J6 is safe.

    Turning J6 alone turns the reflector about its own axis: that home and the
    moves to and from it pass the program's cell check whatever J6 is.
    """
    import numpy as np

    from calibrator import planning

    last = np.degrees(planning.read_plan(inputs / "plan.csv").q_rad[-1])
    return template.replace("{last_pose}", ",".join(repr(float(v)) for v in last[:5]))


# (arguments before the option, the option, a good value with one place to spoil)
OPTIONS = [
    (("program", "{plan}", "-o", "p.script"), "--home", "{last_pose},{}"),
    (("analyze", "deflection"), "--pose", "0,-90,{},0,90"),
    (("analyze", "deflection"), "--start", "0,-90,{},0,90"),
    (("analyze", "misalignment", "--trials", "10000"), "--pose", "0,0,{},0,0,0"),
    (("analyze", "misalignment", "--trials", "10000"), "--r0", "0.05,{}"),
    (("identify", "{session}", "-o", "c.json", "--joint-terms", "compliance"),
     "--payload-com-mm", "0,0,{}"),
    (("measure", "-o", "m.parquet", "--poses", "30"), "--tool", "0,0,{}"),
    (("measure", "-o", "m.parquet", "--poses", "30"), "--tracker-at", "2500,0,{}"),
    (("plan", "-o", "q.csv", "--poses", "30"), "--tracker-at", "2500,0,{}"),
    (("verify", "-o", "v.json"), "--cube", "600,0,400,{}"),
]  # fmt: skip


@pytest.mark.parametrize("spoiled", ["0_5", "nan", "inf", "-inf", "1e400", "0x10", ""])
@pytest.mark.parametrize(("before", "option", "value"), OPTIONS)
def test_a_number_python_would_read_is_refused_in_one_line(
    inputs, tmp_path, before, option, value, spoiled
):
    args = [a.format(plan=inputs / "plan.csv", session=inputs / "s.parquet") for a in before]
    out = cli(*args, option, _value(value, inputs).format(spoiled), cwd=tmp_path)
    line = one_line_error(out)
    assert out.code == 2, out
    assert option in line and line.startswith("calibrator: error: ")
    assert list(tmp_path.iterdir()) == []  # nothing written


@pytest.mark.parametrize(("before", "option", "value"), OPTIONS[:3])
def test_the_same_list_written_plainly_is_taken(inputs, tmp_path, before, option, value):
    args = [a.format(plan=inputs / "plan.csv", session=inputs / "s.parquet") for a in before]
    out = cli(*args, option, _value(value, inputs).format("5"), cwd=tmp_path)
    assert out.code == 0, out.stderr
