"""A loopback fake Universal Robots controller for testing the ``ur-rtde`` adapter.

Serves RTDE (30004), the dashboard (29999) and the script port (30003) on
127.0.0.1 and emulates the ``rtde_control`` script's register loop. It must run
in its own process: the ``ur-rtde`` client's constructors hold the GIL while
they block on the network, so an in-process server deadlocks. Start it with
``python -m drivers.robot.ur.simulator`` or
:class:`~drivers.robot.ur.simulator.launcher.FakeUrProcess`.
"""
