"""The name a written program takes from its file, by its language's rules.

KRL and Fanuc LS name the program after its file (upper case, as the
pendant shows it) and refuse a file named after a keyword; URScript is case
sensitive and renames a procedure that would shadow a function it calls
(``movej``) rather than refuse; a differently cased ``MoveJ`` shadows nothing.
"""

from __future__ import annotations

import pytest

from calibrator.errors import CalibrationError
from calibrator.languages import writing


@pytest.mark.parametrize(
    ("fmt", "file", "name"),
    [
        ("krl", "weld.src", "WELD"),
        ("krl", "Naht_2.src", "NAHT_2"),
        ("fanuc-ls", "weld.ls", "WELD"),
        ("urscript", "weld.script", "weld"),
        ("urscript", "movej.script", "movej_program"),
        ("urscript", "end.script", "end_program"),
        ("urscript", "MoveJ.script", "MoveJ"),
        ("urscript", "2nd pass.script", "p_2nd_pass"),
        ("csv", "weld.csv", "calibrator_measure"),
    ],
)
def test_a_program_is_named_after_its_file(fmt, file, name):
    assert writing.name_for(fmt, file) == name


@pytest.mark.parametrize("file", ["ptp.src", "END.src", "wait.src"])
def test_a_krl_file_named_after_a_keyword_is_refused(file):
    with pytest.raises(CalibrationError, match="is a KRL keyword or a name the program uses"):
        writing.name_for("krl", file)
