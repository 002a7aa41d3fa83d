"""Filtering a long machining program against compensating the same targets as CSV.

Run::

    .venv/bin/python benchmarks/compensate_programs.py [--language urscript] \
        [--targets 1000000] [--repeats 3] [--keep DIR]

Two cells, each with hidden MDH errors (0.3 mm, 0.5 mrad) and a tool off the
flange, and a smooth machining path of ``--targets`` Cartesian targets (a
raster over a part, one configuration) written twice: as one program and as
a targets CSV (the nominal joints and the base-frame pose of each target).

- ``urscript`` (default, issue #42's acceptance check F2): a UR10e, one
  ``movel(p[...], a=1.2, v=0.25)`` a line under one ``set_tcp``; the CSV's
  calibration carries the same tool, so both solve the very same targets.
- ``krl``: an ER10L-C10, a tool 180 mm off the flange and a work base; inline
  ``LIN`` aggregates with ``S``/``T``, tool and base from a ``$config.dat``.

Each is compensated in a fresh process, ``--repeats`` times; the median
wall time, the median CPU time (the child's own, which a loaded machine
inflates less) and the largest peak resident memory (the child's ``VmHWM``,
Linux) are printed, with their ratios and the time per target. The two are
run in turn, so a change in the machine's load falls on both alike.
``--keep DIR`` copies the last outputs there (``o.csv`` and the filtered
program) to compare two versions of the code byte for byte.
"""

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent


def _setup_krl(folder: Path, n: int) -> None:
    from calibrator import compensate, robots, simulate
    from calibrator.calibration import Calibration
    from calibrator.compensate.solve import Solver
    from calibrator.languages import frames_file
    from calibrator.languages.krl.reader import KRL
    from calibrator.languages.reading import Job
    from calibrator.model import frames, kinematics, parameters, rotations

    model = robots.get("er10l-c10")
    errors = simulate.random_errors(model.mdh, np.random.default_rng(3), mm=0.3, rad=0.0005)
    free = tuple(np.array(parameters.MDH_NAMES)[errors.ravel() != 0])
    cal = Calibration(
        nominal_mdh=model.mdh, mdh=model.mdh + errors, model=model.name, free=free,
        deltas=dict(zip(free, errors.ravel()[errors.ravel() != 0], strict=True)),
    )  # fmt: skip
    cal.save(folder / "cal.json")
    tool = frames.transform(rotations.zyx_to_matrix([[0.0, 30.0, 0.0]])[0], [12.5, -4.0, 180.0])
    base = frames.transform(rotations.zyx_to_matrix([[25.0, 0.0, 0.0]])[0], [900.0, -250.0, 120.0])
    # A raster over the part: rows of steps of joints around a working pose, clear of
    # the turn bits' boundaries (a joint at 0 deg) and of singularities.
    t = np.arange(n)
    rows = max(1, int(np.sqrt(n / 4)))
    u = (t % (n // rows)) / (n // rows)
    v = (t // (n // rows)) / rows
    q = np.column_stack(
        [
            0.05 + 0.8 * u,
            0.1 + 0.3 * v,
            -0.3 + 0.2 * v,
            0.3 + 0.3 * np.sin(3 * u),
            0.9 + 0.2 * u,
            0.2 + 0.5 * v,
        ]
    )
    lang = KRL.__new__(KRL)
    codes = Solver(lang, Job(calibration=cal, frames=frames_file.FrameTable())).code_of(q)
    with open(folder / "path.src", "w", newline="") as src, open(folder / "path.csv", "w") as csv:
        src.write("DEF PATH()\r\n$TOOL = TOOL_DATA[1]\r\n$BASE = BASE_DATA[1]\r\n")
        csv.write(",".join(compensate.JOINT_COLUMNS + compensate.POSE_COLUMNS) + "\n")
        for s in range(0, n, 100_000):
            sl = slice(s, min(n, s + 100_000))
            in_base = kinematics.tool_poses(model.mdh, q[sl], tool)
            pose = frames.invert(base) @ in_base
            abc = rotations.matrix_to_zyx(pose[:, :3, :3], np.zeros((len(pose), 3)))
            rv = rotations.matrix_to_rotvec(in_base[:, :3, :3])
            lines = []
            for p, a, c in zip(pose[:, :3, 3], abc, codes[sl], strict=True):
                lines.append(
                    f"LIN {{X {p[0]:.3f},Y {p[1]:.3f},Z {p[2]:.3f},A {a[0]:.4f},B {a[1]:.4f},"
                    f"C {a[2]:.4f},S {c[0]},T {c[1]}}} C_DIS\r\n"
                )
            src.write("".join(lines))
            rows_csv = np.column_stack([q[sl], in_base[:, :3, 3], rv])
            np.savetxt(csv, rows_csv, fmt="%.10g", delimiter=",")
        src.write("END\r\n")
    with open(folder / "config.dat", "w") as cfg:
        for name, f in (("TOOL_DATA", tool), ("BASE_DATA", base)):
            a = rotations.matrix_to_zyx(f[None, :3, :3], np.zeros((1, 3)))[0]
            cfg.write(
                f"{name}[1]={{X {f[0, 3]:.4f},Y {f[1, 3]:.4f},Z {f[2, 3]:.4f},"
                f"A {a[0]:.6f},B {a[1]:.6f},C {a[2]:.6f}}}\n"
            )


def _calibration(name: str, tool=None):
    from calibrator import robots, simulate
    from calibrator.calibration import Calibration
    from calibrator.model import parameters

    model = robots.get(name)
    errors = simulate.random_errors(model.mdh, np.random.default_rng(3), mm=0.3, rad=0.0005)
    free = tuple(np.array(parameters.MDH_NAMES)[errors.ravel() != 0])
    extra = {} if tool is None else {"flange2tool": tool}
    return model, Calibration(
        nominal_mdh=model.mdh, mdh=model.mdh + errors, model=model.name, free=free,
        deltas=dict(zip(free, errors.ravel()[errors.ravel() != 0], strict=True)), **extra,
    )  # fmt: skip


def _setup_urscript(folder: Path, n: int) -> None:
    from calibrator import compensate
    from calibrator.model import frames, kinematics, rotations

    tool = frames.transform(rotations.zyx_to_matrix([[0.0, 30.0, 0.0]])[0], [12.5, -4.0, 180.0])
    model, cal = _calibration("ur10e", tool)
    cal.save(folder / "cal.json")
    # A raster over a part in front of the arm: elbow up, wrist clear of joint 5 = 0.
    t = np.arange(n)
    rows = max(1, int(np.sqrt(n / 4)))
    u = (t % (n // rows)) / (n // rows)
    v = (t // (n // rows)) / rows
    q = np.column_stack(
        [
            0.3 + 0.8 * u,
            -1.7 + 0.3 * v,
            1.3 + 0.3 * v,
            -1.2 + 0.3 * np.sin(3 * u),
            1.2 + 0.2 * u,
            0.2 + 0.5 * v,
        ]
    )
    rv_tool = rotations.matrix_to_rotvec(tool[None, :3, :3])[0]
    tcp = ", ".join([f"{x / 1000:.5f}" for x in tool[:3, 3]] + [f"{r:.6f}" for r in rv_tool])
    script, table = folder / "path.script", folder / "path.csv"
    with open(script, "w", newline="") as src, open(table, "w") as csv:
        src.write(f"def path():\n  set_tcp(p[{tcp}])\n")
        csv.write(",".join(compensate.JOINT_COLUMNS + compensate.POSE_COLUMNS) + "\n")
        for s in range(0, n, 100_000):
            sl = slice(s, min(n, s + 100_000))
            pose = kinematics.tool_poses(model.mdh, q[sl], tool)  # UR: controller base = model's
            rv = rotations.matrix_to_rotvec(pose[:, :3, :3])
            m = pose[:, :3, 3] / 1000.0
            src.write(
                "".join(
                    f"  movel(p[{a[0]:.6f}, {a[1]:.6f}, {a[2]:.6f}, {r[0]:.5f}, {r[1]:.5f}, "
                    f"{r[2]:.5f}], a=1.2, v=0.25)\n"
                    for a, r in zip(m.tolist(), rv.tolist(), strict=True)
                )
            )
            rows_csv = np.column_stack([q[sl], pose[:, :3, 3], rv])
            np.savetxt(csv, rows_csv, fmt="%.10g", delimiter=",")
        src.write("end\n")


def _child(kind: str, folder: Path, language: str) -> None:
    from calibrator import calibration, compensate, robots
    from calibrator.compensate import programs
    from calibrator.languages import frames_file
    from calibrator.languages.reading import Job

    cal = calibration.load(folder / "cal.json")
    suffix = ".src" if language == "krl" else ".script"
    out = folder / ("o.csv" if kind == "csv" else "o" + suffix)
    if out.exists():
        out.unlink()
    t, cpu = time.perf_counter(), time.process_time()
    if kind == "csv":
        report = compensate.run(cal, folder / "path.csv", out)
        failed = 0 if report.ok else -1
    else:
        dat = folder / "config.dat" if language == "krl" else None
        job = Job(
            calibration=cal, frames=frames_file.FrameTable(),
            limits=robots.get(cal.model).joint_limits_rad, config_dat=dat,
        )  # fmt: skip
        failed = programs.Filter(language, job, folder / ("path" + suffix)).run(out, []).n_failed
    wall, cpu = time.perf_counter() - t, time.process_time() - cpu
    # VmHWM: this process's own peak resident memory. (ru_maxrss of a process
    # started by fork and exec starts at its parent's peak on Linux.)
    status = Path("/proc/self/status").read_text()
    peak_kib = int(status.split("VmHWM:")[1].split()[0])
    print(f"{wall:.3f} {cpu:.3f} {failed} {peak_kib}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--language", choices=["urscript", "krl"], default="urscript")
    ap.add_argument("--targets", type=int, default=1_000_000)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--keep", type=Path, help="copy the last outputs into this folder")
    ap.add_argument("--child", choices=["csv", "program"])
    ap.add_argument("--folder", type=Path)
    args = ap.parse_args()
    if args.child:
        _child(args.child, args.folder, args.language)
        return
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        t = time.perf_counter()
        (_setup_krl if args.language == "krl" else _setup_urscript)(folder, args.targets)
        print(f"{args.targets} targets written in {time.perf_counter() - t:.1f} s")
        walls: dict = {"csv": [], "program": []}
        cpus: dict = {"csv": [], "program": []}
        peaks: dict = {"csv": [], "program": []}
        # Alternating, so a change in the machine's load falls on both alike.
        for _ in range(args.repeats):
            for kind in ("csv", "program"):
                done = subprocess.run(
                    [sys.executable, __file__, "--child", kind, "--folder", str(folder),
                     "--language", args.language],
                    capture_output=True, text=True, check=True, env=dict(os.environ),
                )  # fmt: skip
                wall, cpu, failed, peak = done.stdout.split()
                walls[kind].append(float(wall))
                cpus[kind].append(float(cpu))
                peaks[kind].append(int(peak))  # the child's own peak resident memory (KiB)
                if int(failed):
                    print(f"{kind}: {failed} failed targets")
        results = {}
        for kind in ("csv", "program"):
            results[kind] = (
                statistics.median(walls[kind]), statistics.median(cpus[kind]),
                max(peaks[kind]) / 1024,
            )  # fmt: skip
            wall, cpu, peak = results[kind]
            print(
                f"{kind if kind == 'csv' else args.language}: median {wall:.2f} s of "
                f"{args.repeats} (min {min(walls[kind]):.2f}, {1e6 * wall / args.targets:.1f} us "
                f"a target), CPU {cpu:.2f} s ({1e6 * cpu / args.targets:.1f} us a target), "
                f"peak RSS {peak:.0f} MiB"
            )
        pairs = [k / c for k, c in zip(walls["program"], walls["csv"], strict=True)]
        print(f"program / CSV per pair: {', '.join(f'{r:.2f}' for r in pairs)}")
        print(
            f"program / CSV time: {results['program'][0] / results['csv'][0]:.2f}x "
            f"(CPU {results['program'][1] / results['csv'][1]:.2f}x)"
        )
        if args.keep is not None:
            args.keep.mkdir(parents=True, exist_ok=True)
            for out in folder.glob("o.*"):
                shutil.copy(out, args.keep / out.name)


if __name__ == "__main__":
    main()
