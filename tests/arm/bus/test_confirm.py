"""Confirmed bus transactions (issue 41): lost writes sent again, lost status packets read again, pings retried,
the USB latency timer read from (a fake) sysfs and reported with its fix."""

import warnings

import pytest

from labkit.arm.bus import BusEmulator, bus_module
from labkit.arm.bus import _adapter
from labkit.arm.bus._confirm import WRITE_TRIES, write_confirmed
from labkit.exceptions import BusFault, BusWarning
from labkit.robot import Robot


@pytest.fixture
def bus(robot_file, kind):
    emu = BusEmulator(robot_file, wall_clock=True)
    driver = bus_module(kind).Driver(Robot.load(robot_file), emu.path, latency=100)  # a loaded machine answers late
    yield emu, driver
    driver.close()
    emu.close()


def _ignore_writes(monkeypatch, emu, servo_id, field, times=None):
    """Make servo ``servo_id`` ignore writes to ``field`` (all of them, or the first ``times``)."""
    address, _ = emu.bus.TABLE[field]
    apply, left = emu._apply_write, [times]

    def apply_write(sid, start, data):
        if sid == servo_id and start == address and (left[0] is None or left[0] > 0):
            if left[0] is not None:
                left[0] -= 1
            return
        apply(sid, start, data)

    monkeypatch.setattr(emu, "_apply_write", apply_write)


def _goals(emu):
    return [emu.get(i, "goal_position") for i in emu.ids]


def test_a_goal_a_servo_missed_is_sent_again(bus, monkeypatch):
    emu, driver = bus
    servo = emu.ids[2]
    _ignore_writes(monkeypatch, emu, servo, "goal_position", times=2)
    goal = [2000, 2100, 1900, 2050]
    writes = emu.sync_writes
    driver.write_goals(goal)
    assert _goals(emu) == goal
    assert emu.sync_writes - writes == 3  # the first two missed by one servo, each followed by a read-back
    last = [p for p in emu.packets if p[0] == "sync write"][-1]
    assert last[2][2 * emu.bus.ADDRESS_BYTES] == servo  # the resend goes to that servo only


def test_a_resend_that_lands_on_another_servo_is_caught_by_reading_every_servo_back(bus, monkeypatch):
    """A resend of one servo's goal, damaged on the way so that it passes the checksum (Feetech's is 8 bits) but
    writes another servo's goal register, must not leave that servo (confirmed earlier) with a wrong goal."""
    emu, driver = bus
    missed, hit = emu.ids[2], emu.ids[0]
    _ignore_writes(monkeypatch, emu, missed, "goal_position", times=1)
    address, size = emu.bus.TABLE["goal_position"]
    apply, writes = emu._apply_write, [0]

    def apply_write(sid, start, data):
        if start == address and sid == missed:
            writes[0] += 1
            if writes[0] == 2:  # the resend to that servo alone, its bytes also taken as a write to another
                apply(hit, start, list((1234).to_bytes(size, "little")))
        apply(sid, start, data)

    monkeypatch.setattr(emu, "_apply_write", apply_write)
    goal = [2000, 2100, 1900, 2050]
    driver.write_goals(goal)
    assert writes[0] >= 2 and _goals(emu) == goal


def test_a_servo_that_never_takes_its_goal_is_a_bus_fault_naming_it(bus, monkeypatch):
    emu, driver = bus
    servo = emu.ids[1]
    _ignore_writes(monkeypatch, emu, servo, "goal_position")
    name = driver.robot.joint_names[1]
    with pytest.raises(BusFault, match=rf"goal_position not confirmed after {WRITE_TRIES} sync writes.*servo {servo} "
                                       rf"\(joint '{name}'\) was sent 2222, holds \d+") as info:
        driver.write_goals([2048, 2222, 2048, 2048])
    assert "servo " + str(emu.ids[0]) + " " not in str(info.value)  # only the servo that failed is named
    assert "tried at 1000000 bit/s" in str(info.value)


def test_torque_is_confirmed_by_reading_it_back(bus, monkeypatch):
    emu, driver = bus
    emu.faults.drop_status = 3  # read-backs lost: read again, not taken on trust
    driver.torque(True)
    assert [emu.torque(i) for i in emu.ids] == [True] * len(emu.ids)
    _ignore_writes(monkeypatch, emu, emu.ids[3], "torque_enable")
    with pytest.raises(BusFault, match=rf"torque_enable not confirmed.*servo {emu.ids[3]} .*was sent 0, holds 1"):
        driver.torque(False)
    assert driver.torque_off_quietly() == [emu.ids[3]]


def test_the_confirmed_write_takes_any_register(bus):
    emu, driver = bus
    field = "profile_velocity" if emu.bus.PROTOCOL == "dynamixel" else "goal_velocity"
    write_confirmed(driver, field, {i: 100 + i for i in emu.ids})
    assert [emu.get(i, field) for i in emu.ids] == [100 + i for i in emu.ids]


def test_a_damaged_status_packet_is_read_again_from_that_servo_only(bus):
    emu, driver = bus
    emu.faults.corrupt_status = 1  # the first servo's answer to the next sync read
    reading = driver.read_state()
    assert len(reading.ticks) == len(emu.ids)
    reads = [p for p in emu.packets if p[0] == "sync read"]
    assert reads[-1][2][2 * emu.bus.ADDRESS_BYTES:] == [emu.ids[0]]


def test_pings_are_retried_and_a_silent_servo_is_named_with_what_was_tried(bus):
    emu, driver = bus
    emu.faults.corrupt_status = 2
    assert set(driver.ping_all()) == set(emu.ids)
    emu.faults.silent.add(emu.ids[1])
    with pytest.raises(BusFault, match=rf"servo {emu.ids[1]} .* does not answer ping \(There is no status packet!\) "
                                       rf"after {driver.retries + 1} pings.*tried at 1000000 bit/s, status timeouts "
                                       rf"for 100 ms"):
        driver.ping_all()
    emu.faults.silent.clear()
    emu.faults.corrupt_status = 100
    # (a reply that a loaded machine delays past its timeout counts as none: then both kinds are listed)
    with pytest.raises(BusFault, match=r"answers only with damaged status packets|"
                                       r"does not answer ping \(.*Incorrect status packet!"):
        driver.ping_all()


def _fake_sysfs(tmp_path, device, value):
    tty = device.rsplit("/", 1)[-1]
    folder = tmp_path / "bus" / "usb-serial" / "devices" / tty
    folder.mkdir(parents=True)
    (folder / "latency_timer").write_text(value)
    return tty


def test_a_latency_timer_above_the_latency_allowed_for_is_reported_with_its_fix(robot_file, kind, tmp_path,
                                                                                monkeypatch):
    with BusEmulator(robot_file, wall_clock=True) as emu:
        tty = _fake_sysfs(tmp_path, emu.path, "16\n")
        monkeypatch.setattr(_adapter, "SYSFS", str(tmp_path))
        driver_class = bus_module(kind).Driver
        with pytest.warns(BusWarning, match=rf"holds received bytes for 16 ms .* longer than the 1 ms .*"
                                            rf"'echo 1 \| sudo tee /sys/bus/usb-serial/devices/{tty}/latency_timer'"):
            driver = driver_class(Robot.load(robot_file), emu.path, latency=1)
        try:
            assert driver.latency_timer == 16
            emu.faults.silent.add(emu.ids[0])
            with pytest.raises(BusFault, match=r"adapter latency timer 16 ms; the adapter .* set it to 1 ms"):
                driver.ping_all()
        finally:
            driver.close()
        with warnings.catch_warnings():
            warnings.simplefilter("error", BusWarning)  # a timer within the latency allowed for: nothing to say
            driver_class(Robot.load(robot_file), emu.path, latency=20).close()


def test_the_latency_timer_is_none_where_the_system_shows_none(tmp_path):
    assert _adapter.latency_timer("/dev/ttyUSB0", sysfs=str(tmp_path)) is None
    _fake_sysfs(tmp_path, "/dev/ttyUSB0", "not a number")
    assert _adapter.latency_timer("/dev/ttyUSB0", sysfs=str(tmp_path)) is None
    assert _adapter.latency_note("/dev/ttyUSB0", None, 16.0) == ""
    assert _adapter.latency_note("/dev/ttyUSB0", 16, 16.0) == ""


def test_the_robot_files_bus_latency_sets_the_status_timeouts(robot_file, kind, tmp_path):
    text = open(robot_file, encoding="utf-8").read().replace("[bus]\n", "[bus]\nlatency = 30\n", 1)
    path = tmp_path / "robot.toml"
    path.write_text(text, encoding="utf-8")
    robot = Robot.load(str(path))
    assert robot.bus.latency == 30.0
    with BusEmulator(robot) as emu:
        driver = bus_module(kind).Driver(robot, emu.path)
        try:
            assert driver.latency == 30.0
            driver.handler.setPacketTimeout(0)
            assert driver.handler.packet_timeout == pytest.approx(62.0)
        finally:
            driver.close()


def test_a_gain_write_a_servo_missed_is_sent_again(bus, monkeypatch):
    from labkit.arm.bus._gains import GainBook

    emu, driver = bus
    field = emu.bus.GAINS["kp"][0]
    _ignore_writes(monkeypatch, emu, emu.ids[1], field, times=1)
    book = GainBook(driver)
    kp = book.read(1).kp + 3
    assert book.write(1, kp=kp).kp == kp
    assert emu.get(emu.ids[1], field) == kp


def test_a_virtual_bus_slower_than_the_status_timeout_is_waited_for_and_a_lost_packet_is_not(bus, monkeypatch):
    """The emulator is a thread of this process: on a loaded machine it answers seconds late. The driver's timeout
    starts once the emulator has the request, so a late answer is taken at the first sync read, while a status
    packet the emulator drops is still a timeout (read again)."""
    import time

    emu, driver = bus
    handle = emu.handle

    def slow(*args):  # the emulator's thread held up for longer than the 202 ms status timeout
        time.sleep(0.6)
        return handle(*args)

    monkeypatch.setattr(emu, "handle", slow)
    sent, send = [], driver._sync_read_tx

    def counted(*args):  # the sync reads the host sends
        sent.append(args)
        return send(*args)

    monkeypatch.setattr(driver, "_sync_read_tx", counted)
    driver.read_state()
    assert len(sent) == 1  # no retry: nothing was lost
    emu.faults.drop_status = 1  # the first servo's answer lost: a timeout, then the servos without one asked again
    driver.read_state()
    assert len(sent) == 3
