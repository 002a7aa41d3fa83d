"""The robot interface on a Universal Robots controller, through the ``ur-rtde`` client.

Built on ``rtde_control.RTDEControlInterface`` (moveJ, stopJ, isSteady),
``rtde_receive.RTDEReceiveInterface`` (actual joints, safety bits, timestamp)
and ``dashboard_client.DashboardClient`` (unlock protective stop, and the
safety status when a move fails: the stream may show a stop late). ur-rtde
speaks radians for joints, so no unit conversion is needed for joint moves;
Cartesian values (metres) are not used here.

How a move is followed (and why)
--------------------------------
``moveJ`` is sent *asynchronously* and the adapter polls, instead of the
client's blocking ``moveJ``: the blocking call only notices a dead link after
its own 300 s execution timeout, while polling lets us check, every few
milliseconds, that the RTDE stream is alive (timestamp advancing), that no
protective or emergency stop appeared, and that the move's own deadline holds.
The move is over when the control script reports its async operation finished;
then ``isSteady`` must be true and ``getActualQ`` must be within tolerance of
the target, else :class:`~drivers.robot.errors.MotionFailed`.

How a timed path is run (and recorded)
--------------------------------------
A path test needs the tool to pass its points at given times, which a
``movej`` cannot promise (its speed is a joint speed, its blends cut the
path). :meth:`UrRtdeRobot.follow_path` does what a UR does for a timed joint
trajectory: it streams ``servoJ`` set-points every :data:`SERVO_PERIOD_S`,
each the path at the host's time now (a late loop sends a later point, never
a stale one), and meanwhile records the controller's ``actual_q`` with its
``timestamp`` (RTDE receive) and the host's monotonic time each sample was
seen. :meth:`UrRtdeRobot.joint_stream` hands the record over once the run
ends: the robot's side of the path test's time alignment.
"""

import threading
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from calibrator.acquire import ports
from drivers.robot.errors import (
    ConnectionLost,
    DriverTimeout,
    EmergencyStop,
    LimitsViolation,
    MotionFailed,
    NotReady,
    ProtectiveStop,
)
from drivers.robot.interface import Robot, SafetyState, check_move_args
from drivers.robot.options import RobotOptions
from drivers.robot.safety import GuardedRobot, check_plan

#: ``robot_mode`` of an arm that is powered on with its brakes released (UR RTDE guide).
ROBOT_MODE_RUNNING = 7
#: Dashboard ``safetystatus`` values under which the arm may move (any other one is a stop).
SAFETY_MODES_RUNNING = frozenset({"NORMAL", "REDUCED", "RECOVERY"})
#: Longest wait, after a safety stop, for the control interface to show that the stop
#: ended its script (s); it takes milliseconds unless the host is loaded.
SCRIPT_END_WAIT_S = 2.0
#: servoJ period while a path runs, s (250 Hz, the path test's command rate; servoj's ``t``).
SERVO_PERIOD_S = 0.004
#: servoj's lookahead time (s, UR range 0.03-0.2) and gain (UR range 100-2000).
SERVO_LOOKAHEAD_S = 0.1
SERVO_GAIN = 300.0
#: Leading-joint speed (rad/s) and acceleration (rad/s^2) of the moveJ to a path's start.
LEAD_IN_SPEED_RAD_S = 0.5
LEAD_IN_ACCEL_RAD_S2 = 1.0


def lead_in_motion(limits: Any = None) -> tuple[float, float]:
    """Speed (rad/s) and acceleration (rad/s^2) of the moveJ to a path's start.

    :data:`LEAD_IN_SPEED_RAD_S` and :data:`LEAD_IN_ACCEL_RAD_S2`, lowered to
    the caps of ``limits`` (:class:`drivers.robot.safety.MotionLimits`) when
    given: a user's ``--max-speed`` holds for it too.
    """
    if limits is None:
        return LEAD_IN_SPEED_RAD_S, LEAD_IN_ACCEL_RAD_S2
    speed = min(LEAD_IN_SPEED_RAD_S, float(limits.max_speed_rad_s))
    if limits.max_joint_speed_rad_s is not None:
        speed = min(speed, float(np.min(limits.max_joint_speed_rad_s)))
    return speed, min(LEAD_IN_ACCEL_RAD_S2, float(limits.max_accel_rad_s2))


@dataclass(frozen=True)
class JointStream:
    """The controller's actual joints recorded while a path ran (RTDE receive).

    Attributes
    ----------
    t_s : ndarray, shape (R,)
        Controller timestamps of the samples, s (its clock, increasing).
    q_rad : ndarray, shape (R, 6)
        ``actual_q`` at those timestamps, rad.
    host_offset_s : float
        Host monotonic time = ``t_s + host_offset_s``: the smallest gap seen
        between a sample's arrival on the host and its timestamp (the link's
        least delay, sub-millisecond on a direct cable).
    start_host_s : float
        When the commanded path started, host monotonic time, s.
    """

    t_s: np.ndarray
    q_rad: np.ndarray
    host_offset_s: float
    start_host_s: float


def expected_move_time(
    q0: ArrayLike, q1: ArrayLike, speed_rad_s: float, accel_rad_s2: float
) -> float:
    """Duration of a synchronised trapezoidal joint move (as URScript ``movej``), s.

    Parameters
    ----------
    q0, q1 : array_like, shape (6,)
        Start and target joint angles, rad.
    speed_rad_s, accel_rad_s2 : float
        Leading-joint speed (rad/s) and acceleration (rad/s^2).
    """
    travel = float(np.max(np.abs(np.asarray(q1, float) - np.asarray(q0, float))))
    if travel * accel_rad_s2 <= speed_rad_s**2:  # triangular profile
        return 2.0 * float(np.sqrt(travel / accel_rad_s2))
    return travel / speed_rad_s + speed_rad_s / accel_rad_s2


class UrRtdeRobot(Robot):
    """A UR arm over RTDE.

    Parameters
    ----------
    host : str
        Controller address, given by the caller (no default: a driver never
        picks an address on its own).
    tolerance_rad : float, default 0.001
        Largest joint error accepted at the end of a move, rad.
    stale_after_s : float, default 1
        The link counts as lost when the RTDE timestamp has not advanced for
        this long, s (the controller streams at 500 Hz).
    timeout_margin_s : float, default 5
        Added to the expected move time to make a move's deadline, s.
    poll_s : float, default 0.002
        Polling period while a move runs, s.
    command_timeout_s : float, default 5
        Deadline of one control command (moveJ, stopJ, isSteady, ...), s; a
        command without an answer by then means the link is lost.
    """

    capabilities = frozenset({ports.MOVES_HARDWARE, ports.REPORTS_TEMPERATURES, ports.FOLLOW_PATH})

    #: Seconds a started move may take to show up as running (see :meth:`_wait_move`).
    start_grace_s = 0.1
    #: Seconds to wait for ``actual_q`` to catch up once steady (it lags ~1 period).
    settle_s = 0.1
    #: Seconds after a move's end for ``isSteady`` to become true.
    steady_timeout_s = 2.0

    def __init__(
        self,
        host: str,
        *,
        tolerance_rad: float = 1e-3,
        stale_after_s: float = 1.0,
        timeout_margin_s: float = 5.0,
        poll_s: float = 0.002,
        command_timeout_s: float = 5.0,
    ) -> None:
        if not host:
            raise ValueError("host is required")
        self.host = host
        self.tolerance_rad = float(tolerance_rad)
        self.stale_after_s = float(stale_after_s)
        self.timeout_margin_s = float(timeout_margin_s)
        self.poll_s = float(poll_s)
        self.command_timeout_s = float(command_timeout_s)
        # ur-rtde ships no type stubs: its clients are typed as Any.
        self._control: Any = None
        self._receive: Any = None
        self._dashboard: Any = None
        # commands on the control interface are register handshakes: one at a time
        self._cmd_lock = threading.Lock()
        self._stop_latch = False
        self._last_stamp: tuple[float, float] | None = None
        self._lost: str | None = None  # why the link was declared lost; no client call after that
        self._path: _PathRun | None = None  # the path running or last run (follow_path)

    # ------------------------------------------------------------ lifecycle
    def connect(self) -> None:
        import dashboard_client
        import rtde_control
        import rtde_receive

        self._lost = None
        try:
            self._receive = rtde_receive.RTDEReceiveInterface(self.host)
            if self._receive.getRobotMode() != ROBOT_MODE_RUNNING:
                # The control script would never start (ur-rtde then waits 60 s): say why now.
                try:
                    self._require_running_mode()
                finally:
                    self.close()
            self._control = rtde_control.RTDEControlInterface(self.host)
            self._dashboard = dashboard_client.DashboardClient(self.host)
            self._dashboard.connect()
        except RuntimeError as exc:
            estop = self._receive is not None and self._receive.isEmergencyStopped()
            pstop = self._receive is not None and self._receive.isProtectiveStopped()
            self.close()
            if estop or pstop:
                # Typed as the stop it is (a RobotHalted): the caller says "clear the stop".
                kind = EmergencyStop if estop else ProtectiveStop
                raise kind(f"UR controller at {self.host} is safety-stopped: {exc}") from exc
            raise ConnectionLost(f"could not connect to {self.host}: {exc}") from exc
        self._last_stamp = (self._receive.getTimestamp(), time.monotonic())
        # a robot that is stopped at connect time must be cleared explicitly too
        self._stop_latch = not self.safety_state().ok

    def close(self) -> None:
        if self._control is not None and not self._lost:
            try:
                # leave no control script running on the robot
                self._command(self._control.stopScript)
            except (ConnectionLost, NotReady):
                pass  # closing a dead link: nothing more to do
        control = self._control
        self._control = self._receive = self._dashboard = None
        # Dropping the last reference disconnects: the clients' destructors call
        # disconnect() themselves, and each disconnect blocks ~0.5 s, so an
        # explicit disconnect() first would only double the wait.
        del control

    # --------------------------------------------------------------- state
    def actual_joints(self) -> np.ndarray:
        self._check_link()
        return np.array(self._receive.getActualQ(), dtype=float)

    def joint_temperatures(self) -> np.ndarray:
        """The joints' temperatures the controller reports (RTDE ``joint_temperatures``), degC."""
        self._check_link()
        return np.array(self._receive.getJointTemperatures(), dtype=float)

    def safety_state(self) -> SafetyState:
        self._check_link()
        state = SafetyState(
            protective_stopped=bool(self._receive.isProtectiveStopped()),
            emergency_stopped=bool(self._receive.isEmergencyStopped()),
        )
        # a stop seen here must be cleared through us even if unlocked elsewhere
        self._stop_latch = self._stop_latch or not state.ok
        return state

    # -------------------------------------------------------------- motion
    def move_joints(self, q_rad: ArrayLike, speed_rad_s: float, accel_rad_s2: float) -> np.ndarray:
        target = check_move_args(q_rad, speed_rad_s, accel_rad_s2)
        self._check_link()
        self._raise_for_safety()
        if self._stop_latch:
            raise ProtectiveStop("the arm was safety-stopped; call clear_protective_stop() first")
        if not self._control.isProgramRunning():
            self._raise_for_reported_stop()
            raise NotReady(
                "the rtde_control script is not running (stopped on the pendant or by "
                "a safety stop); call clear_protective_stop() to restart it"
            )
        start = self.actual_joints()
        accepted = self._command(
            self._control.moveJ, target.tolist(), float(speed_rad_s), float(accel_rad_s2), True
        )
        if not accepted:
            self._check_link()
            self._raise_for_reported_stop()
            raise MotionFailed(f"controller refused moveJ to {target.tolist()}")
        deadline = expected_move_time(start, target, speed_rad_s, accel_rad_s2)
        self._wait_move(deadline + self.timeout_margin_s)
        return self._verify_reached(target)

    def follow_path(
        self,
        t_s: ArrayLike,
        q_rad: ArrayLike,
        delay_s: float = 0.0,
        *,
        start_host_s: float | None = None,
        lead_in: tuple[float, float] | None = None,
    ) -> int:
        """Start running a timed joint path; returns when it starts (host clock, us).

        Moves the arm to ``q_rad[0]`` first (moveJ, when it is not there), then
        returns while a thread holds it there for ``delay_s``, streams the path
        by servoJ (:data:`SERVO_PERIOD_S`), holds the end for ``delay_s`` more,
        and records the actual joints throughout. :meth:`joint_stream` waits
        for the end and gives the record.

        Parameters
        ----------
        t_s : array_like, shape (N,)
            Command times from the start of the motion, s, increasing from 0.
        q_rad : array_like, shape (N, 6)
            Joint commands at ``t_s``, rad (linear in between).
        delay_s : float
            Hold before and after the motion, s (0 to 10).
        start_host_s : float, optional
            Start the motion then instead (host monotonic time, s, within 10 s
            from now): a simulated tracker started at a known moment is joined
            exactly (:mod:`drivers.robot.ur.sim_cell`).
        lead_in : (float, float), optional
            Speed (rad/s) and acceleration (rad/s^2) of the moveJ to the start
            (default :func:`lead_in_motion`).

        Returns
        -------
        int
            The motion's start on the host's monotonic clock, microseconds (a
            UR knows no tracker's clock: the path test aligns the streams
            through the host's clock, :class:`JointStream`).

        Raises
        ------
        ValueError
            Times not increasing from 0, shapes, a delay outside 0..10 s.
        NotReady, ProtectiveStop, EmergencyStop, ConnectionLost
            As :meth:`move_joints`; ``NotReady`` too while a path still runs.
        """
        t = np.asarray(t_s, dtype=float)
        q = np.asarray(q_rad, dtype=float)
        if t.ndim != 1 or len(t) < 2 or q.shape != (len(t), 6):
            raise ValueError(f"a path is t_s (N >= 2,) and q_rad (N, 6), got {t.shape}, {q.shape}")
        if not (np.all(np.isfinite(t)) and np.all(np.isfinite(q))):
            raise ValueError("a path's times and joints must be finite")
        if t[0] != 0.0 or np.any(np.diff(t) <= 0):
            raise ValueError("a path's times must start at 0 and increase")
        if not 0.0 <= delay_s <= 10.0:
            raise ValueError(f"delay_s must be in 0..10 s, got {delay_s}")
        if self._path is not None and self._path.is_alive():
            raise NotReady("a path is still running: call joint_stream() for its end first")
        if np.max(np.abs(self.actual_joints() - q[0])) > self.tolerance_rad:
            self.move_joints(q[0], *(lead_in or lead_in_motion()))
        self._check_link()
        self._raise_for_safety()
        now = time.monotonic()
        start = now + float(delay_s) if start_host_s is None else float(start_host_s)
        if not now <= start <= now + 10.0:
            raise ValueError(f"the path's start is {start - now:.3f} s from now, not in 0..10 s")
        self._path = _PathRun(self, t, q, start, float(delay_s))
        self._path.start()
        return int(round(start * 1e6))

    def joint_stream(self) -> JointStream:
        """Wait for the path :meth:`follow_path` started to end; its recorded joints.

        Raises
        ------
        NotReady
            No path was started.
        DriverTimeout
            The run did not end by its deadline (the arm is stopped).
        ProtectiveStop, EmergencyStop, ConnectionLost
            The run ended on a stop or a lost link (the record is not given).
        """
        run = self._path
        if run is None:
            raise NotReady("no path was run: call follow_path() first")
        run.join(max(run.end_host_s - time.monotonic(), 0.0) + self.timeout_margin_s)
        if run.is_alive():
            run.abort = True
            run.join(self.command_timeout_s)
            self.stop()
            raise DriverTimeout("the path did not end by its deadline; stopped")
        if run.error is not None:
            raise run.error
        return run.record()

    def stop(self, decel_rad_s2: float = 2.0) -> None:
        """Stop any motion now with deceleration ``decel_rad_s2`` (rad/s^2).

        A path running (:meth:`follow_path`) is ended first: its thread would
        otherwise send the next set-point after the stop.
        """
        run = self._path
        if run is not None and run.is_alive() and run is not threading.current_thread():
            run.abort = True
            run.join(self.command_timeout_s)
        self._check_link()
        self._command(self._control.stopJ, float(decel_rad_s2))

    def clear_protective_stop(self, timeout_s: float = 6.0) -> None:
        """Unlock the protective stop (dashboard), restart the control script, lift the latch.

        A real controller refuses the unlock for 5 s after the stop, so the
        unlock is retried until ``timeout_s``; a refusal that lasts longer is
        :class:`~drivers.errors.NotReady`.

        A safety stop ends the control script, but the control interface
        learns that from its own RTDE stream, which a loaded host reads late:
        until then its ``isProgramRunning()`` is the ended script's, and a move
        sent on it fails with "RTDE control script is not running!". So after a
        stop the adapter has seen, the script is restarted once that view shows
        it ended (or after :data:`SCRIPT_END_WAIT_S`, when it never does), and
        only a start seen after that counts.
        """
        self._check_link()
        if self._receive.isEmergencyStopped():
            raise EmergencyStop("emergency stop engaged: an operator must release it")
        protective = self._receive.isProtectiveStopped()
        stopped = self._stop_latch or protective
        if protective:
            self._unlock(timeout_s)
            self._wait_for(
                lambda: not self._receive.isProtectiveStopped(),
                timeout_s,
                "protective stop to clear",
            )
        if stopped:
            self._wait_for_script_end(min(timeout_s, SCRIPT_END_WAIT_S))
        if stopped or not self._control.isProgramRunning():
            self._require_running_mode()
            self._command(self._control.reuploadScript)
            # reuploadScript returns before the program runs; a moveJ sent now would fail
            self._wait_for(self._control.isProgramRunning, timeout_s, "control script to start")
        self._stop_latch = False

    # ------------------------------------------------------------ internals
    def _require_running_mode(self):
        """Refuse when the arm is powered off or braked (after an e-stop): no program can run."""
        deadline = time.monotonic() + 0.2  # a brake release seen on the dashboard lags RTDE
        while (mode := self._receive.getRobotMode()) != ROBOT_MODE_RUNNING:
            if time.monotonic() > deadline:
                break
            time.sleep(0.01)
        if mode != ROBOT_MODE_RUNNING:
            raise NotReady(
                f"UR controller at {self.host} is not running (robot mode {mode}): power the "
                "arm on and release the brakes (pendant or dashboard), then retry"
            )

    def _wait_for_script_end(self, timeout_s):
        """Until the control interface shows no script running, at most ``timeout_s``.

        Not an error when it never does (a script someone restarted): restarting
        it, as ur-rtde's ``reuploadScript`` does, stops it first.
        """
        try:
            self._wait_for(
                lambda: not self._control.isProgramRunning(), timeout_s, "control script to end"
            )
        except DriverTimeout:
            pass

    def _unlock(self, timeout_s):
        deadline = time.monotonic() + timeout_s
        while True:
            try:
                self._dashboard.unlockProtectiveStop()
                return
            except RuntimeError as exc:  # the dashboard's refusal, e.g. "until 5s after"
                if time.monotonic() > deadline:
                    raise NotReady(
                        f"controller refused to unlock the protective stop: {exc}"
                    ) from exc
            self._check_link()
            time.sleep(0.5)

    def _wait_move(self, timeout_s):
        """Poll until the async move finished; raise on stop, lost link or deadline."""
        t0 = time.monotonic()
        seen_running = False
        while True:
            self._check_link()
            self._raise_for_safety()
            running = self._control.getAsyncOperationProgress() >= 0
            seen_running = seen_running or running
            elapsed = time.monotonic() - t0
            # right after moveJ a real script may not have started its move thread yet
            if not running and (seen_running or elapsed > self.start_grace_s):
                return
            if elapsed > timeout_s:
                self.stop()
                raise DriverTimeout(f"move did not finish within {timeout_s:.1f} s; stopped")
            time.sleep(self.poll_s)

    def _verify_reached(self, target):
        # a real arm reports steady only once fully at rest, a moment after the move
        deadline = time.monotonic() + self.steady_timeout_s
        while not self._command(self._control.isSteady):
            if time.monotonic() > deadline:
                self._raise_for_reported_stop()
                raise MotionFailed(f"arm not steady {self.steady_timeout_s} s after the move")
            time.sleep(0.01)
        t0 = time.monotonic()
        while True:
            q = self.actual_joints()
            error = np.abs(q - target)
            if np.max(error) <= self.tolerance_rad:
                return q
            if time.monotonic() - t0 > self.settle_s:
                break
            time.sleep(self.poll_s)
        # a stop that ended the move may reach the stream later than the move's end
        self._raise_for_reported_stop()
        joint = int(np.argmax(error))
        raise MotionFailed(
            f"move ended away from its target: joint {joint + 1} off by {error[joint]:.4g} rad "
            f"(tolerance {self.tolerance_rad:g} rad)"
        )

    def _command(self, method, *args):
        """Run a control-interface command with a deadline, one command at a time.

        Commands are register handshakes with the control script. On a link
        that died without the client noticing (no data, sockets open) the client
        keeps waiting on its stale state for up to its 300 s execution timeout,
        so the call runs in a daemon thread and is abandoned after
        ``command_timeout_s``: the link is then declared lost.
        """
        result, error = [], []

        def call():
            try:
                result.append(method(*args))
            except Exception as exc:  # re-raised in the caller's thread below
                error.append(exc)

        with self._cmd_lock:
            self._check_link()
            worker = threading.Thread(target=call, daemon=True, name="ur-rtde command")
            worker.start()
            worker.join(self.command_timeout_s)
        if worker.is_alive():
            self._lost = f"command {method.__name__} got no answer in {self.command_timeout_s} s"
            raise ConnectionLost(f"UR controller at {self.host}: {self._lost}")
        if error:
            if isinstance(error[0], RuntimeError):
                self._lost = str(error[0])
                raise ConnectionLost(f"UR controller at {self.host}: {error[0]}") from error[0]
            raise error[0]
        return result[0]

    def _check_link(self):
        if self._receive is None or self._control is None:
            raise NotReady("not connected; call connect() first")
        if self._lost:
            raise ConnectionLost(f"link to {self.host} lost earlier ({self._lost}); reconnect")
        if not (self._receive.isConnected() and self._control.isConnected()):
            self._lost = "RTDE connection closed"
            raise ConnectionLost(f"lost the RTDE connection to {self.host}")
        stamp, now = self._receive.getTimestamp(), time.monotonic()
        last_stamp, last_seen = self._last_stamp
        if stamp != last_stamp:
            self._last_stamp = (stamp, now)
        elif now - last_seen > self.stale_after_s:
            self._lost = f"no RTDE data for {now - last_seen:.2f} s"
            raise ConnectionLost(
                f"no RTDE data from {self.host} for {now - last_seen:.2f} s (controller hung up?)"
            )

    def _raise_for_safety(self):
        if self._receive is None:
            return
        if self._receive.isEmergencyStopped():
            self._stop_latch = True
            raise EmergencyStop("emergency stop engaged")
        if self._receive.isProtectiveStopped():
            self._stop_latch = True
            raise ProtectiveStop("protective stop: the controller stopped the arm")

    def _raise_for_reported_stop(self):
        """Raise the safety stop behind a failed move, asking the controller if need be.

        A move refused or ended early is often a stop that the receive stream
        has not shown yet: the control interface reads its own stream, which
        may be periods ahead (more on a loaded host). The dashboard answers
        from the controller's current state, so a stop that caused the failure
        is reported as that stop, not as a generic motion failure. Without an
        answer from the dashboard the caller's own error stands.
        """
        self._raise_for_safety()
        try:
            status = self._dashboard.safetystatus()
        except (RuntimeError, OSError):
            return
        mode = status.partition(":")[2].strip().upper()
        if "EMERGENCY_STOP" in mode:
            self._stop_latch = True
            raise EmergencyStop(f"emergency stop engaged (dashboard: {status.strip()})")
        if mode and mode not in SAFETY_MODES_RUNNING:
            self._stop_latch = True
            raise ProtectiveStop(f"the controller stopped the arm (dashboard: {status.strip()})")

    def _wait_for(self, condition, timeout_s, what):
        deadline = time.monotonic() + timeout_s
        while not condition():
            if time.monotonic() > deadline:
                raise DriverTimeout(f"timed out after {timeout_s:.1f} s waiting for {what}")
            self._check_link()
            time.sleep(self.poll_s)


class _PathRun(threading.Thread):
    """The thread of one :meth:`UrRtdeRobot.follow_path`: servoJ out, actual joints in."""

    def __init__(
        self, robot: UrRtdeRobot, t: np.ndarray, q: np.ndarray, start: float, hold_s: float
    ) -> None:
        super().__init__(daemon=True, name="ur-rtde path")
        self.robot, self.t, self.q = robot, t, q
        self.start_host_s = start
        self.end_host_s = start + float(t[-1]) + hold_s
        self.abort = False
        self.error: BaseException | None = None
        # (host time seen, controller timestamp, actual q) per new RTDE sample
        self.samples: list[tuple[float, float, list[float]]] = []

    def run(self) -> None:
        robot, receive, control = self.robot, self.robot._receive, self.robot._control
        last_stamp = None
        servoing = stopped = ended = False
        next_at = time.monotonic()
        try:
            while not self.abort:
                stamp = receive.getTimestamp()
                q = receive.getActualQ()
                seen = time.monotonic()
                if stamp != last_stamp:
                    self.samples.append((seen, stamp, q))
                    last_stamp = stamp
                if receive.isEmergencyStopped() or receive.isProtectiveStopped():
                    robot._raise_for_safety()
                if seen >= self.end_host_s:
                    break
                rel = seen - self.start_host_s
                if 0.0 <= rel and (rel <= self.t[-1] + 2 * SERVO_PERIOD_S or not ended):
                    # The path where it is now: a late cycle sends a later point, never a stale
                    # one; and its end before servoing stops, however late the loop ran.
                    target = [float(np.interp(rel, self.t, col)) for col in self.q.T]
                    ended = rel >= self.t[-1]
                    with robot._cmd_lock:
                        sent = control.servoJ(
                            target, 0.0, 0.0, SERVO_PERIOD_S, SERVO_LOOKAHEAD_S, SERVO_GAIN
                        )
                    if not sent:
                        robot._raise_for_reported_stop()
                        raise MotionFailed("the controller refused servoJ along the path")
                    servoing = True
                elif servoing and not stopped:
                    with robot._cmd_lock:
                        control.servoStop(10.0)
                    stopped = True
                next_at = max(next_at + SERVO_PERIOD_S, time.monotonic())
                time.sleep(max(next_at - time.monotonic(), 0.0))
            if servoing and not stopped:
                with robot._cmd_lock:
                    control.servoStop(10.0)
        except RuntimeError as exc:  # the client's own failure: the link is gone
            robot._lost = str(exc)
            self.error = ConnectionLost(f"UR controller at {robot.host}: {exc}")
        except Exception as exc:  # handed to joint_stream()'s caller
            self.error = exc

    def record(self) -> JointStream:
        seen = np.array([s[0] for s in self.samples])
        stamps = np.array([s[1] for s in self.samples])
        keep = np.concatenate([[True], np.diff(stamps) > 0]) if len(stamps) else stamps > 0
        return JointStream(
            t_s=stamps[keep],
            q_rad=np.array([s[2] for s in self.samples], dtype=float).reshape(-1, 6)[keep],
            host_offset_s=float(np.min(seen - stamps)) if len(seen) else float("nan"),
            start_host_s=self.start_host_s,
        )


class GuardedUr(GuardedRobot):
    """:class:`GuardedRobot` over a UR, its timed paths checked against the limits too."""

    def follow_path(
        self,
        t_s: ArrayLike,
        q_rad: ArrayLike,
        delay_s: float = 0.0,
        *,
        start_host_s: float | None = None,
    ) -> int:
        """:meth:`UrRtdeRobot.follow_path`, once every command is within the joint limits
        and no joint turns faster than the caps between two commands.

        Raises
        ------
        LimitsViolation
            A command out of limits, or a joint speed above a cap.
        """
        t = np.asarray(t_s, dtype=float)
        lead_in = lead_in_motion(self.limits)
        q = check_plan(q_rad, self.limits, *lead_in)
        if len(t) == len(q) and len(t) > 1 and np.all(np.diff(t) > 0):
            speed = np.abs(np.diff(q, axis=0)) / np.diff(t)[:, None]
            cap = np.full(6, self.limits.max_speed_rad_s)
            if self.limits.max_joint_speed_rad_s is not None:
                cap = np.minimum(cap, self.limits.max_joint_speed_rad_s)
            over = speed > cap
            if over.any():
                row, joint = np.argwhere(over)[0]
                raise LimitsViolation(
                    f"path command {row + 1} turns joint J{joint + 1} at "
                    f"{speed[row, joint]:.4g} rad/s, above its cap {cap[joint]:.4g} rad/s"
                )
        return self.robot.follow_path(  # type: ignore[attr-defined]
            t, q, delay_s, start_host_s=start_host_s, lead_in=lead_in
        )

    def joint_stream(self) -> JointStream:
        """The inner UR's :meth:`UrRtdeRobot.joint_stream`."""
        return self.robot.joint_stream()  # type: ignore[attr-defined]


def open_url(url: str, options: RobotOptions) -> Robot:
    """The robot registry's handler of ``ur://HOST``: the adapter behind the model's limits."""
    from drivers import urls
    from drivers.robot.safety import MotionLimits

    # The controller's ports are fixed (RTDE 30004, dashboard 29999): a host only.
    host = urls.parse(url, "ur", port="none").host
    limits = MotionLimits.from_model(
        options.model, options.max_speed_rad_s, options.max_accel_rad_s2
    )
    robot = GuardedUr(UrRtdeRobot(host), limits)
    robot.device_id = f"ur://{host}:{options.model.name}"
    return robot
