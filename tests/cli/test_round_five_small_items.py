"""Issue 41's smaller items: names printed safely, empty items, a PNG named .txt, choices."""

from pathlib import Path

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
    from calibrator.languages.registry import readers

    assert FORMAT_CHOICES.split("|") == list(readers())
    shown = cli("compensate", "-h", cwd=tmp_path).stdout
    assert "--format urscript|krl|rapid|fanuc|jbi" in shown
    assert "--joint-targets keep|correct" in shown
    group = " ".join(cli("history", "-h", cwd=tmp_path).stdout.split())
    assert "--csv FILE, --html DIR" in group and "calibrator history show -h" in group


def test_library_warnings_on_the_way_to_a_refusal_are_not_printed_around_its_line(tmp_path):
    from cli_process_kit import run_cli

    from calibrator import robots

    # Masses of 1e308 kg: numpy warns while the centres of mass are computed
    # (inf * 0), then the description is refused in one line.
    heavy = (
        '<link name="{0}"><inertial><origin xyz="0.2 0 0"/><mass value="1e308"/>'
        '<inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>'
    )
    text = (Path(robots.__file__).with_name("data") / "kuka-kr6-r900.urdf").read_text()
    for link in ("link_2", "link_3"):
        text = text.replace(f'<link name="{link}"/>', heavy.format(link))
    (tmp_path / "heavy.urdf").write_text(text)
    done = run_cli("plan", "--model", "heavy.urdf", "-o", "p.csv", cwd=tmp_path, timeout=120)
    assert done.returncode == 2, done.stderr
    assert done.stderr.strip().splitlines() == [done.stderr.strip()], done.stderr
    assert "Warning" not in done.stderr and done.stderr.startswith("calibrator: error: ")
    assert not (tmp_path / "p.csv").exists()


def test_a_sections_file_for_another_arms_mass_model_is_refused_unless_asked_for(tmp_path):
    (tmp_path / "s.yaml").write_text(
        "mass_model: ur5e\n"
        "links:\n  2: {outer_mm: 100, inner_mm: 80, e_mpa: 70000}\n"
        "  3: {outer_mm: 90, inner_mm: 74, e_mpa: 70000}\n"
    )
    args = ("analyze", "deflection", "--model", "ur10e", "--sections", "s.yaml", "--json", "d.json")
    line = one_line_error(cli(*args, cwd=tmp_path))
    assert "its mass_model is the ur5e's, not --model ur10e's; give --masses ur5e" in line
    assert not (tmp_path / "d.json").exists()
    done = cli(*args, "--masses", "ur5e", cwd=tmp_path)
    assert done.code == 0, done.stderr
    (tmp_path / "s.yaml").write_text(
        (tmp_path / "s.yaml").read_text().replace("mass_model: ur5e", "mass_model: ur10e")
    )
    assert cli(*args, "--force", cwd=tmp_path).code == 0
