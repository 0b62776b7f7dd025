"""The rules a robot on a servo bus keeps: a ``[bus]`` table, one bus servo per revolute joint, distinct ids.

Checked by :class:`labkit.robot.Robot` whenever its links, bus or gripper are set (a bus gripper's servo
shares the bus: its id is one of the ids that must differ).
"""

from __future__ import annotations

import math

from labkit.exceptions import RobotError
from labkit.robot.types import Bus, BusGripper

__all__ = ["check_bus"]


def check_bus(owner, bus, links, gripper):
    """A ``[bus]`` table and per-joint ``bus`` servos come together: one servo per joint, distinct ids.

    Parameters
    ----------
    owner : str
        How messages name the robot.
    bus : Bus or None
    links : sequence of Link
    gripper : Gripper or BusGripper or None

    Raises
    ------
    RobotError
        A rule broken (the message names the field).
    """
    if bus is not None and not isinstance(bus, Bus):
        raise RobotError(f"{owner}: field 'bus': expected a Bus or None, got {bus!r}", "bus")
    on_bus = [i for i, lk in enumerate(links, start=1) if lk.bus is not None]
    if isinstance(gripper, BusGripper) and (bus is None or gripper.servo.resolution != bus.resolution):
        raise RobotError(f"{owner}: field 'gripper.bus': expected a [bus] table and a gripper servo of its "
                         f"resolution, got {'no [bus] table' if bus is None else gripper.servo}",
                         "gripper.bus")
    if bus is None:
        if on_bus:
            raise RobotError(f"{owner}: field 'joint[{on_bus[0]}].bus': expected a [bus] table (kind, baudrate, "
                             f"resolution) for joints on a servo bus, got none", f"joint[{on_bus[0]}].bus")
        return
    for i, lk in enumerate(links, start=1):
        if lk.bus is None:
            raise RobotError(f"{owner}: field 'joint[{i}].bus': expected a bus servo (id, zero, direction) on "
                             f"every joint of a robot with a [bus] table, got none", f"joint[{i}].bus")
        if lk.servo is not None:
            raise RobotError(f"{owner}: field 'joint[{i}].servo': expected either a hobby servo or a bus servo, "
                             f"got both", f"joint[{i}].servo")
        if not lk.is_revolute:
            raise RobotError(f"{owner}: field 'joint[{i}].bus': expected a revolute joint on a servo bus, "
                             f"got a prismatic one", f"joint[{i}].bus")
        if lk.bus.resolution != bus.resolution:
            raise RobotError(f"{owner}: field 'joint[{i}].bus': expected the bus resolution "
                             f"{bus.resolution} ticks/turn, got {lk.bus.resolution}", f"joint[{i}].bus")
        if not all(math.isfinite(v) for v in lk.limits):
            raise RobotError(f"{owner}: field 'joint[{i}].limits': expected finite limits on a servo bus, "
                             f"got {lk.limits}", f"joint[{i}].limits")
        # beyond a turn no tick fits (nor, far beyond, an int64): the message shows an infinite tick
        ticks = [int(lk.bus.ticks(v)) if abs(v) <= 7.0 else math.copysign(math.inf, v) for v in lk.limits]
        if min(ticks) < 0 or max(ticks) > bus.resolution - 1:
            raise RobotError(f"{owner}: field 'joint[{i}].limits': expected limits inside the servo's position "
                             f"range 0..{bus.resolution - 1} ticks (zero {lk.bus.zero:g}, direction "
                             f"{lk.bus.direction}), got {ticks[0]}..{ticks[1]} ticks", f"joint[{i}].limits")
    ids = [lk.bus.id for lk in links] + [g.servo.id for g in [gripper] if isinstance(g, BusGripper)]
    dup = sorted({i for i in ids if ids.count(i) > 1})
    if dup:
        raise RobotError(f"{owner}: field 'joint.bus.id': expected distinct servo ids, got {dup[0]} twice",
                         "joint.bus.id")
