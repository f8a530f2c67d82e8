# SPDX-License-Identifier: Apache-2.0
"""The vocabulary the analysis modules share: the tick, the pose axes and
their units, and the names of the controller's states, the drives' states
and the operator commands.

States, drive modes and commands are the value tables of
``protocol/stewart.dbc`` (read through cantools), indexed by raw value; the
axis names are OP_COMMAND.Axis's table in lower case.
"""

from __future__ import annotations

from .. import protocol as pr

#: Nominal control period, s (1 tick = 1 ms).
TICK_S = 1e-3

AXES = pr.axis_names()
#: The external wrench's components (CTRL_WRENCH Fx..Mz; the truth CSV's
#: wrench_fx..wrench_mz): force N, moment about o' N m, base frame.
WRENCH_AXES = ("fx", "fy", "fz", "mx", "my", "mz")
#: The motion along each axis, for the labels.
MOTIONS = ("surge", "sway", "heave", "roll", "pitch", "yaw")
#: CTRL_STATUS.State.
STATES = pr.value_names("CTRL_STATUS", "State")
#: CTRL_STATUS.DriveMode.
DRIVE_MODES = pr.value_names("CTRL_STATUS", "DriveMode")
#: AXIS_FEEDBACK_s.State.
DRIVE_STATES = pr.value_names("AXIS_FEEDBACK_1", "State")
#: OP_COMMAND.Command.
COMMANDS = pr.value_names("OP_COMMAND", "Command")


def is_angle(axis: int) -> bool:
    return axis >= 3


def axis_unit(axis: int, scaled: bool = True) -> str:
    """'mm' / 'mrad' (scaled for errors) or 'm' / 'rad'."""
    if scaled:
        return "mrad" if is_angle(axis) else "mm"
    return "rad" if is_angle(axis) else "m"


def motion_name(axis: int) -> str:
    """'surge x', ..., 'roll' (the motion, and the axis where they differ)."""
    m, a = MOTIONS[axis], AXES[axis]
    return m if m == a else f"{m} {a}"
