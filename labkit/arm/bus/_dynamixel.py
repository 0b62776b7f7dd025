"""Dynamixel Protocol 2.0: the XM430 / XL430 control table, the packet format, the host driver.

One module holds what the bus fixes for both ends: the control-table addresses (ROBOTIS
e-Manual, XM430-W350 and XL430-W250, Protocol 2.0), the packet codec the virtual bus parses
and answers with (header ``FF FF FD 00``, id, length, instruction, parameters, CRC-16 with
polynomial 0x8005 over the stuffed packet; byte stuffing ``FF FF FD`` -> ``FF FF FD FD``),
and :class:`DynamixelDriver`, the host side through the unmodified ``dynamixel-sdk``.

The codec is written from the protocol's documentation, not from the SDK, so the SDK's
packets are checked by an independent implementation.

Examples
--------
>>> hex(crc16(b"123456789"))   # CRC-16/BUYPASS, the check value of polynomial 0x8005
'0xfee8'
>>> decode(encode(1, 0x55, [0x00, 0x20, 0x04, 0x26]))[0][0]
(1, 85, [0, 32, 4, 38])
"""

from __future__ import annotations

from labkit.arm.bus._driver import BusDriver
from labkit.exceptions import needs_extra

__all__ = []

PROTOCOL = "dynamixel"
#: control table (address, size [bytes]) of the XM430 / XL430 in Protocol 2.0
TABLE = {
    "model_number": (0, 2), "firmware": (6, 1), "id": (7, 1), "operating_mode": (11, 1),
    "torque_enable": (64, 1), "hardware_error": (70, 1), "profile_acceleration": (108, 4),
    "profile_velocity": (112, 4), "goal_position": (116, 4), "moving": (122, 1),
    "present_current": (126, 2), "present_velocity": (128, 4), "present_position": (132, 4),
    # the position loop and the gripper's current limit (RAM, e-Manual XM430-W350 "Position PID Gain", "Goal Current")
    "current_limit": (38, 2), "position_d_gain": (80, 2), "position_i_gain": (82, 2), "position_p_gain": (84, 2),
    "goal_current": (102, 2),
}
#: what a sync read of the state takes: present current .. present position (10 bytes)
STATE = (126, 10)
#: model number the virtual servos report (XM430-W350)
MODEL = 1020
#: present-current unit of the XM430 [A per LSB] (XL430: address 126 is present load [0.1 %])
CURRENT_UNIT = 2.69e-3
#: torque constant used by the virtual bus [N m / A] (XM430-W350: 4.1 N m stall at 2.3 A, 12 V)
TORQUE_CONSTANT = 1.78
#: profile-velocity unit [rev/min per LSB] and profile-acceleration unit [rev/min^2 per LSB]
VELOCITY_UNIT = 0.229
ACCELERATION_UNIT = 214.577
#: the largest profile velocity and acceleration the registers take (velocity-based profile; 0 means "no limit")
PROFILE_MAX = 32767
#: hardware error status bits (address 70)
HARDWARE_ERRORS = {0x01: "input voltage", 0x04: "overheating", 0x08: "motor encoder", 0x10: "electrical shock",
                   0x20: "overload"}
#: the status packet's alert bit: read the hardware error status
ALERT = 0x80
INSTRUCTIONS = {0x01: "ping", 0x02: "read", 0x03: "write", 0x82: "sync read", 0x83: "sync write"}
BROADCAST = 0xFE
STATUS = 0x55
HEADER = bytes([0xFF, 0xFF, 0xFD, 0x00])
#: bytes of an address and of a length in a read / write / sync instruction
ADDRESS_BYTES = 2
#: present current is two's complement (not sign-magnitude)
SIGN_MAGNITUDE = False
#: the position loop's gains: name -> (control-table field, largest value, factor to the e-Manual's K_P P/I/D);
#: every one 0..16383 (XM430-W350 control table: KPP = P(84) / 128, KPI = I(82) / 65536, KPD = D(80) / 16)
GAINS = {"kp": ("position_p_gain", 16383, 1 / 128), "ki": ("position_i_gain", 16383, 1 / 65536),
         "kd": ("position_d_gain", 16383, 1 / 16)}
#: the gains of a servo out of the box (XM430-W350 initial values: P 800, I 0, D 0)
DEFAULT_GAINS = {"kp": 800, "ki": 0, "kd": 0}
#: the motor behind the loop (XM430-W350 at 12 V): stall torque [N m], no-load speed [rad/s] (46 rev/min), gear ratio,
#: full-scale output of the loop [PWM LSB] (PWM Limit(36), initial 885 = 100 %), rotor inertia [kg m^2] (ASSUMED, not
#: published: a 1 g cm^2 coreless motor; 0.0125 kg m^2 through the gearbox)
MOTOR = {"stall_torque": 4.1, "no_load_speed": 46 * 2 * 3.141592653589793 / 60, "gear_ratio": 353.5, "full_scale": 885,
         "rotor_inertia": 1.0e-7}
#: the gripper's operating mode: current-based position control (Operating Mode(11) = 5, the OpenMANIPULATOR-X
#: gripper's), its limit the Goal Current(102) [CURRENT_UNIT], at most Current Limit(38) = 1193
GRIPPER_MODE = 5
CURRENT_LIMIT = 1193
#: homing offset (address, size; EEPROM, written with torque off): present position = actual + HOMING_SIGN * offset
HOMING_OFFSET = (20, 4)
HOMING_SIGN = 1
#: largest homing-offset magnitude the servo takes [ticks] (XM430 e-Manual: -1,044,479 .. 1,044,479)
HOMING_LIMIT = 1_044_479
#: the offset's sign bit (sign-magnitude), ``None``: two's complement
HOMING_SIGN_BIT = None
#: the EEPROM lock register (address, size), ``None``: torque off is enough to write the EEPROM
EEPROM_LOCK = None


def ping_reply(model):
    """The parameters of the status packet answering a ping: model number (2 bytes), firmware version.

    Parameters
    ----------
    model : int
        The servo's model number.

    Returns
    -------
    list of int
    """
    return [model & 0xFF, model >> 8, 52]


def crc16(data):
    """CRC-16 of Dynamixel Protocol 2.0 (polynomial 0x8005, initial value 0, not reflected).

    Parameters
    ----------
    data : bytes-like
        The packet from its header to the last byte before the CRC (stuffed, as sent).

    Returns
    -------
    int
        0..65535 (sent low byte first).
    """
    crc = 0
    for byte in bytes(data):
        crc ^= byte << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x8005) if crc & 0x8000 else crc << 1
            crc &= 0xFFFF
    return crc


def _stuff(body):
    out = bytearray()
    for b in body:
        out.append(b)
        if b == 0xFD and out[-3:] == b"\xff\xff\xfd":
            out.append(0xFD)
    return bytes(out)


def encode(servo_id, instruction, params, error=None):
    """One packet: header, id, length, instruction (and error for a status packet), stuffed parameters, CRC.

    Parameters
    ----------
    servo_id : int
    instruction : int
        0x55 for a status packet.
    params : sequence of int
        Parameter bytes (unstuffed).
    error : int, optional
        The status packet's error byte (put before the parameters).

    Returns
    -------
    bytes
    """
    body = bytes(([] if error is None else [error]) + list(params))
    stuffed = _stuff(bytes([instruction]) + body)
    length = len(stuffed) + 2
    packet = HEADER + bytes([servo_id, length & 0xFF, length >> 8]) + stuffed
    crc = crc16(packet)
    return packet + bytes([crc & 0xFF, crc >> 8])


def decode(buffer):
    """Complete packets at the front of ``buffer``: ``(packets, rest, rejected)``.

    Parameters
    ----------
    buffer : bytes-like
        Bytes received so far.

    Returns
    -------
    packets : list of tuple
        ``(id, instruction, params)`` of each intact packet, parameters unstuffed.
    rest : bytes
        An incomplete packet still waiting for its bytes.
    rejected : list of str
        Why each damaged packet was dropped (bad CRC, bad stuffing, bad length, garbage before a header).
    """
    buf = bytes(buffer)
    packets, rejected = [], []
    while True:
        k = buf.find(HEADER[:3])
        if k < 0:
            if buf.strip(b"\xff"):
                rejected.append(f"{len(buf)} bytes without a header")
            return packets, (buf[-2:] if buf.endswith(b"\xff") else b""), rejected
        if k > 0:
            rejected.append(f"{k} bytes before a header")
            buf = buf[k:]
        if len(buf) < 7:
            return packets, buf, rejected
        if buf[3] != 0x00:
            rejected.append(f"reserved byte {buf[3]:#04x} (expected 0x00)")
            buf = buf[3:]
            continue
        length = buf[5] | buf[6] << 8
        if not 3 <= length <= 1000:
            rejected.append(f"length {length}")
            buf = buf[3:]
            continue
        if len(buf) < 7 + length:
            return packets, buf, rejected
        packet, buf = buf[:7 + length], buf[7 + length:]
        if crc16(packet[:-2]) != (packet[-2] | packet[-1] << 8):
            rejected.append("CRC mismatch")
            continue
        stuffed = packet[7:-2]
        body, i = bytearray(), 0
        while i < len(stuffed):
            body.append(stuffed[i])
            if stuffed[i] == 0xFD and stuffed[i - 2:i] == b"\xff\xff" and i >= 2:
                if i + 1 >= len(stuffed) or stuffed[i + 1] != 0xFD:
                    rejected.append("unstuffed FF FF FD in the parameters")
                    body = None
                    break
                i += 1
            i += 1
        if body is not None:
            packets.append((packet[4], body[0], list(body[1:])))


def word(values, size):
    """Little-endian integer of ``size`` bytes (two's complement) from ``values``.

    Parameters
    ----------
    values : sequence of int
        Bytes, least significant first.
    size : int
        How many of them.

    Returns
    -------
    int
    """
    v = int.from_bytes(bytes(values[:size]), "little")
    return v - (1 << 8 * size) if v >> (8 * size - 1) else v


def status(servo_id, error, params):
    """A status packet (instruction 0x55, error byte, parameters).

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
    return encode(servo_id, STATUS, params, error=error)


class DynamixelDriver(BusDriver):
    """The host side of a Dynamixel Protocol 2.0 bus through ``dynamixel-sdk`` (see :class:`BusDriver`)."""

    protocol = PROTOCOL
    table = TABLE
    state = STATE
    current_unit = CURRENT_UNIT
    errors = HARDWARE_ERRORS
    profile = ("profile_velocity", "profile_acceleration")

    def _sdk(self):
        with needs_extra("bus"):
            import dynamixel_sdk as sdk

        return sdk, sdk.PortHandler, sdk.PacketHandler(2.0)

    def _sync_read_tx(self, address, size, ids):
        return self.packets.syncReadTx(self.handler, address, size, list(ids), len(ids), False)

    def _hardware_error(self, servo_id, error):
        if not error & ALERT:
            return f"status error {error:#04x} (instruction-level)"
        try:
            code, result, _ = self.packets.read1ByteTxRx(self.handler, servo_id, TABLE["hardware_error"][0])
        except IndexError:  # the SDK takes the byte from a short status packet unchecked
            result = self.sdk.COMM_RX_CORRUPT
        if result != self.sdk.COMM_SUCCESS:
            return "hardware alert (its hardware error status could not be read)"
        return self.describe(code)

    def _decode_state(self, data):
        return word(data[6:10], 4), word(data[0:2], 2)

    def _velocity_value(self, rad_s):
        return min(max(1, round(rad_s * 60 / (2 * 3.141592653589793) / VELOCITY_UNIT)), PROFILE_MAX)

    def _acceleration_value(self, rad_s2):
        return min(max(1, round(rad_s2 * 3600 / (2 * 3.141592653589793) / ACCELERATION_UNIT)), PROFILE_MAX)

#: the host side of this bus (the registry's contract, :mod:`labkit.arm.bus`)
Driver = DynamixelDriver
