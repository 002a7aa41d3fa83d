"""RTDE v2 wire format: headers, package types and the field type of each variable.

Only what a controller needs to answer the ``ur-rtde`` client (see
``docs/robot-link.md``). Everything is big-endian. A package is a header
``>HB`` (total size including the 3 header bytes, package type) and a payload.
"""

from __future__ import annotations

import re
import struct
from collections.abc import Iterable

HEADER = struct.Struct(">HB")

REQUEST_PROTOCOL_VERSION = ord("V")
GET_URCONTROL_VERSION = ord("v")
TEXT_MESSAGE = ord("M")
DATA_PACKAGE = ord("U")
SETUP_OUTPUTS = ord("O")
SETUP_INPUTS = ord("I")
START = ord("S")
PAUSE = ord("P")

# struct format and zero value of each RTDE type
TYPE_FORMATS = {
    "BOOL": "?",
    "UINT8": "B",
    "INT32": "i",
    "UINT32": "I",
    "UINT64": "Q",
    "DOUBLE": "d",
    "VECTOR3D": "3d",
    "VECTOR6D": "6d",
    "VECTOR6INT32": "6i",
}

# Field types from Universal Robots' RTDE guide; the client unpacks by name with
# these sizes, so a wrong size here would shift every later field.
_EXACT_TYPES = {
    "timestamp": "DOUBLE",
    "actual_digital_input_bits": "UINT64",
    "actual_digital_output_bits": "UINT64",
    "actual_execution_time": "DOUBLE",
    "robot_mode": "INT32",
    "joint_mode": "VECTOR6INT32",
    "safety_mode": "INT32",
    "safety_status": "INT32",
    "actual_tool_accelerometer": "VECTOR3D",
    "payload_cog": "VECTOR3D",
    "elbow_position": "VECTOR3D",
    "elbow_velocity": "VECTOR3D",
    "runtime_state": "UINT32",
    "robot_status_bits": "UINT32",
    "safety_status_bits": "UINT32",
    "analog_io_types": "UINT32",
    "io_current": "DOUBLE",
    "tool_mode": "UINT32",
    "tool_analog_input_types": "UINT32",
    "tool_output_voltage": "INT32",
    "tool_output_mode": "UINT8",
    "tool_digital_output0_mode": "UINT8",
    "tool_digital_output1_mode": "UINT8",
    "script_control_line": "UINT32",
    "output_bit_registers0_to_31": "UINT32",
    "output_bit_registers32_to_63": "UINT32",
    "input_bit_registers0_to_31": "UINT32",
    "input_bit_registers32_to_63": "UINT32",
    "speed_slider_mask": "UINT32",
    "standard_digital_output_mask": "UINT8",
    "standard_digital_output": "UINT8",
    "configurable_digital_output_mask": "UINT8",
    "configurable_digital_output": "UINT8",
    "tool_digital_output_mask": "UINT8",
    "tool_digital_output": "UINT8",
    "standard_analog_output_mask": "UINT8",
    "standard_analog_output_type": "UINT8",
    "external_force_torque": "VECTOR6D",
    "payload_inertia": "VECTOR6D",
    "euromap67_input_bits": "UINT32",
    "euromap67_output_bits": "UINT32",
}

_PATTERN_TYPES = [
    (re.compile(r"(input|output)_int_register_\d+$"), "INT32"),
    (re.compile(r"(input|output)_double_register_\d+$"), "DOUBLE"),
    (re.compile(r"(input|output)_bit_register_\d+$"), "BOOL"),
    # every joint- or Cartesian-space vector the guide lists is six doubles
    (
        re.compile(r"^(target|actual)_(q|qd|qdd|current|moment|TCP_pose|TCP_speed|TCP_force)$"),
        "VECTOR6D",
    ),
    (
        re.compile(
            r"^(target_current|actual_current_as_torque|actual_current_window"
            r"|joint_control_output|joint_temperatures|actual_joint_voltage"
            r"|ft_raw_wrench|joint_position_deviation_ratio)$"
        ),
        "VECTOR6D",
    ),
]


def type_of(name: str) -> str:
    """RTDE type name of a variable; unknown names are served as ``DOUBLE`` zeros.

    Parameters
    ----------
    name : str
        RTDE variable name as the client requested it.

    Returns
    -------
    str
        A key of :data:`TYPE_FORMATS`.
    """
    if name in _EXACT_TYPES:
        return _EXACT_TYPES[name]
    for pattern, type_name in _PATTERN_TYPES:
        if pattern.search(name):
            return type_name
    return "DOUBLE"


def recipe_struct(type_names: Iterable[str]) -> struct.Struct:
    """``struct.Struct`` for the fields of one recipe (after its 1-byte id)."""
    return struct.Struct(">" + "".join(TYPE_FORMATS[t] for t in type_names))


def count_of(type_name: str) -> int:
    """Number of scalar values in one field of this type (6 for ``VECTOR6D``)."""
    fmt = TYPE_FORMATS[type_name]
    return int(fmt[:-1]) if len(fmt) > 1 else 1


def zero_of(type_name: str) -> tuple[bool | int, ...]:
    """Zero value(s) of an RTDE type, as a tuple ready to pack."""
    zero = False if TYPE_FORMATS[type_name] == "?" else 0
    return (zero,) * count_of(type_name)


def pack(package_type: int, payload: bytes = b"") -> bytes:
    """Frame one package: header then payload."""
    return HEADER.pack(HEADER.size + len(payload), package_type) + payload


def split_names(payload: bytes) -> list[str]:
    """Variable names of a setup request (``"a,b,c,"``; the trailing comma is optional)."""
    return [n for n in payload.decode("ascii", "replace").strip("\x00").split(",") if n]
