"""The fake controller's state: a 6-joint arm, safety flags and the control script's register loop.

One :class:`FakeController` is shared by the RTDE, dashboard and script servers
of the fake. :meth:`FakeController.tick` runs at the controller period
(2 ms) and does what ``rtde_control.script`` does each ``sync()``: it reads
the command register the client wrote, executes the command and answers on the
output registers. Motion is simulated time; ``time_scale`` makes it run faster
than the wall clock so tests stay short.

The arm is a named model from :mod:`calibrator.robots` (UR5e by default);
``actual_TCP_pose`` is its nominal forward kinematics with the TCP set by
``setTcp``, the rotation as :func:`calibrator.model.rotations.matrix_to_rotvec` gives it
(the one conversion of the project, exact near pi).

Power and brakes follow a real controller: an e-stop powers the arm off;
the dashboard's ``power on`` (POWER_OFF -> IDLE), ``brake release``
(IDLE -> RUNNING) and ``power off`` drive ``robot_mode``, and no program runs
until the mode is RUNNING. ``unlock protective stop`` is refused for 5 s after
the stop and whenever no protective stop is active. A control-script command
the fake does not emulate stops the program (as a script error on a real
controller), so the client's call fails visibly instead of reporting success.

Register protocol (ur-rtde 1.6.5): ``output_int_register_0`` is 1 when the script
is ready for a command and 2 when it has finished one; the client then writes
NO_CMD (0) and the script answers ready again.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from calibrator import robots
from calibrator.model import frames, kinematics, rotations

# runtime_state values (UR RTDE guide)
RUNTIME_STOPPED = 1
RUNTIME_PLAYING = 2

# safety_status_bits
SAFETY_NORMAL = 1 << 0
SAFETY_PROTECTIVE_STOPPED = 1 << 2
SAFETY_EMERGENCY_STOPPED = 1 << 7

# robot_status_bits: bit 0 power on, bit 1 program running
STATUS_POWER_ON = 1 << 0
STATUS_PROGRAM_RUNNING = 1 << 1

# control script commands (RTDE::RobotCommand::Type in ur-rtde)
CMD_NO_CMD = 0
CMD_MOVEJ = 1
CMD_SERVOJ = 11
CMD_SERVO_STOP = 16
CMD_SET_TCP = 29
CMD_PROTECTIVE_STOP = 31
CMD_STOPL = 33
CMD_STOPJ = 34
CMD_IS_STEADY = 47
CMD_STOP_SCRIPT = 255
# commands the script treats as real-time: processed without the done handshake
REALTIME_CMDS = {24, 11, 9, 10, 6, 25, 26, 27, 38, 58, 66, 67, 68, 69, 70, 71}

READY = 1
DONE = 2

# robot_mode values (UR RTDE guide / dashboard "robotmode")
ROBOT_MODES = {3: "POWER_OFF", 5: "IDLE", 7: "RUNNING"}
MODE_POWER_OFF, MODE_IDLE, MODE_RUNNING = 3, 5, 7
#: Seconds a real controller refuses "unlock protective stop" after the stop.
UNLOCK_DELAY_S = 5.0

# A plausible UR5e pose away from singularities (rad).
#: The fake arm's joint temperatures (RTDE ``joint_temperatures``): the room, degC,
#: the rise of each joint once warm (shoulder and elbow motors the most), degC, and
#: the time constant of the warming, s of controller time.
ROOM_C = 22.0
JOINT_RISE_C = np.array([9.0, 12.0, 10.0, 6.0, 5.0, 5.0])
WARM_TAU_S = 1800.0
HOME_Q = np.array([0.0, -1.5708, 1.5708, -1.5708, -1.5708, 0.0])


def safety_mode(bits: int) -> int:
    """RTDE ``safety_mode`` of ``safety_status_bits``: 1 NORMAL, 3 PROTECTIVE_STOP, 7 E-STOP."""
    if bits & SAFETY_EMERGENCY_STOPPED:
        return 7
    if bits & SAFETY_PROTECTIVE_STOPPED:
        return 3
    return 1


def tcp_pose(
    q: ArrayLike, mdh: ArrayLike | None = None, flange2tcp: ArrayLike | None = None
) -> np.ndarray:
    """TCP pose as UR reports it: ``[x, y, z, rx, ry, rz]`` (m, rotation vector in rad).

    Parameters
    ----------
    q : array_like, shape (6,)
        Joint angles, rad.
    mdh : array_like, shape (6, 5), optional
        The arm's table (mm, rad); default the nominal UR5e.
    flange2tcp : array_like, shape (4, 4), optional
        TCP in the flange frame (mm), as set by ``setTcp``; default the flange.
    """
    mdh = robots.get("ur5e").mdh if mdh is None else mdh
    pose = kinematics.forward(mdh, np.asarray(q, float)[None], flange2tcp)[0]
    return np.concatenate([pose[:3, 3] / 1000.0, rotations.matrix_to_rotvec(pose[:3, :3])])


class _JointMove:
    """A synchronised joint move: trapezoidal profile on the leading joint, others scaled.

    Like URScript ``movej``: every joint starts and stops together, the joint
    with the largest travel moves at ``speed``/``accel``.
    """

    def __init__(self, q0, q1, speed, accel):
        self.q0 = np.asarray(q0, float)
        self.delta = np.asarray(q1, float) - self.q0
        self.length = float(np.max(np.abs(self.delta)))
        speed = max(float(speed), 1e-6)
        accel = max(float(accel), 1e-6)
        t_acc = speed / accel
        if accel * t_acc**2 >= self.length:  # never reaches full speed: triangular
            t_acc = np.sqrt(self.length / accel) if self.length > 0 else 0.0
            speed = accel * t_acc
        self.speed, self.accel, self.t_acc = speed, accel, t_acc
        cruise = (self.length - accel * t_acc**2) / speed if self.length > 0 else 0.0
        self.duration = 2 * t_acc + max(cruise, 0.0)
        self.t = 0.0

    @property
    def finished(self):
        return self.t >= self.duration

    def advance(self, dt):
        """Advance by ``dt`` seconds of simulated time; returns ``(q, qd)`` in rad, rad/s."""
        self.t = min(self.t + dt, self.duration)
        if self.length == 0:
            return self.q0 + self.delta, np.zeros(6)
        t, a, ta, v, dur = self.t, self.accel, self.t_acc, self.speed, self.duration
        if t < ta:
            s, sd = 0.5 * a * t**2, a * t
        elif t <= dur - ta:
            s, sd = 0.5 * a * ta**2 + v * (t - ta), v
        else:
            rest = dur - t
            s, sd = self.length - 0.5 * a * rest**2, a * rest
        direction = self.delta / self.length
        return self.q0 + direction * s, direction * sd


class _Streamed:
    """A controller value and its recent changes, which the RTDE stream may report late.

    Test hook: two streams, or one starved client thread, can show a change at
    different moments. With ``lag_s`` set, :meth:`streamed` is the value as it
    was ``lag_s`` ago, but never older than the moment the lag was set, so
    changes from before it (another test's stop) are not played again.
    """

    def __init__(self, value: int) -> None:
        self.value = value
        self.lag_s = 0.0
        self.lag_since = 0.0
        self.log: list[tuple[float, int]] = [(time.monotonic(), value)]  # (monotonic time, value)

    def set(self, value: int) -> None:
        self.value = value
        self.log = [*self.log[-15:], (time.monotonic(), value)]

    def set_lag(self, lag_s: float) -> None:
        self.lag_s = float(lag_s)
        self.lag_since = time.monotonic()

    def streamed(self) -> int:
        if self.lag_s <= 0:
            return self.value
        seen = max(time.monotonic() - self.lag_s, self.lag_since)
        reported = [value for t, value in self.log if t <= seen]
        return reported[-1] if reported else self.log[0][1]


class FakeController:
    """State of the fake UR controller, advanced by :meth:`tick`.

    Parameters
    ----------
    time_scale : float
        Simulated seconds per wall-clock second for motion (10 = moves run ten
        times faster than on a robot).
    initial_q : array_like, shape (6,), optional
        Starting joint angles, rad. Default :data:`HOME_Q`.
    model : str
        Named model of :mod:`calibrator.robots` (``ur5e``, ``ur10e``).
    unlock_delay_s : float
        Refuse ``unlock protective stop`` this long after a stop, s (5 on a
        real controller; tests may shorten it).
    """

    period_s = 0.002  # 500 Hz, as an e-Series controller

    def __init__(
        self,
        time_scale: float = 1.0,
        initial_q: ArrayLike | None = None,
        model: str = "ur5e",
        unlock_delay_s: float = UNLOCK_DELAY_S,
    ) -> None:
        if time_scale <= 0:
            raise ValueError(f"time_scale must be > 0, got {time_scale}")
        self.time_scale = float(time_scale)
        self.lock = threading.RLock()
        self.q = np.array(HOME_Q if initial_q is None else initial_q, dtype=float)
        self.qd = np.zeros(6)
        self.target_q = self.q.copy()
        self._move: _JointMove | None = None
        # servoJ's latest target while servoing (rad), else None (see _advance)
        self._servo_target: np.ndarray | None = None
        # controller time of the last cycle, s: the RTDE timestamp of the joints it reports
        self._cycle_s: float | None = None
        self.cycles = 0  # cycles run; the RTDE stream sends after each (wait_cycle)
        self._cycle_done = threading.Condition(self.lock)
        self._move_is_sync = False  # a sync movej holds the script until it ends
        self._busy = False
        self._executing_cmd = False
        # What the stream reports of these two may lag (test hooks: set_safety_lag,
        # set_program_lag); the dashboard and the script loop see them as they are.
        self._runtime = _Streamed(RUNTIME_STOPPED)
        self._safety = _Streamed(SAFETY_NORMAL)
        self.estop_at_movej = 0  # test hook: the n-th MOVEJ from now is an e-stop instead
        self.reg_offset = 0
        self.out_int = np.zeros(48, dtype=np.int64)
        self.out_double = np.zeros(48)
        self.in_int = np.zeros(48, dtype=np.int64)
        self.in_double = np.zeros(48)
        self._async_wr_count = 0
        self._async_op_id = 0
        self.frozen_timestamp: float | None = (
            None  # test hook: keep streaming, repeat this timestamp
        )
        self._t0 = time.monotonic()
        self.stalled = False  # test hook: stop streaming, keep sockets open
        self.unlock_delay_s = float(unlock_delay_s)
        self.model = robots.get(model)
        self.flange2tcp = np.eye(4)  # setTcp changes it (mm)
        self.robot_mode = MODE_RUNNING
        self._protective_since: float | None = None
        self.log: list[str] = []  # commands executed, for the fake's own tests

    # ----------------------------------------------------------------- state
    @property
    def safety_bits(self) -> int:
        """``safety_status_bits`` now (the dashboard's view)."""
        return self._safety.value

    @safety_bits.setter
    def safety_bits(self, bits: int) -> None:
        self._safety.set(bits)

    @property
    def runtime_state(self) -> int:
        """``runtime_state`` now (the dashboard's ``programState``, the script loop's)."""
        return self._runtime.value

    @runtime_state.setter
    def runtime_state(self, state: int) -> None:
        self._runtime.set(state)

    @property
    def safety_lag_s(self) -> float:
        return self._safety.lag_s

    @property
    def program_lag_s(self) -> float:
        return self._runtime.lag_s

    def set_safety_lag(self, lag_s: float) -> None:
        """Test hook: from now on the stream shows safety changes ``lag_s`` late."""
        with self.lock:
            self._safety.set_lag(lag_s)

    def set_program_lag(self, lag_s: float) -> None:
        """Test hook: from now on the stream shows the program start and end ``lag_s`` late.

        ``runtime_state`` and the program-running bit of ``robot_status_bits``, as a
        client's starved receive thread would: the control interface then says a
        program runs that a safety stop has already ended.
        """
        with self.lock:
            self._runtime.set_lag(lag_s)

    def streamed_safety_bits(self) -> int:
        """``safety_status_bits`` as the RTDE stream reports it: ``safety_lag_s`` old."""
        return self._safety.streamed()

    def timestamp(self) -> float:
        """Controller time since start, s (the RTDE ``timestamp``)."""
        if self.frozen_timestamp is not None:
            return self.frozen_timestamp
        return time.monotonic() - self._t0

    def joint_temperatures_c(self) -> np.ndarray:
        """The joints' temperatures, degC: the room plus a rise that settles as the arm runs.

        Each joint warms from :data:`ROOM_C` towards its own rise
        (:data:`JOINT_RISE_C`) with the time constant :data:`WARM_TAU_S`
        (controller time): what a real arm reports over its first hour.
        """
        warmed = 1.0 - np.exp(-self.timestamp() / WARM_TAU_S)
        return ROOM_C + JOINT_RISE_C * warmed

    def snapshot(self) -> dict[str, Any]:
        """Values of the outputs a client may request, by RTDE name (units as UR: m, rad)."""
        with self.lock:
            runtime = self._runtime.streamed()
            playing = runtime == RUNTIME_PLAYING
            streamed = self.streamed_safety_bits()
            # The joints are those of the last cycle: its time stamps them, as on a controller.
            stamp = self._cycle_s if self.frozen_timestamp is None else None
            values = {
                "timestamp": self.timestamp() if stamp is None else stamp,
                "actual_q": tuple(self.q),
                "target_q": tuple(self.target_q),
                "actual_qd": tuple(self.qd),
                "target_qd": tuple(self.qd),
                "actual_TCP_pose": tuple(tcp_pose(self.q, self.model.mdh, self.flange2tcp)),
                "target_TCP_pose": tuple(tcp_pose(self.target_q, self.model.mdh, self.flange2tcp)),
                "runtime_state": runtime,
                "robot_mode": self.robot_mode,
                "joint_mode": (253,) * 6,  # JOINT_RUNNING_MODE
                "safety_mode": safety_mode(streamed),
                "safety_status": safety_mode(streamed),
                "safety_status_bits": streamed,
                "robot_status_bits": (STATUS_POWER_ON if self.robot_mode != MODE_POWER_OFF else 0)
                | (STATUS_PROGRAM_RUNNING if playing else 0),
                "speed_scaling": 1.0,
                "target_speed_fraction": 1.0,
                "joint_temperatures": tuple(self.joint_temperatures_c()),
            }
            for i in range(48):
                values[f"output_int_register_{i}"] = int(self.out_int[i])
                values[f"output_double_register_{i}"] = float(self.out_double[i])
                values[f"input_int_register_{i}"] = int(self.in_int[i])
                values[f"input_double_register_{i}"] = float(self.in_double[i])
        return values

    @property
    def moving(self) -> bool:
        return self._move is not None or self._servo_target is not None

    def write_inputs(self, values: Mapping[str, float]) -> None:
        """Store input registers the client sent (``{"input_int_register_3": 7, ...}``).

        A package that writes the command register is a new command, even when
        the register already holds the same value: a command the client wrote
        while no program ran (then cleared too late for the new program to see)
        would otherwise be taken for the one it sends next, and that one would
        never be answered.
        """
        with self.lock:
            if f"input_int_register_{self.reg_offset}" in values:
                self._executing_cmd = False
            for name, value in values.items():
                kind, _, index = name.rpartition("_")
                if not index.isdigit() or int(index) >= 48:
                    continue
                if kind == "input_int_register":
                    self.in_int[int(index)] = value
                elif kind == "input_double_register":
                    self.in_double[int(index)] = value

    # ------------------------------------------------------------- programs
    def start_program(self, reg_offset: int = 0) -> None:
        """A ``def rtde_control():`` program arrived on the script port: start its loop."""
        with self.lock:
            if self.safety_bits & (SAFETY_PROTECTIVE_STOPPED | SAFETY_EMERGENCY_STOPPED):
                self.log.append("program refused: safety stop")
                return  # a real controller will not run a program while safety-stopped
            if self.robot_mode != MODE_RUNNING:
                self.log.append(f"program refused: robot mode {ROBOT_MODES[self.robot_mode]}")
                return  # nor while powered off or with the brakes on
            self._halt()
            self.reg_offset = int(reg_offset)
            # A command left in the register by the previous program (or one the client
            # wrote while none ran) is not executed again: a real program takes long
            # enough to start that the client's NO_CMD arrives first.
            self._executing_cmd = int(self.in_int[self.reg_offset]) != CMD_NO_CMD
            self._busy = False
            self.runtime_state = RUNTIME_PLAYING
            self._write_async_progress(-1)
            self._out_int(0, READY)
            self.log.append("program started")

    def stop_program(self) -> None:
        """Dashboard ``stop`` or STOP_SCRIPT: the program ends and the arm halts."""
        with self.lock:
            self._halt()
            self.runtime_state = RUNTIME_STOPPED
            self._busy = False
            self._executing_cmd = False
            self.log.append("program stopped")

    def protective_stop(self) -> None:
        """Safety system trips: the arm halts, the program stops, bit 2 is raised."""
        with self.lock:
            self.stop_program()
            self.safety_bits = (self.safety_bits | SAFETY_PROTECTIVE_STOPPED) & ~SAFETY_NORMAL
            self._protective_since = time.monotonic()
            self.log.append("protective stop")

    def emergency_stop(self) -> None:
        """E-stop pressed: the program stops, bit 7 is raised and the arm is powered off."""
        with self.lock:
            self.stop_program()
            self.safety_bits = (self.safety_bits | SAFETY_EMERGENCY_STOPPED) & ~SAFETY_NORMAL
            self.robot_mode = MODE_POWER_OFF
            self.log.append("emergency stop")

    def power_on(self) -> str:
        """Dashboard ``power on``: POWER_OFF -> IDLE (brakes still on). Returns the reply."""
        with self.lock:
            if self.safety_bits & SAFETY_EMERGENCY_STOPPED:
                return "Cannot power on: the emergency stop is engaged"
            if self.robot_mode == MODE_POWER_OFF:
                self.robot_mode = MODE_IDLE
            return "Powering on"

    def brake_release(self) -> str:
        """Dashboard ``brake release``: IDLE -> RUNNING. Returns the reply."""
        with self.lock:
            if self.robot_mode == MODE_POWER_OFF:
                return "Cannot release brakes: the robot is powered off"
            self.robot_mode = MODE_RUNNING
            return "Brake releasing"

    def power_off(self) -> str:
        """Dashboard ``power off``: the program stops, the arm is powered off."""
        with self.lock:
            self.stop_program()
            self.robot_mode = MODE_POWER_OFF
            return "Powering off"

    def release_emergency_stop(self) -> None:
        with self.lock:
            self.safety_bits &= ~SAFETY_EMERGENCY_STOPPED
            if not self.safety_bits & SAFETY_PROTECTIVE_STOPPED:
                self.safety_bits |= SAFETY_NORMAL

    def unlock_protective_stop(self) -> str:
        """Dashboard ``unlock protective stop``; refused while e-stopped. Returns the reply line."""
        with self.lock:
            if self.safety_bits & SAFETY_EMERGENCY_STOPPED or not (
                self.safety_bits & SAFETY_PROTECTIVE_STOPPED
            ):
                return "Cannot unlock protective stop, safetymode is not PROTECTIVE_STOP"
            since = self._protective_since
            if since is not None and time.monotonic() - since < self.unlock_delay_s:
                return (
                    "Cannot unlock protective stop until 5s after occurrence. "
                    "Always inspect cause of protective stop before unlocking"
                )
            self.safety_bits = (self.safety_bits & ~SAFETY_PROTECTIVE_STOPPED) | SAFETY_NORMAL
            return "Protective stop releasing"

    # ----------------------------------------------------------- the loop
    def tick(self, dt_wall: float) -> None:
        """One controller cycle: motion advances ``dt_wall * time_scale``, then the script runs."""
        with self.lock:
            self._advance(dt_wall * self.time_scale)
            if self.runtime_state == RUNTIME_PLAYING:
                self._script_cycle()
            if self._servo_target is not None:
                # A stiff servo: the joints reach servoJ's latest target within the cycle
                # it was read in (a real arm's servoj, with its lookahead, lags more: the
                # robot stream reports what the arm did, whatever its lag).
                self.qd = (self._servo_target - self.q) / max(dt_wall, 1e-9)
                self.q = self._servo_target.copy()
            self._cycle_s = time.monotonic() - self._t0
            self.cycles += 1
            self._cycle_done.notify_all()

    def wait_cycle(self, seen: int, timeout_s: float) -> int:
        """Wait until a cycle after the ``seen``-th has run (at most ``timeout_s``); the count.

        The RTDE stream sends its packages on the controller's cycles, as a
        controller does: each carries the joints and the timestamp of one cycle.
        """
        with self.lock:
            self._cycle_done.wait_for(lambda: self.cycles > seen, timeout_s)
            return self.cycles

    def _advance(self, dt):
        if self._move is None:
            self.qd = np.zeros(6)
            return
        self.q, self.qd = self._move.advance(dt)
        if self._move.finished:
            self._move = None
            self.qd = np.zeros(6)
            self._write_async_progress(-1)
            if self._busy:  # a sync movej returns now
                self._busy = False
                self._out_int(0, DONE)

    def _script_cycle(self):
        if self._busy:
            return  # the script is inside a blocking movej
        cmd = int(self.in_int[self.reg_offset])
        if cmd in REALTIME_CMDS:
            if cmd == CMD_SERVOJ:  # processed every cycle the register holds it, as the script
                self._servo()
            self._out_int(0, READY)
        elif cmd == CMD_NO_CMD:
            self._executing_cmd = False
            self._out_int(0, READY)
        elif not self._executing_cmd:
            self._executing_cmd = True
            self._process(cmd)

    def _process(self, cmd):
        self.log.append(f"cmd {cmd}")
        if cmd == CMD_MOVEJ and self.estop_at_movej:
            self.estop_at_movej -= 1
            if not self.estop_at_movej:  # pressed as this move arrives: it never starts
                self.emergency_stop()
                return
        if cmd == CMD_MOVEJ:
            target = np.array([self._in_double(i) for i in range(6)])
            speed, accel = self._in_double(6), self._in_double(7)
            is_async = self._in_int(1) == 1
            self._move = _JointMove(self.q, target, speed, accel)
            self.target_q = target
            if is_async:
                self._write_async_progress(0)
                self._out_int(0, DONE)
            else:
                self._busy = True
        elif cmd == CMD_SERVO_STOP:
            self._halt()
            self._out_int(0, DONE)
        elif cmd in (CMD_STOPJ, CMD_STOPL):
            # the fake freezes at once: a deceleration ramp adds nothing the tests need
            self._halt()
            self._out_int(0, DONE)
        elif cmd == CMD_IS_STEADY:
            self._out_int(1, 0 if self.moving else 1)
            self._out_int(0, DONE)
        elif cmd == CMD_PROTECTIVE_STOP:
            self.protective_stop()
        elif cmd == CMD_STOP_SCRIPT:
            self.stop_program()
        elif cmd == CMD_SET_TCP:
            pose = np.array([self._in_double(i) for i in range(6)])  # m, rotation vector
            self.flange2tcp = frames.transform(
                rotations.rotvec_to_matrix(pose[3:]), pose[:3] * 1000
            )
            self._out_int(0, DONE)
        else:
            # Not emulated (moveL, movePath, IK, ...): stop the program, as a script
            # error would, so the client's call fails instead of reporting success.
            self.log.append(f"unsupported command {cmd}: program stopped")
            self.stop_program()

    def _servo(self):
        """servoJ (ur-rtde: q in input doubles 0-5, then speed, accel, time, lookahead, gain)."""
        if self._move is not None:  # servoing takes over from a running movej
            self._halt()
        self._servo_target = np.array([self._in_double(i) for i in range(6)])
        self.target_q = self._servo_target.copy()

    def _halt(self):
        self._servo_target = None
        if self._move is not None:
            self._move = None
            self._write_async_progress(-1)
        self.qd = np.zeros(6)
        self.target_q = self.q.copy()

    # ------------------------------------------------------------ registers
    def _in_double(self, i):
        return float(self.in_double[i + self.reg_offset])

    def _in_int(self, i):
        return int(self.in_int[i + self.reg_offset])

    def _out_int(self, i, value):
        self.out_int[i + self.reg_offset] = value

    def _write_async_progress(self, value):
        # layout of the script's write_async_progress_register(): op id in bits
        # 24-30, write count in 16-23, bit 15 "running" plus 15-bit progress
        self._async_wr_count = (self._async_wr_count + 1) % 128
        if value == 0:
            self._async_op_id = (self._async_op_id + 1) % 128
        reg = self._async_wr_count * 65536 + self._async_op_id * 16777216
        if value >= 0:
            reg += value + 32768
        self._out_int(2, reg)
