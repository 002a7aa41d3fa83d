"""Every shipped non-UR arm as its controller states it: sessions, plans and programs.

The session of each arm is written the way an integrator's own tool would
write it from docs/session-format.md: joint columns are the angles the
controller reports, the points come from an independent forward kinematics
(yourdfpy) of a perturbed copy of the arm's URDF (joint origins moved and
turned, so every joint's zero is off too), seen by a tracker standing
anywhere, with a reflector the session only guesses. The controller ->
URDF angle map is written here from the vendors' ROS drivers, not taken from
the description (FANUC's J3 is measured from the horizon: J3_urdf = J3 + J2,
fanuc_driver's J23 factor 1 for the M-20iA; the others relay the axes
unchanged). ``identify`` must come within 1.5x of least squares started from
the truth; the plan a user reads must hold the angles its program commands.
"""

import json
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
import yourdfpy
from cli_process_kit import run_cli
from grammar_kit import PARSERS
from urdf_truth_kit import perturbed

from calibrator import calibration, planning, robots, session
from calibrator.identify import pipeline
from calibrator.identify.problem import Problem
from calibrator.identify.refine import refine
from calibrator.model import frames, kinematics, parameters, rotations
from calibrator.robots.urdf import read_chain

DATA = Path(robots.__file__).with_name("data")
ARMS = ["kuka-kr6-r900", "abb-irb4600-60-205", "fanuc-m20ia", "yaskawa-gp8", "staubli-tx2-60"]
#: The language each arm's program is written in, and its file name.
PROGRAMS = {
    "kuka-kr6-r900": ("krl", "cell.src"),
    "abb-irb4600-60-205": ("rapid", "cell.mod"),
    "fanuc-m20ia": ("fanuc-ls", "cell.ls"),
}


def urdf_of_controller(arm: str, q: np.ndarray) -> np.ndarray:
    """URDF joint angles of controller angles (rad), as the vendor's ROS driver maps them."""
    q = np.array(q, dtype=float)
    if arm == "fanuc-m20ia":
        q[:, 2] += q[:, 1]  # fanuc_driver linkage_transform, J23 factor 1
    return q


def controller_of_urdf(arm: str, q: np.ndarray) -> np.ndarray:
    q = np.array(q, dtype=float)
    if arm == "fanuc-m20ia":
        q[:, 2] -= q[:, 1]
    return q


class TrueArm:
    """A perturbed copy of a shipped URDF, moved by yourdfpy (base_link -> tip, mm)."""

    def __init__(self, arm: str, tmp_path: Path, seed: int) -> None:
        self.arm = arm
        text = (DATA / f"{arm}.urdf").read_text()
        # The description's tip: its file's tip_link, else tool0 (robots.urdf's default).
        self.tip = "flange" if '<link name="flange"' in text else "tool0"
        self.path = tmp_path / "true.urdf"
        self.path.write_text(perturbed(text, np.random.default_rng(seed), (0.02, 0.2)))
        self.urdf = yourdfpy.URDF.load(
            str(self.path), load_meshes=False, build_collision_scene_graph=False
        )
        chain = read_chain(self.path, "base_link", self.tip)
        self.names = [j.name for j in chain.moving]
        self.limits = np.array(
            [[self.urdf.joint_map[n].limit.lower, self.urdf.joint_map[n].limit.upper]
             for n in self.names]
        )  # fmt: skip

    def tip_poses(self, q_controller: np.ndarray) -> np.ndarray:
        out = []
        for row in urdf_of_controller(self.arm, q_controller):
            self.urdf.update_cfg(dict(zip(self.names, row, strict=True)))
            out.append(np.array(self.urdf.get_transform(self.tip, "base_link")))
        poses = np.array(out)
        poses[:, :3, 3] *= 1000.0
        return poses

    def sample(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """Controller angles of poses inside the URDF's limits (shrunk 10 %)."""
        lo, hi = self.limits.T
        mid, half = (lo + hi) / 2, (hi - lo) / 2 * 0.9
        return controller_of_urdf(self.arm, rng.uniform(mid - half, mid + half, (n, 6)))


def write_session(path: Path, arm: str, q: np.ndarray, points: np.ndarray) -> None:
    """A session file as docs/session-format.md says, written with pyarrow alone."""
    columns = {"pose": np.arange(len(q))}
    columns.update({f"q{i + 1}_rad": q[:, i] for i in range(6)})
    columns.update({c: points[:, k] for k, c in enumerate(("x_mm", "y_mm", "z_mm"))})
    meta = {
        "format": "calibrator.session",
        "version": 1,
        "frame": "tracker",
        "model": arm,
        "flange2tool": frames.transform(translation=[0.0, 0.0, 100.0]).tolist(),
        "tool_known": False,
    }
    table = pa.table(columns).replace_schema_metadata({"calibrator": json.dumps(meta)})
    pq.write_table(table, path)


@pytest.mark.parametrize("arm", ARMS)
def test_a_session_in_controller_angles_identifies_as_least_squares_from_the_truth(tmp_path, arm):
    rng = np.random.default_rng(11)
    true = TrueArm(arm, tmp_path, seed=ARMS.index(arm) + 1)
    tool_tip = frames.transform(translation=[12.0, -7.0, 135.0])  # the real reflector
    base2tracker = frames.transform(rotations.rotvec_to_matrix([0.1, -0.2, 2.5]), [3100, -800, 400])
    q = true.sample(60, rng)
    points = (base2tracker @ true.tip_poses(q) @ tool_tip)[:, :3, 3]
    points += rng.normal(0.0, 0.01, points.shape)
    write_session(tmp_path / "s.parquet", arm, q, points)

    done = run_cli("identify", "s.parquet", "-q", "-o", "cal.json", cwd=tmp_path)
    assert done.returncode == 0, done.stderr

    cal = calibration.load(tmp_path / "cal.json")
    nominal = robots.get(arm)
    true_arm = robots.get(f"{true.path}#base_link:{true.tip}")
    truth = (
        true_arm.mdh,
        base2tracker @ true_arm.base_offset,
        true_arm.flange_offset @ tool_tip,
    )
    obs = session.load(tmp_path / "s.parquet").observations
    space = parameters.ParameterSpace(cal.nominal_mdh, cal.base0, cal.tool0, cal.free)
    ran = cal.provenance.options  # the split the fit made
    assert ran is not None
    fit, _ = pipeline.split(len(obs), ran.validation_fraction, ran.seed)
    best = refine(Problem.of(space, obs.subset(fit), 0.0), space.pack(*truth))
    mdh, b2t, f2t = space.unpack(best.x)

    # Unseen poses, in the controller's angles, through the model's convention.
    q_new = true.sample(200, np.random.default_rng(12))
    seen = (base2tracker @ true.tip_poses(q_new) @ tool_tip)[:, :3, 3]
    q_model = nominal.convention.to_model(q_new)

    def rms(mdh_, b2t_, f2t_):
        model = kinematics.forward(mdh_, q_model, f2t_, b2t_)[:, :3, 3]
        return float(np.sqrt(np.mean(np.sum((model - seen) ** 2, axis=1))))

    ours, baseline = rms(cal.mdh, cal.base2tracker, cal.flange2tool), rms(mdh, b2t, f2t)
    print(f"{arm}: identify {ours:.4f} mm, least squares from the truth {baseline:.4f} mm")
    assert baseline < 0.05
    assert ours <= 1.5 * baseline


def test_a_session_is_read_through_its_arms_convention(tmp_path):
    """A KUKA session in A1..A6 reaches the kinematics mirrored in joints 1 and 6."""
    rng = np.random.default_rng(3)
    true = TrueArm("kuka-kr6-r900", tmp_path, seed=4)
    q = true.sample(40, rng)
    points = (true.tip_poses(q) @ frames.transform(translation=[0, 0, 100.0]))[:, :3, 3]
    write_session(tmp_path / "s.parquet", "kuka-kr6-r900", q, points)
    good = session.load(tmp_path / "s.parquet")
    np.testing.assert_allclose(
        good.observations.q, robots.get("kuka-kr6-r900").convention.to_model(q), atol=0
    )
    assert not np.allclose(good.observations.q, q)  # A1 and A6 turn the other way


def test_a_session_written_by_an_earlier_version_is_read_in_its_model_angles(tmp_path):
    """Sessions ``simulate`` wrote before the ``joints`` key held the model's angles."""
    arm = robots.get("kuka-kr6-r900")
    lo, hi = arm.joint_limits_rad.T
    q_model = np.random.default_rng(2).uniform(lo * 0.9 + hi * 0.1, lo * 0.1 + hi * 0.9, (12, 6))
    points = kinematics.forward(arm.mdh, q_model, frames.transform(translation=[0, 0, 100.0]))
    table = session.to_table(q_model, points[:, :3, 3])
    meta = {
        "format": "calibrator.session",
        "version": 1,
        "frame": "base",
        "model": arm.name,
        "simulated": {"seed": 1},
    }
    pq.write_table(
        table.replace_schema_metadata({"calibrator": json.dumps(meta)}), tmp_path / "old.parquet"
    )
    old = session.load(tmp_path / "old.parquet")
    assert old.meta.joints == "model"
    np.testing.assert_array_equal(old.observations.q, q_model)
    # Written again, it says what it holds.
    session.write(tmp_path / "again.parquet", old.table, old.meta)
    again = session.load(tmp_path / "again.parquet")
    assert again.meta.joints == "model"
    np.testing.assert_array_equal(again.observations.q, q_model)


def test_a_session_saying_other_joints_is_refused_in_one_line(tmp_path):
    q = np.random.default_rng(2).uniform(-1, 1, (12, 6))
    table = session.to_table(q, np.random.default_rng(3).uniform(0, 900, (12, 3)))
    meta = {"format": "calibrator.session", "version": 1, "frame": "tracker",
            "model": "kuka-kr6-r900", "joints": "urdf"}  # fmt: skip
    pq.write_table(
        table.replace_schema_metadata({"calibrator": json.dumps(meta)}), tmp_path / "s.parquet"
    )
    done = run_cli("identify", "s.parquet", "-o", "cal.json", cwd=tmp_path)
    assert done.returncode == 2
    assert "'joints' must be 'controller' or 'model'" in done.stderr
    assert len(done.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "cal.json").exists()


@pytest.mark.parametrize("arm", ARMS)
def test_the_plan_holds_the_angles_its_program_commands(tmp_path, arm):
    made = run_cli(
        "plan", "--model", arm, "--poses", "12", "--tracker-at", "4500,0,500", "-o", "plan.csv",
        cwd=tmp_path,
    )  # fmt: skip
    assert made.returncode == 0, made.stderr
    with open(tmp_path / "plan.csv", encoding="utf-8") as fh:
        header = fh.readline().strip().split(",")
        rows = [line.strip().split(",") for line in fh]
    assert {r[header.index("joints")] for r in rows} == {"controller"}
    cols = [header.index(f"q{i}_rad") for i in range(1, 7)]
    measured = [r for r in rows if r[header.index("via")] == "0"]
    in_file = np.degrees([[float(r[c]) for c in cols] for r in measured])
    fmt, name = PROGRAMS.get(arm, ("csv", "cell.csv"))
    done = run_cli("program", "plan.csv", "--model", arm, "-o", name, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    text = (tmp_path / name).read_text()
    if fmt == "csv":
        lines = [line.split(",") for line in text.strip().splitlines()]
        kinds = [line[1] for line in lines[1:]]
        targets = np.array([[float(v) for v in line[3:9]] for line in lines[1:]])
        commanded = targets[[k == "pose" for k in kinds]]
    else:
        # The parsers give radians; home moves dropped.
        path = np.degrees(PARSERS[fmt](text).targets())[1:-1]
        vias = [r[header.index("via")] == "1" for r in rows]
        commanded = path[[not v for v in vias]]
    # The program writes 1e-6 degree: the same angles, not mirrored or shifted.
    np.testing.assert_allclose(commanded, in_file, rtol=0, atol=2e-6)
    # Read back, the plan is the model's angles the planner made.
    plan = planning.read_plan(tmp_path / "plan.csv")
    np.testing.assert_allclose(
        robots.get(arm).convention.to_controller(plan.q_rad), np.radians(in_file), atol=1e-12
    )


def test_a_plan_from_an_earlier_version_is_read_in_its_model_angles(tmp_path):
    """Plans ``plan`` wrote with a model column but no ``joints`` one held the model's angles."""
    made = run_cli(
        "plan", "--model", "kuka-kr6-r900", "--poses", "12", "-o", "plan.csv", cwd=tmp_path
    )
    assert made.returncode == 0, made.stderr
    new = planning.read_plan(tmp_path / "plan.csv")
    lines = (tmp_path / "plan.csv").read_text().splitlines()
    header = lines[0].split(",")
    j = header.index("joints")
    old = [",".join(c for k, c in enumerate(line.split(",")) if k != j) for line in lines]
    # The old file's joint columns: the model's angles of the same plan.
    q_cols = [header.index(f"q{i}_rad") - 1 for i in range(1, 7)]
    rows = [line.split(",") for line in old[1:]]
    for r, q in zip(rows, new.path_rad, strict=True):
        for c, v in zip(q_cols, q, strict=True):
            r[c] = repr(float(v))
    (tmp_path / "old.csv").write_text("\n".join([old[0], *(",".join(r) for r in rows)]) + "\n")
    back = planning.read_plan(tmp_path / "old.csv")
    np.testing.assert_array_equal(back.q_rad, new.q_rad)


def test_a_session_states_its_convention_and_reads_right_where_its_arm_is_missing(tmp_path):
    """A session names its arm by a description file that may not be there when read."""
    arm = robots.get("fanuc-m20ia")
    lo, hi = arm.joint_limits_rad.T
    q_model = np.random.default_rng(5).uniform(lo * 0.8, hi * 0.8, (12, 6))
    tool = frames.transform(translation=[0, 0, 100.0])
    points = kinematics.forward(arm.mdh, q_model, tool)[:, :3, 3]
    meta = session.SessionMeta("base", arm.mdh, arm.name, tool, True)
    session.write(
        tmp_path / "s.parquet",
        session.to_table(arm.convention.to_controller(q_model), points),
        meta,
    )
    footer = json.loads(pq.ParquetFile(tmp_path / "s.parquet").schema_arrow.metadata[b"calibrator"])
    assert footer["joints"] == "controller" and footer["convention"]["couplings"] == [[2, 1, 1.0]]
    # The same file naming an arm nobody can find: the stated convention still reads it.
    footer["model"] = "gone/arm.urdf"
    table = pq.read_table(tmp_path / "s.parquet")
    pq.write_table(
        table.replace_schema_metadata({"calibrator": json.dumps(footer)}),
        tmp_path / "moved.parquet",
    )
    moved = session.load(tmp_path / "moved.parquet")
    np.testing.assert_allclose(moved.observations.q, q_model, atol=1e-12)
