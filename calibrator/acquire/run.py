"""One measure run as an object: plan -> checks -> journal -> loop -> session file.

The cell sequence (:func:`calibrator.acquire.procedure.run`) opens the two
devices through its port and runs them here, for every procedure that
drives a robot past a tracker (``measure``, ``verify``, ``check``). How
the poses are measured is the strategy the run picks for its robot
(:mod:`calibrator.acquire.strategy`): a robot it commands, or an arm
running the plan as its own program (``--robot external``) whose stops the
tracker is watched for::

    run = MeasureRun(robot, tracker, model, RunOptions(plan=Plan(q)), output)
    run.connect()                      # tracker initialised? robot reachable?
    plan = run.make_plan()             # checked whole, size budget, robot's own check
    run.open_journal(confirm)          # new journal, or --resume (locked)
    outcome = run.measure()            # the loop (calibrator.acquire.loop)
    summary = run.finish()             # session written only when a pose was measured

Every refusal is a :class:`~calibrator.errors.CalibrationError` with one
line naming what was wrong; device failures during the loop end the run
cleanly (see :mod:`calibrator.acquire.loop`).
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from calibrator import outputs
from calibrator.acquire import journal as journals
from calibrator.acquire import loop, ports
from calibrator.acquire.external.arm import ProgramArm
from calibrator.acquire.strategy import Acquisition, acquisition_for
from calibrator.errors import CalibrationError
from calibrator.model import DEFAULT_TOOL_MM, frames

if TYPE_CHECKING:
    from calibrator.planning import Plan

#: Most poses a plan may hold: the most ``identify`` accepts
#: (``calibrator.identify.pipeline.MAX_POSES``), so no run measures a session
#: that cannot be identified. Kept here so measure does not import the solver.
MAX_POSES = 50_000


@dataclass(frozen=True)
class RunOptions(loop.LoopOptions):
    """What one measure run does: how each pose is measured, and the run around the loop.

    Every field has the CLI's default; those of :class:`~calibrator.acquire.loop.LoopOptions`
    are handed to the loop as they are (a run gives up after 5 failed poses in a row and
    pauses before a retry, where the bare loop does neither).

    Attributes
    ----------
    plan : calibrator.planning.Plan, optional
        The poses to measure (rad) and the vias moved through before each
        (never measured); None makes a plan of ``poses`` poses.
    poses : int
        Poses of a made plan.
    seed : int
        Seed of a made plan.
    readings, settle_s, retries, speed_rad_s, accel_rad_s2, retry_pause_s, give_up_after
        Inherited: see :class:`calibrator.acquire.loop.LoopOptions`.
    tool_mm : tuple of 3 float
        First guess of the reflector on the flange, mm.
    tracker_at_mm : tuple of 3 float, optional
        Rough tracker position in the robot base frame, mm (made plans face it).
    cell : calibrator.cell.Cell, optional
        The robot's surroundings (mounting plane, obstacles, tracker range);
        every pose and move of the plan is checked against it before the
        first motion. None: the default cell (:class:`calibrator.cell.Cell`).
    resume : bool
        Continue the run recorded in the journal beside the output.
    force : bool
        Replace an existing output (``--force``); a journal is still only
        resumed or removed.
    lead_in : bool
        Before the first pose still to measure, move to the plan row before it
        (row 0: the last row), so that pose is approached as in an
        uninterrupted run of a cyclic plan, also after a resume (backlash).
    need_poses : int, optional
        Fewest poses the plan must hold; default what identification needs.
    """

    retry_pause_s: float = 0.2
    give_up_after: int = 5
    plan: Plan | None = None
    poses: int = 40
    seed: int = 0
    tool_mm: tuple[float, float, float] = DEFAULT_TOOL_MM
    tracker_at_mm: tuple[float, float, float] | None = None
    cell: Any = None
    resume: bool = False
    force: bool = False
    lead_in: bool = False
    need_poses: int | None = None


@dataclass
class Summary:
    """How a run ended, for the one-line report.

    Attributes
    ----------
    written : Path or None
        The session file, or None when none was written.
    measured, failed : list of int
        Plan rows measured and given up.
    total : int
        Poses in the plan.
    stopped : str or None
        Why the run ended early (None: every pose was visited).
    causes : collections.Counter
        Lost readings by failure class over the failed poses ("beam broken": 48).
    journal : Path
    complete : bool
        Every pose measured; the journal was removed.
    notes : list of str
        The acquisition's own end-of-run lines (an arm running its own
        program: poses it skipped, stops that matched no pose).
    """

    written: Path | None
    measured: list[int]
    failed: list[int]
    total: int
    stopped: str | None
    causes: Counter = field(default_factory=Counter)
    journal: Path = Path()
    complete: bool = False
    notes: list[str] = field(default_factory=list)

    @property
    def exit_code(self) -> int:
        """0 when a session was written and the run was not cut short, else 1."""
        return 0 if self.written is not None and self.stopped is None else 1

    def causes_text(self) -> str:
        """``beam broken x48, tracker timeout x2`` (most frequent first)."""
        return ", ".join(f"{what} x{n}" for what, n in self.causes.most_common())


class MeasureRun:
    """One measure run over a connected-on-demand robot and tracker.

    Parameters
    ----------
    robot : calibrator.acquire.ports.Robot or calibrator.acquire.external.arm.ProgramArm
        A robot the run commands, or an arm running the plan as its own
        program (the run then watches the tracker for its stops).
    tracker : calibrator.acquire.ports.Tracker
    model : calibrator.robots.RobotDescription
        The named arm (nominal MDH, joint limits).
    options : RunOptions
    output : Path
        Session file to write; its journal is beside it.
    tracker_at_mm : array_like, shape (3,), optional
        Where the devices say the tracker stands (robot base frame, mm: the
        simulated cell's, :attr:`calibrator.acquire.ports.Opened.tracker_at_mm`),
        used when the options give no position.
    """

    def __init__(
        self,
        robot: ports.Robot | ProgramArm,
        tracker: ports.Tracker,
        model: Any,
        options: RunOptions,
        output: Path,
        *,
        tracker_at_mm: npt.ArrayLike | None = None,
    ) -> None:
        self.robot, self.tracker, self.model = robot, tracker, model
        self.options = options
        self.output = Path(output)
        self.journal_path = journals.journal_path(self.output)
        self.flange2tool_guess = frames.transform(translation=np.asarray(options.tool_mm, float))
        self.acquisition: Acquisition = acquisition_for(robot, tracker, model.mdh, options.tool_mm)
        # Where the tracker is: --tracker-at, else the cell file's, else the
        # devices' (a simulated cell's tracker, placed at either of the first two).
        given: npt.ArrayLike | None = tracker_position(options)
        if given is None:
            given = tracker_at_mm
        self.tracker_at_mm = None if given is None else np.array(given, dtype=float).reshape(3)
        self.plan: Plan | None = None
        self.journal: journals.Journal | None = None
        self.done: dict = {}
        self.outcome: loop.Outcome | None = None
        self._connected: list = []

    # ------------------------------------------------------------ steps

    def check_files(self) -> None:
        """Refuse to start over an existing session or journal, or to resume nothing."""
        output, jpath = self.output, self.journal_path
        if not self.options.resume and not self.options.force and output.exists():
            raise outputs.existing(output, resumable=True)
        if not self.options.resume and jpath.exists():
            raise CalibrationError(
                f"{jpath} exists (an unfinished run): pass --resume to continue it, or remove it"
            )
        if self.options.resume and not jpath.exists():
            raise CalibrationError(f"nothing to resume: {jpath} not found")

    def connect(self, tracker_url: str = "the tracker") -> None:
        """Connect the tracker (it must be initialised), then the robot.

        Raises
        ------
        CalibrationError
            The tracker cannot be reached or is not initialised, or the robot
            cannot be reached.
        """
        try:
            status = self.tracker.connect()
        except (ports.PortError, OSError) as exc:
            raise CalibrationError(f"tracker at {tracker_url}: {exc}") from None
        finally:
            self._connected.append(self.tracker)
        if not status.initialised:
            raise CalibrationError(
                f"tracker at {tracker_url} is not initialised: run `calibrator tracker init "
                f"--tracker {tracker_url}` (it moves the head), then measure again"
            )
        self._connected.append(self.robot)
        try:
            self.robot.connect()
        except (ports.PortError, OSError) as exc:
            raise CalibrationError(f"robot {self.robot_id}: {exc}") from None

    @property
    def robot_id(self) -> str:
        return str(getattr(self.robot, "device_id", "") or type(self.robot).__name__)

    @property
    def tracker_id(self) -> str:
        return str(self.tracker.device_id or type(self.tracker).__name__)

    @property
    def moves_hardware(self) -> bool:
        return ports.MOVES_HARDWARE in self.robot.capabilities

    def make_plan(self, on_note: Callable[[str], None] = lambda text: None) -> Plan:
        """The plan, checked whole before anything moves (limits, count, size, robot's caps).

        Raises
        ------
        CalibrationError
            A plan (or its via poses) outside the limits, too short, larger
            than :data:`MAX_POSES`, or refused by the robot's own check.
        """
        from calibrator import cell as cells
        from calibrator import planning

        opts = self.options
        cell = (opts.cell if opts.cell is not None else cells.Cell()).with_tracker(
            self.tracker_at_mm
        )
        plan = opts.plan
        if plan is None:
            if self.tracker_at_mm is None:
                on_note("no --tracker-at: the plan ignores the acceptance angle")
            # The one planner of `calibrator plan`: every pose and move clear
            # of the mounting plane, the arm itself and the cell, in time order.
            plan = planning.make_checked(
                self.model, opts.poses, cell, opts.tool_mm, seed=opts.seed
            ).plan
        if len(plan.q_rad) > MAX_POSES:
            raise CalibrationError(
                f"plan has {len(plan.q_rad)} poses; identify takes at most {MAX_POSES}: "
                "thin the plan (a well-spread subset identifies as well)"
            )
        need = opts.need_poses
        if need is None:
            need = planning.min_poses(self.model.mdh)
        # Before anything moves, the one whole-plan check every runner uses
        # (``calibrator program`` too): limits, count, every pose, via and
        # joint-space move against the arm's capsules, the cell and the tracker.
        planning.check_plan(plan, self.model, cell, opts.tool_mm, need=need)
        try:
            self.acquisition.check_plan(plan.q_rad, list(plan.via_rad), opts)
        except ValueError as exc:
            raise CalibrationError(str(exc)) from None
        self.plan = plan
        return plan

    def estimate(self) -> Any:
        """The cell time of the checked plan: moves at the run's speed, settle, readings.

        Returns
        -------
        calibrator.cell.CellTime
        """
        from calibrator import planning

        if self.plan is None:
            raise CalibrationError("no plan yet: call make_plan first")
        o = self.options
        return planning.estimate(
            self.plan,
            self.model,
            o.speed_rad_s,
            o.accel_rad_s2,
            settle_s=o.settle_s,
            readings=o.readings,
        )

    def header(self, meta: Any) -> dict:
        """The journal header: what a resume must match."""
        from calibrator import planning

        assert self.plan is not None, "make_plan() first"
        return {
            "plan_sha256": planning.digest(self.plan.q_rad),
            "robot": self.robot_id,
            "tracker": self.tracker_id,
            "readings": self.options.readings,
            "poses": len(self.plan.q_rad),
            "meta": meta.to_json(),
        }

    def session_meta(self) -> Any:
        """The session's metadata (nominal arm, tool guess, devices and the plan's digest)."""
        from calibrator import planning, session

        assert self.plan is not None, "make_plan() first"

        return session.SessionMeta(
            frame="tracker",
            nominal_mdh=self.model.mdh,
            model=self.model.name,
            flange2tool=self.flange2tool_guess,
            tool_known=False,
            extra={
                "measured": {
                    "robot": self.robot_id,
                    "tracker": self.tracker_id,
                    "plan_sha256": planning.digest(self.plan.q_rad),
                    # Which description of the arm: the same name may be edited.
                    "description": {"name": self.model.name, "sha256": self.model.digest},
                }
            },
        )

    def open_journal(self, confirm: Callable[[str, int], None] | None = None) -> None:
        """Create the journal, or (resume) lock and check it; ``confirm(robot_id, n)`` first.

        ``confirm`` is called before a robot that moves hardware moves
        through ``n`` poses; it raises to refuse.
        """
        self.meta = self.session_meta()
        header = self.header(self.meta)
        assert self.plan is not None
        if self.options.resume:
            self.journal, resumed = journals.Journal.resume(
                self.journal_path,
                header,
                plan_rad=self.plan.q_rad,
                convention=self.model.convention,
            )
            self.done = resumed.records
            try:
                self._check_own_session(header)
            except CalibrationError:
                self.journal.close()
                raise
            left = len(self.plan.q_rad) - sum(r["status"] == "measured" for r in self.done.values())
        else:
            left = len(self.plan.q_rad)
        if self.moves_hardware and confirm is not None:
            try:
                confirm(self.robot_id, left)
            except BaseException:
                self.close()
                raise
        if not self.options.resume:
            self.journal = journals.Journal.create(self.journal_path, header, self.model.convention)

    def _check_own_session(self, header: dict) -> None:
        """On resume, an existing session file must be one this run wrote (else it is not ours)."""
        if not self.output.exists():
            return
        import json

        import pyarrow.parquet as pq

        from calibrator.session import META_KEY

        try:
            meta = json.loads((pq.read_schema(self.output).metadata or {})[META_KEY])
            measured = meta["measured"]
            ours = all(measured[key] == header[key] for key in ("plan_sha256", "robot", "tracker"))
        except (OSError, ValueError, KeyError, TypeError):
            ours = False
        if not ours:
            raise CalibrationError(
                f"{self.output} exists and was not written by the run in {self.journal_path}: "
                "move it away, then resume"
            )

    def measure(
        self,
        *,
        should_stop: Callable[[], bool] = lambda: False,
        on_pose: Callable[[loop.Progress], None] | None = None,
        on_beam_lost: Callable[[int, int], None] | None = None,
    ) -> loop.Outcome:
        """Every pose not finished yet, as the run's acquisition measures them.

        See :func:`calibrator.acquire.loop.run` (a commanded robot) and
        :class:`calibrator.acquire.external.watched.Watched` (an arm running its
        own program).
        """
        assert self.plan is not None and self.journal is not None
        o = self.options
        via_rad = self._with_lead_in(self.plan)
        hooks = loop.Hooks(self.done, via_rad, None, should_stop, on_pose, on_beam_lost)
        self.outcome = self.acquisition.measure(self.plan.q_rad, self.journal, o, hooks)
        # The journal stays open, and so locked, until finish() has removed it:
        # a --resume started in between must find it in use, not half gone.
        return self.outcome

    def _with_lead_in(self, plan: Plan) -> Sequence[np.ndarray]:
        """The plan's via poses, plus the lead-in before the first pose still to measure."""
        if not self.options.lead_in:
            return plan.via_rad
        q = plan.q_rad
        todo = [i for i in range(len(q)) if self.done.get(i, {}).get("status") != "measured"]
        if not todo:
            return plan.via_rad
        first = todo[0]
        vias = list(plan.via_rad)
        # A plan row, so already inside the limits and the robot's plan check.
        vias[first] = np.concatenate([vias[first], q[first - 1][None]])
        return vias

    def finish(self, write: Callable[[loop.Outcome], Path | None] | None = None) -> Summary:
        """Write the result when at least one pose was measured; never claim one otherwise.

        ``write(outcome)`` writes the result and returns its path (or None
        when it wrote nothing); default: the session file. The journal stays
        (for ``--resume``) unless every pose was measured and the result written.
        """
        assert self.outcome is not None and self.plan is not None
        outcome = self.outcome
        measured, failed = outcome.measured, outcome.failed
        causes: Counter = Counter()
        for pose in failed:
            causes.update(outcome.records[pose].get("causes", {}))
        written = None
        if measured:
            written = (write or self.write_session)(outcome)
        complete = written is not None and not failed and outcome.stopped is None
        if complete:
            self.journal_path.unlink()
        if self.journal is not None:
            self.journal.close()  # releases the lock, after the unlink
        notes = self.acquisition.notes()
        return Summary(
            written,
            measured,
            failed,
            len(self.plan.q_rad),
            outcome.stopped,
            causes,
            self.journal_path,
            complete,
            notes,
        )

    def write_session(self, outcome: loop.Outcome) -> Path:
        """The session file of ``outcome``'s measured poses (``measure``'s document)."""
        from calibrator import session
        from calibrator.acquire import rows

        table = rows.to_table(outcome.records.values(), self.model.convention)
        session.write(self.output, table, self.meta)
        return self.output

    def close(self) -> None:
        """Close the journal and every device connected (reverse order); safe to call twice."""
        if self.journal is not None:
            self.journal.close()
        while self._connected:
            device = self._connected.pop()
            try:
                device.close()
            except OSError:
                pass  # closing a link that already failed: nothing left to release

    def __enter__(self) -> MeasureRun:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def tracker_position(options: RunOptions) -> tuple[float, float, float] | None:
    """The tracker's position the run was given (robot base frame, mm), or None.

    ``--tracker-at`` wins over the cell file's ``tracker.at_mm``; a simulated
    tracker is placed there too, so a cell file's tracker is never silently
    replaced by the simulator's default position.
    """
    if options.tracker_at_mm is not None:
        return options.tracker_at_mm
    cell = options.cell
    return None if cell is None else cell.tracker_at_mm
