"""Link deflection by kinetostatics (the deflection paper): cantilevers, its example, CLI."""

import json

import numpy as np
import pytest
from cli_kit import cli, listing, one_line_error

from calibrator.analysis import deflection as dfl
from calibrator.errors import CalibrationError
from calibrator.model import mass_models
from calibrator.robots import masses as robot_masses

G = 9.81  # N/kg, as mass_models.GRAVITY_MM_S2 / 1000
ROD = dfl.PAPER_ROD
EI = ROD.e_mpa * np.pi / 64 * (50.0**4 - 30.0**4)  # N mm^2, written out from D and d


def test_section_constants_match_the_handbook_formulas():
    assert ROD.bending_mm4 == pytest.approx(np.pi * (50**4 - 30**4) / 64)
    assert ROD.area_mm2 == pytest.approx(np.pi * (50**2 - 30**2) / 4)
    assert ROD.shear_mpa == pytest.approx(2.1e5 / 2.6)


def _numerical_tip(length, ei, tip_force, tip_moment, spread, station, station_moment):
    """Tip of a beam along +x loaded in the xy plane, by integrating M(s) / EI numerically."""
    s = np.linspace(0.0, length, 200001)
    # Bending moment about +z at section s from everything beyond s.
    m = tip_force * (length - s) + tip_moment + spread / length * (length - s) ** 2 / 2
    m = m + np.where(s < station, station_moment, 0.0)
    kappa = m / ei
    rot = np.trapezoid(kappa, s)
    disp = np.trapezoid(kappa * (length - s), s)
    return rot, disp


@pytest.mark.parametrize(
    "loads",
    [
        (100.0, 0.0, 0.0, 0.0),  # tip force: P L^3 / 3EI
        (0.0, 2.0e4, 0.0, 0.0),  # tip moment: M L^2 / 2EI
        (0.0, 0.0, 180.0, 0.0),  # own weight spread: W L^3 / 8EI
        (0.0, 0.0, 0.0, -1.5e4),  # moment at a station
        (-60.0, 5.0e3, 120.0, 8.0e3),
    ],
)
def test_influence_coefficients_match_an_integrated_beam(loads):
    force, moment, spread, station_moment = loads
    length, station = 600.0, 230.0
    rot, disp = dfl.cantilever_tip(
        np.array([[1.0, 0.0, 0.0]]),
        np.array([length]),
        ROD,
        np.array([[0.0, force, 0.0]]),
        np.array([[0.0, 0.0, moment]]),
        np.array([[0.0, spread, 0.0]]),
        np.array([station]),
        np.array([[0.0, 0.0, station_moment]]),
    )
    want_rot, want_disp = _numerical_tip(length, EI, force, moment, spread, station, station_moment)
    assert rot[0] == pytest.approx([0.0, 0.0, want_rot], rel=1e-5, abs=1e-12)
    assert disp[0] == pytest.approx([0.0, want_disp, 0.0], rel=1e-5, abs=1e-12)


def test_axial_and_torsion_coefficients():
    rot, disp = dfl.cantilever_tip(
        np.array([[0.0, 0.0, 1.0]]),
        np.array([500.0]),
        ROD,
        np.array([[0.0, 0.0, 1000.0]]),
        np.array([[0.0, 0.0, 3.0e4]]),
        np.zeros((1, 3)),
        np.array([0.0]),
        np.zeros((1, 3)),
    )
    assert disp[0, 2] == pytest.approx(1000.0 * 500.0 / (2.1e5 * ROD.area_mm2))
    gj = 2.1e5 / 2.6 * np.pi / 32 * (50**4 - 30**4)
    assert rot[0, 2] == pytest.approx(3.0e4 * 500.0 / gj)


def test_seed_example_matches_cantilever_formulas_at_the_end_pose():
    """The rod, horizontal, 600 mm: tip load of links 4-5 and its own weight, by hand."""
    arm = dfl.paper_arm()
    q, _ = dfl.paper_trajectory()
    result = dfl.deflect(arm, q[-1:])
    length = 600.0
    tip_load = (5.33 + 6.5 + 5.0) * G
    own = 18.72 * G
    from_tip = tip_load * length**3 / (3 * EI)  # about 0.21 mm
    from_own = own * length**3 / (8 * EI)  # about 0.09 mm
    assert from_tip == pytest.approx(0.212, abs=0.002)
    assert from_own == pytest.approx(0.088, abs=0.002)
    rod = result.links[3]
    assert rod["tip_mm"][0, 2] == pytest.approx(-(from_tip + from_own), rel=1e-9)
    # The hand hangs below the rod's tip: bending rotation moves it sideways only.
    assert result.hand_mm[0, 2] == pytest.approx(-(from_tip + from_own), rel=1e-9)
    bend = tip_load * length**2 / (2 * EI) + own * length**2 / (6 * EI)
    tangential = np.array([-1.0, 1.0, 0.0]) / np.sqrt(2)  # across the arm at 45 deg
    assert rod["tip_rot_rad"][0] @ tangential == pytest.approx(bend, rel=1e-9)  # tip dips
    # Link 5's centre of mass, 100 mm across the rod, twists it: T L / GJ.
    radial = np.array([1.0, 1.0, 0.0]) / np.sqrt(2)
    twist = 11.5 * G * 100.0 * length / (ROD.shear_mpa * 2 * np.pi / 64 * (50**4 - 30**4))
    assert abs(rod["tip_rot_rad"][0] @ radial) == pytest.approx(twist, rel=1e-9)


def test_named_arm_links_match_cantilever_formulas_when_stretched_out():
    """UR10e at zero: upper arm and forearm horizontal; each link's tip by hand."""
    sec = dfl.Section(outer_mm=100.0, inner_mm=80.0, e_mpa=7.0e4)
    arm = dfl.named_arm("ur10e", {2: sec, 3: sec})
    masses = robot_masses.get("ur10e")
    q = np.zeros((1, 6))
    frames = arm.frames(q)[0]
    result = dfl.deflect(arm, q)
    ei = 7.0e4 * np.pi / 64 * (100.0**4 - 80.0**4)
    coms = np.array(
        [frames[i + 1, :3, :3] @ masses.com_mm[i] + frames[i + 1, :3, 3] for i in range(6)]
    )
    weights = masses.mass_kg * G
    for link in (2, 3):
        root, tip = frames[link - 1, :3, 3], frames[link, :3, 3]
        length = np.linalg.norm(tip - root)
        along = (tip - root) / length
        assert abs(along[2]) < 1e-9  # horizontal
        beyond = slice(link, 6)
        load = weights[beyond].sum()
        # Moment about the tip of the loads beyond it, in the vertical plane of the beam:
        # lever along the beam (positive outwards) times the weight.
        lever = (coms[beyond] - tip) @ along
        tip_moment = (weights[beyond] * lever).sum()
        own = weights[link - 1]  # spread evenly; its centre's offset only twists the link
        want = load * length**3 / (3 * ei) + tip_moment * length**2 / (2 * ei)
        want += own * length**3 / (8 * ei)
        assert result.links[link]["tip_mm"][0, 2] == pytest.approx(-want, rel=1e-9)


def test_a_motion_at_rest_is_the_static_answer_and_inertia_shows_when_moving():
    arm = dfl.paper_arm()
    q, _ = dfl.paper_trajectory(samples=51)
    still = np.repeat(q[-1:], 11, axis=0)
    at_rest = dfl.deflect(arm, still, dt=0.1)
    static = dfl.deflect(arm, q[-1:])
    assert np.allclose(at_rest.hand_mm, static.hand_mm, atol=1e-12)
    moving = dfl.deflect(arm, q, dt=1.0 / 50)
    assert not np.allclose(moving.hand_mm[-1], static.hand_mm[0], atol=1e-3)


def test_trapezoid_law_has_three_phases_and_ends_at_rest():
    q, dt = dfl.trapezoid(np.zeros(1), np.ones(1), 2.0, 401, ramp=0.25)
    assert dt == pytest.approx(2.0 / 400)
    assert q[0, 0] == 0.0 and q[-1, 0] == pytest.approx(1.0)
    v = np.gradient(q[:, 0], dt)
    assert v[200] == pytest.approx(1.0 / (2.0 * 0.75), rel=1e-6)  # cruise
    assert v[0] == pytest.approx(0.0, abs=0.01) and v[-1] == pytest.approx(0.0, abs=0.01)
    with pytest.raises(CalibrationError):
        dfl.trapezoid(np.zeros(1), np.ones(1), 1.0, 10, ramp=0.6)


def test_cli_default_is_the_source_papers_example(tmp_path):
    out = cli("analyze", "deflection", "--json", "d.json", "--plot", "map.png", cwd=tmp_path)
    assert out.code == 0, out.stderr
    line = out.stdout.splitlines()[-3]
    assert line.startswith("hand deflection at the end pose: "), out.stdout
    value = float(line.split("z5 component ")[1].split()[0])
    assert 0.25 <= abs(value) <= 0.35
    doc = json.loads((tmp_path / "d.json").read_text())
    assert doc["hand_dz5_mm"] == pytest.approx(value, abs=5e-4)
    assert len(doc["trajectory"]["t_s"]) == 201
    assert (tmp_path / "map.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_cli_model_seed_is_the_old_spelling_of_paper(tmp_path):
    # Users typed --model seed before the source papers were named by what they are.
    docs = {}
    for spelling in ("paper", "seed", "Seed"):
        out = cli("analyze", "deflection", "--model", spelling, "--json", f"{spelling}.json",
                  "--samples", "21", cwd=tmp_path)  # fmt: skip
        assert out.code == 0, out.stderr
        docs[spelling] = json.loads((tmp_path / f"{spelling}.json").read_text())
    assert docs["seed"] == docs["paper"] == docs["Seed"]
    assert docs["seed"]["model"] == "paper"


def test_cli_named_model_with_sections(tmp_path):
    (tmp_path / "s.yaml").write_text(
        "links:\n  2: {outer_mm: 100, inner_mm: 80, e_mpa: 70000}\n"
        "  3: {outer_mm: 90, inner_mm: 74, e_mpa: 70000}\n"
    )
    out = cli(
        "analyze", "deflection", "--model", "ur10e", "--sections", "s.yaml",
        "--start", "0,-90,0,-90,0,0", "--pose", "0,0,0,-90,0,0", "--json", "d.json",
        cwd=tmp_path,
    )  # fmt: skip
    assert out.code == 0, out.stderr
    doc = json.loads((tmp_path / "d.json").read_text())
    assert set(doc["static"]["links"]) == {"2", "3"}
    assert doc["hand_dz6_mm"] != 0.0


def test_the_last_line_gives_the_size_and_direction_not_one_small_component(tmp_path):
    # At the stretched-out end pose the UR10e's hand moves mostly across z6:
    # its z6 component alone reads as if nothing bent.
    (tmp_path / "s.yaml").write_text(
        "links:\n  2: {outer_mm: 100, inner_mm: 80, e_mpa: 70000}\n"
        "  3: {outer_mm: 90, inner_mm: 74, e_mpa: 70000}\n"
    )
    out = cli(*["analyze", "deflection", *UR, "--json", "d.json"], cwd=tmp_path)
    assert out.code == 0, out.stderr
    hand = np.array(json.loads((tmp_path / "d.json").read_text())["static"]["hand_mm"])
    size = float(np.linalg.norm(hand))
    assert abs(hand[2]) < 0.1 * size  # the case the old line hid
    last = [s for s in out.stdout.splitlines() if s.startswith("hand deflection at the end")]
    assert last == [
        f"hand deflection at the end pose: {size:.3f} mm, direction ("
        + ", ".join(f"{v / size:+.2f}" for v in hand)
        + f") in (x6, y6, z6); z6 component {hand[2]:+.3f} mm"
    ]
    assert json.loads((tmp_path / "d.json").read_text())["hand_deflection_mm"] == pytest.approx(
        size
    )


UR = ["--model", "ur10e", "--sections", "s.yaml"]


@pytest.mark.parametrize(
    ("args", "text", "needle"),
    [
        (["--model", "ur10e"], None, "--sections"),
        (UR, "links: [1, 2]\n", "links"),
        (UR, "links:\n  2: {outer_mm: 10, inner_mm: 20}\n", "inner"),
        (UR, "links:\n  9: {outer_mm: 10}\n", "1..6"),
        (
            ["--model", "er10l-c10", "--sections", "s.yaml"],
            "links:\n  2: {outer_mm: 10}\n",
            "mass model",
        ),
        (["--json", "."], None, "folder"),
        (["--ramp", "0"], None, "--ramp"),
        (["--pose", "1,2"], None, "--pose"),
        (["--sections", "s.yaml"], "links:\n  2: {outer_mm: 10}\n", "named models"),
    ],
)
def test_cli_bad_input_is_one_line_and_writes_nothing(tmp_path, args, text, needle):
    if text is not None:
        (tmp_path / "s.yaml").write_text(text)
    before = listing(tmp_path)
    line = one_line_error(cli("analyze", "deflection", *args, cwd=tmp_path))
    assert needle in line
    assert listing(tmp_path) == before


def test_mass_model_yaml(tmp_path):
    path = tmp_path / "m.yaml"
    rows = "".join(f"  - {{mass_kg: {i}, com_mm: [0, 0, {i}]}}\n" for i in range(6))
    path.write_text("links:\n" + rows)
    model = mass_models.load(path)
    assert model.mass_kg.tolist() == [0, 1, 2, 3, 4, 5]
    path.write_text("links:\n  - {mass_kg: -1, com_mm: [0, 0, 0]}\n" + rows[rows.index("\n") + 1 :])
    with pytest.raises(CalibrationError, match="m.yaml"):
        mass_models.load(path)
