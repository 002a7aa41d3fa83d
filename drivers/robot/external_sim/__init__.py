"""An external controller in simulation: plays a plan as a robot program runs it.

Run as a process (``python -m drivers.robot.external_sim --help``): it moves
a hidden true arm through the plan in joint space (synchronous trapezoidal
moves, a dwell at each pose, optional skipped poses, pauses and vibration)
and steers a tracker simulator's target over its control link
(``SIM,TARGET`` over TCP) every tick, as a real arm carries the reflector.
With ``--program`` it plays a path program of ``calibrator program --path``
instead (:mod:`drivers.robot.external_sim.path_program`): its linear and
circular moves at their stated speeds, handed to the tracker simulator as a
timed path (``SIM,PATH``).
"""
