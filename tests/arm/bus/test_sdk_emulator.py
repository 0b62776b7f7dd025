"""The vendor SDKs, unmodified, against labkit's virtual buses: every packet parsed and checked by the emulator."""

import os
import time

import numpy as np
import pytest

from labkit.arm.bus import BusEmulator, bus_module
from labkit.arm.bus._adapter import paced_by


def _sdk(kind, emu):
    # the SDK's own port, its status timeouts started once the emulator has the request (as labkit's driver does
    # on a virtual bus of its process: a loaded machine delays the emulator's thread, not a servo)
    if kind == "dynamixel":
        import dynamixel_sdk as sdk

        port, packets = paced_by(sdk.PortHandler, emu)(emu.path), sdk.PacketHandler(2.0)
    else:
        import scservo_sdk as sdk

        port, packets = paced_by(sdk.PortHandler, emu)(emu.path), sdk.PacketHandler(0)
    assert port.openPort() and port.setBaudRate(1_000_000)
    port.ser.timeout = 0.001  # wait for status packets in select(), not spinning (as labkit's driver does)
    return sdk, port, packets


@pytest.fixture
def bus(robot_file, kind):
    emu = BusEmulator(robot_file)
    sdk, port, packets = _sdk(kind, emu)
    yield emu, sdk, port, packets, bus_module(kind)
    port.closePort()
    emu.close()


def test_ping_answers_the_model_number(bus, kind):
    emu, sdk, port, packets, mod = bus
    for servo_id in emu.ids:
        model, result, error = packets.ping(port, servo_id)
        assert (result, error) == (sdk.COMM_SUCCESS, 0)
        assert model == mod.MODEL  # Dynamixel: in the ping's status packet; Feetech: the SDK reads address 3
    _, result, _ = packets.ping(port, 99)  # no such servo: no status packet
    assert result == sdk.COMM_RX_TIMEOUT
    assert [p[0] for p in emu.packets if p[0] == "ping"] == ["ping"] * (len(emu.ids) + 1) and emu.rejected == []


def test_sync_write_moves_the_servos_and_sync_read_reports_them(bus, kind):
    emu, sdk, port, packets, mod = bus
    robot = emu.robot
    torque, _ = mod.TABLE["torque_enable"]
    for servo_id in emu.ids:
        assert packets.write1ByteTxRx(port, servo_id, torque, 1) == (sdk.COMM_SUCCESS, 0)
    target = np.radians([20.0, -30.0, 25.0, 40.0])
    goal, size = mod.TABLE["goal_position"]
    group = sdk.GroupSyncWrite(port, packets, goal, size)
    for lk, q in zip(robot.links, target):
        assert group.addParam(lk.bus.id, list(int(lk.bus.ticks(q)).to_bytes(size, "little")))
    assert group.txPacket() == sdk.COMM_SUCCESS
    assert emu.wait_sync_writes(1)  # no status packet: wait until the bus has it, then let the physics run
    emu.model.advance(2.0)  # the physics runs on its driver's clock
    position, psize = mod.TABLE["present_position"]
    reader = sdk.GroupSyncRead(port, packets, position, psize)
    for servo_id in emu.ids:
        reader.addParam(servo_id)
    assert reader.txRxPacket() == sdk.COMM_SUCCESS
    ticks = [reader.getData(lk.bus.id, position, psize) for lk in robot.links]
    got = np.array([float(lk.bus.joint(t)) for lk, t in zip(robot.links, ticks)])
    assert np.allclose(got, target, atol=np.radians(0.2))
    assert [p[0] for p in emu.packets][-2:] == ["sync write", "sync read"] and emu.rejected == []


def test_register_write_and_read_back(bus, kind):
    emu, sdk, port, packets, mod = bus
    servo = emu.ids[0]
    field = "profile_velocity" if kind == "dynamixel" else "goal_velocity"
    address, size = mod.TABLE[field]
    write = packets.write4ByteTxRx if size == 4 else packets.write2ByteTxRx
    read = packets.read4ByteTxRx if size == 4 else packets.read2ByteTxRx
    assert write(port, servo, address, 0x0FFE) == (sdk.COMM_SUCCESS, 0)
    assert read(port, servo, address) == (0x0FFE, sdk.COMM_SUCCESS, 0)
    assert emu.get(servo, field) == 0x0FFE and emu.rejected == []


def test_dynamixel_sdk_packet_that_needs_byte_stuffing_is_refused_like_a_servo_would():
    # dynamixel-sdk 4.1.0's addStuffing builds the stuffed packet in a new list that txPacket discards, so a
    # value with the bytes FF FF FD goes out unstuffed; a servo (and the emulator) takes that for a new header.
    # labkit never sends one: goals are 0..resolution-1 ticks, profiles small positive numbers.
    import dynamixel_sdk as sdk

    from tests.arm.bus.conftest import ROBOTS

    with BusEmulator(ROBOTS["dynamixel"]) as emu:
        _, port, packets = _sdk("dynamixel", emu)
        port.setPacketTimeoutMillis(50)
        result, _ = packets.write4ByteTxRx(port, emu.ids[0], 112, 0x00FDFFFF)
        port.closePort()
        assert result != sdk.COMM_SUCCESS
        assert emu.rejected == ["unstuffed FF FF FD in the parameters"] and emu.status_sent == 0


def test_a_damaged_instruction_is_rejected_and_never_answered(bus, kind):
    emu, sdk, port, packets, mod = bus
    packet = bytearray(mod.encode(emu.ids[0], 0x01, []))
    packet[-1] ^= 0x40
    os.write(os.open(emu.path, os.O_WRONLY | os.O_NOCTTY), bytes(packet))
    deadline = time.monotonic() + 60.0  # the emulator's thread reads it when the host's CPU runs it
    while not emu.rejected and time.monotonic() < deadline:
        time.sleep(0.005)
    assert emu.rejected and emu.status_sent == 0 and emu.packets == []


def test_an_overloaded_servo_flags_every_status_packet_and_drops_torque(bus, kind):
    emu, sdk, port, packets, mod = bus
    servo = emu.ids[1]
    packets.write1ByteTxRx(port, servo, mod.TABLE["torque_enable"][0], 1)
    emu.faults.overload.add(servo)
    _, result, error = packets.read1ByteTxRx(port, servo, mod.TABLE["torque_enable"][0])
    assert result == sdk.COMM_SUCCESS and error & (0x80 if kind == "dynamixel" else 0x20)
    assert not emu.torque(servo)
