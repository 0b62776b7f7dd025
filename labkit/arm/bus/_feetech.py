"""Feetech STS (SMS/STS protocol, STS3215): the control table, the packet format, the host driver.

What the bus fixes for both ends: the STS3215 control-table addresses (Feetech's STS memory
table, as used by the SO-100 / SO-101 arms), the packet codec the virtual bus parses and
answers with (header ``FF FF``, id, length = parameters + 2, instruction or error byte,
parameters, checksum ``~(id + length + instruction + parameters) & 0xFF``), and
:class:`FeetechDriver`, the host side through the unmodified ``feetech-servo-sdk``
(``scservo_sdk``, little-endian words for the STS series).

Examples
--------
>>> encode(1, 0x01, []).hex(" ")
'ff ff 01 02 01 fb'
>>> decode(encode(1, 0x01, []))[0]
[(1, 1, [])]
"""

from __future__ import annotations

from labkit.arm.bus._driver import BusDriver
from labkit.exceptions import needs_extra

__all__ = []

PROTOCOL = "feetech"
#: control table (address, size [bytes]) of the STS3215
TABLE = {
    "firmware": (0, 1), "model_number": (3, 2), "id": (5, 1), "torque_enable": (40, 1), "acceleration": (41, 1),
    "goal_position": (42, 2), "goal_time": (44, 2), "goal_velocity": (46, 2), "present_position": (56, 2),
    "present_velocity": (58, 2), "present_load": (60, 2), "present_voltage": (62, 1),
    "present_temperature": (63, 1), "status": (65, 1), "moving": (66, 1), "present_current": (69, 2),
    # the position loop and the torque limit (lerobot's STS_SMS_SERIES_CONTROL_TABLE; Feetech STS memory table:
    # Torque_Limit(48) 0..1000 [0.1 % of the stall torque], see GAINS for the coefficients' range)
    "p_coefficient": (21, 1), "d_coefficient": (22, 1), "i_coefficient": (23, 1), "torque_limit": (48, 2),
}
#: what a sync read of the state takes: present position .. present current (15 bytes)
STATE = (56, 15)
#: model number the virtual servos report (STS3215)
MODEL = 777
#: present-current unit of the STS3215 [A per LSB]
CURRENT_UNIT = 6.5e-3
#: torque constant used by the virtual bus [N m / A] (ASSUMED: no stall current found in a readable datasheet; the
#: robot files' bus tables carry none for the STS3215)
TORQUE_CONSTANT = 0.6
#: error bits of a status packet (and of the status byte, address 65)
HARDWARE_ERRORS = {0x01: "input voltage", 0x02: "angle sensor", 0x04: "overheating", 0x08: "overcurrent",
                   0x20: "overload"}
INSTRUCTIONS = {0x01: "ping", 0x02: "read", 0x03: "write", 0x82: "sync read", 0x83: "sync write"}
BROADCAST = 0xFE
#: the goal-velocity unit [ticks/s per LSB] and the acceleration unit [ticks/s^2 per LSB]
VELOCITY_UNIT = 1.0
ACCELERATION_UNIT = 100.0
#: bytes of an address and of a length in a read / write / sync instruction
ADDRESS_BYTES = 1
#: no alert bit: a status packet's error byte carries the hardware-error bits themselves
ALERT = None
#: present current, speed and load are sign-magnitude (sign in bit 15)
SIGN_MAGNITUDE = True
#: the position loop's gains: name -> (control-table field, largest value, factor to the loop's gain). Position
#: P / D / I gain at addresses 21 / 22 / 23, one byte each, value range 0..254: Feetech's STS series memory table
#: (doc.feetech.cn, FT-SMS-STS e-manual; transcribed in vassar-robotics/feetech-servo-sdk,
#: docs/reference/memory_tables/sts_memory_table.md, "Position P Gain | RW | 1 | - | 0-254"); addresses and sizes
#: as huggingface/lerobot src/lerobot/motors/feetech/tables.py (P/D/I_Coefficient: (21, 1), (22, 1), (23, 1)).
#: Feetech publishes no conversion to a loop gain: the factor 1 leaves the register values as they are
GAINS = {"kp": ("p_coefficient", 254, 1.0), "ki": ("i_coefficient", 254, 1.0), "kd": ("d_coefficient", 254, 1.0)}
#: the gains of a servo out of the box (STS3215: P 32, D 32, I 0, as lerobot's SO-101 code notes before lowering P)
DEFAULT_GAINS = {"kp": 32, "ki": 0, "kd": 32}
#: the motor behind the loop (STS3215 at 7.4 V, 1:345): stall torque [N m] (19.5 kgf cm = 1.912 N m at 7.4 V: DFRobot
#: SER0069 "ST3215 Serial Bus Servo" (ST3215: the STS3215's name at Waveshare and DFRobot), product data "19.5kg.cm
#: stall torque at 7.4V", "1:345 gear train", as listed by Little Bird Electronics), no-load speed [rad/s] (0.222 s / 60 deg, see
#: so101.toml [STS]; the same listing gives 0.192 s / 60 deg at 7.4 V), gear ratio (1:345), full-scale output of the
#: loop [LSB] (Torque_Limit(48) 1000 = 100 %), rotor inertia [kg m^2] (ASSUMED, not published: 0.5 g cm^2; 0.006 kg m^2
#: through the gearbox)
MOTOR = {"stall_torque": 1.912, "no_load_speed": 4.7, "gear_ratio": 345.0, "full_scale": 1000,
         "rotor_inertia": 5.0e-8}
#: the gripper: position mode with its Torque_Limit(48) [0.1 % of the stall torque], 0..1000
GRIPPER_MODE = None
CURRENT_LIMIT = None
#: homing offset ("Ofs", address, size; EEPROM): present position = actual - offset (HOMING_SIGN = -1)
HOMING_OFFSET = (31, 2)
HOMING_SIGN = -1
#: largest homing-offset magnitude the STS3215 takes [ticks]: 11 bits and a sign (LeRobot's "magnitude exceeds 2047")
HOMING_LIMIT = 2047
#: the offset's sign bit (sign-magnitude, bit 11)
HOMING_SIGN_BIT = 11
#: the EEPROM lock register (address, size): 0 to write the EEPROM, 1 to keep it over a power cycle
EEPROM_LOCK = (55, 1)


def ping_reply(model):
    """The parameters of the status packet answering a ping: none.

    Parameters
    ----------
    model : int
        The servo's model number.

    Returns
    -------
    list of int
    """
    return []


def status(servo_id, error, params):
    """A status packet (error byte, parameters).

    Parameters
    ----------
    servo_id : int
    error : int
        The error byte.
    params : sequence of int

    Returns
    -------
    bytes
    """
    return encode(servo_id, 0, params, error=error)


def sts_checksum(body):
    """The STS checksum: the inverted low byte of the sum of id, length, instruction and parameters.

    Parameters
    ----------
    body : bytes-like
        The packet without its ``FF FF`` header and its checksum.

    Returns
    -------
    int
        0..255.
    """
    return ~sum(bytes(body)) & 0xFF


def encode(servo_id, instruction, params, error=None):
    """One packet: ``FF FF``, id, length, instruction (or, for a status packet, the error byte), parameters, checksum.

    Parameters
    ----------
    servo_id : int
    instruction : int
        Instruction code; ignored when ``error`` is given (a status packet).
    params : sequence of int
    error : int, optional

    Returns
    -------
    bytes
    """
    body = bytes([servo_id, len(params) + 2, instruction if error is None else error, *params])
    return b"\xff\xff" + body + bytes([sts_checksum(body)])


def decode(buffer):
    """Complete packets at the front of ``buffer``: ``(packets, rest, rejected)`` (see the Dynamixel codec).

    Parameters
    ----------
    buffer : bytes-like

    Returns
    -------
    packets : list of tuple
        ``(id, instruction, params)``.
    rest : bytes
    rejected : list of str
    """
    buf = bytes(buffer)
    packets, rejected = [], []
    while True:
        k = buf.find(b"\xff\xff")
        if k < 0:
            if buf.strip(b"\xff"):
                rejected.append(f"{len(buf)} bytes without a header")
            return packets, (b"\xff" if buf.endswith(b"\xff") else b""), rejected
        while k + 2 < len(buf) and buf[k + 2] == 0xFF:  # a header FF FF is followed by an id, never 0xFF
            k += 1
        if k > 0:
            rejected.append(f"{k} bytes before a header")
            buf = buf[k:]
        if len(buf) < 4:
            return packets, buf, rejected
        length = buf[3]
        if length < 2:
            rejected.append(f"length {length}")
            buf = buf[2:]
            continue
        if len(buf) < 4 + length:
            return packets, buf, rejected
        packet, buf = buf[:4 + length], buf[4 + length:]
        if sts_checksum(packet[2:-1]) != packet[-1]:
            rejected.append("checksum mismatch")
            continue
        packets.append((packet[2], packet[4], list(packet[5:-1])))


def signed(value, bit=15):
    """An STS sign-magnitude word (sign in ``bit``) as an int.

    Parameters
    ----------
    value : int
        The word as read.
    bit : int
        The sign bit.

    Returns
    -------
    int
    """
    return -(value & ~(1 << bit)) if value & (1 << bit) else value


class FeetechDriver(BusDriver):
    """The host side of a Feetech STS bus through ``feetech-servo-sdk`` (see :class:`BusDriver`)."""

    protocol = PROTOCOL
    table = TABLE
    state = STATE
    current_unit = CURRENT_UNIT
    errors = HARDWARE_ERRORS
    profile = ("goal_velocity", "acceleration")

    def _sdk(self):
        with needs_extra("bus"):
            import scservo_sdk as sdk

        return sdk, sdk.PortHandler, sdk.PacketHandler(0)

    def _sync_read_tx(self, address, size, ids):
        return self.packets.syncReadTx(self.handler, address, size, list(ids), len(ids))

    def _hardware_error(self, servo_id, error):
        return self.describe(error)

    def _decode_state(self, data):
        return data[0] | data[1] << 8, signed(data[13] | data[14] << 8)

    def _velocity_value(self, rad_s):
        return min(max(1, round(rad_s * self.resolution / (2 * 3.141592653589793) / VELOCITY_UNIT)), 32767)

    def _acceleration_value(self, rad_s2):
        return min(max(1, round(rad_s2 * self.resolution / (2 * 3.141592653589793) / ACCELERATION_UNIT)), 254)

#: the host side of this bus (the registry's contract, :mod:`labkit.arm.bus`)
Driver = FeetechDriver
