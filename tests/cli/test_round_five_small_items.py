"""Issue 41's smaller items: names printed safely, empty items, a PNG named .txt, choices."""

from cli_kit import cli, one_line_error


def test_robot_names_with_newlines_or_escapes_cannot_forge_a_line_of_the_table(tmp_path):
    for name in ("evil\nforged-robot  ur10e  1234  99", "\x1b[31mred"):
        done = cli("history", "robot", name, "--history", "h.sqlite", cwd=tmp_path)
        assert done.code == 0, done.stderr
        assert "\x1b" not in done.stdout and done.stdout.count("\n") == 1, done.stdout
    listed = cli("history", "--history", "h.sqlite", cwd=tmp_path)
    assert listed.code == 0, listed.stderr
    lines = listed.stdout.splitlines()
    assert len(lines) == 3, lines  # the header and one line per robot
    assert "\x1b" not in listed.stdout
    assert any(line.startswith("evil\\nforged-robot") for line in lines), lines
    assert any(line.startswith("\\x1b[31mred") for line in lines), lines


def test_an_empty_joint_terms_item_is_refused(tmp_path):
    assert cli("simulate", "--poses", "12", "-o", "s.parquet", cwd=tmp_path).code == 0
    for text in ("scale,,harmonic", "scale,"):
        line = one_line_error(
            cli("identify", "s.parquet", "-o", "c.json", "--joint-terms", text, cwd=tmp_path)
        )
        assert "--joint-terms" in line and "has an empty item" in line, line
        assert not (tmp_path / "c.json").exists()


def test_a_deflection_plot_not_named_png_is_refused_before_the_work(tmp_path):
    line = one_line_error(cli("analyze", "deflection", "--plot", "out.txt", cwd=tmp_path))
    assert "--plot out.txt: the map is a PNG; end the name in .png" in line
    assert sorted(p.name for p in tmp_path.iterdir()) == []


def test_options_with_fixed_choices_show_them_in_their_help(tmp_path):
    from calibrator.cli.compensate import FORMAT_CHOICES
    from calibrator.filtering import FORMATS

    assert FORMAT_CHOICES.split("|") == list(FORMATS)
    shown = cli("compensate", "-h", cwd=tmp_path).stdout
    assert "--format urscript|krl|rapid|fanuc|jbi" in shown
    assert "--joint-targets keep|correct" in shown
    group = " ".join(cli("history", "-h", cwd=tmp_path).stdout.split())
    assert "--csv FILE, --html DIR" in group and "calibrator history show -h" in group
