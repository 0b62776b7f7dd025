"""Confirmed bus transactions: reads retried servo by servo, writes read back until every servo holds its value.

A sync write has no status packet, so nothing says whether each servo took it; a status packet can be
lost or damaged on its way back. The functions here are what :class:`BusDriver` does on top of the vendor
SDK so that the host always knows what the servos hold:

- :func:`read_registers` sync-reads a register block of several servos and reads again, a bounded number
  of times, only the servos whose status packet did not come back intact (a short, stale or corrupt
  packet counts as lost);
- :func:`write_confirmed` sync-writes a register of several servos, reads it back and writes again to
  the servos that do not hold their value, a bounded number of times (after a resend to some servos only,
  every servo is read back once more: a damaged resend that passes the checksum may have landed on another),
  and raises a :class:`BusFault` naming the servos that still do not; :func:`write_unconfirmed` is the same returning them instead
  (torque off after a fault, which must never raise).

Every register write that matters goes through :func:`write_confirmed`: goal positions every servo
frame, torque on and off, and any register a caller adds (position-loop gains, profiles). Before each
request the host discards what is left in its receive buffer, so that a late status packet of an earlier
request is never taken for the answer to this one.
"""

from __future__ import annotations

from labkit.exceptions import BusFault
from labkit.arm.bus._adapter import advice

__all__ = ["READ_TRIES", "WRITE_TRIES", "READBACK_TRIES", "read_registers", "write_confirmed", "write_unconfirmed"]

#: sync reads of one register block before a servo without an intact status packet is a :class:`BusFault`
READ_TRIES = 8
#: sync writes of one value before a servo that does not hold it is a :class:`BusFault`
WRITE_TRIES = 8
#: sync reads of each read-back after a sync write (a servo whose read-back is lost is asked again, then written again)
READBACK_TRIES = 2


def _drain(driver):
    """Discard received bytes nobody waits for (a late or damaged status packet of an earlier request)."""
    try:
        driver.handler.ser.reset_input_buffer()
    except Exception:  # noqa: BLE001 - a vanished adapter: the request that follows reports it
        pass


def _servos(driver, ids):
    return ", ".join(driver.servo(i) for i in ids)


def read_registers(driver, address, size, ids, *, tries=READ_TRIES, check_error=True):
    """The ``size`` bytes at ``address`` of every servo in ``ids``, by sync reads retried servo by servo.

    Parameters
    ----------
    driver : BusDriver
        The open bus.
    address, size : int
        Control-table address and length [bytes] of the block.
    ids : sequence of int
        Servo ids.
    tries : int
        Sync reads at most; each one asks only the servos still without an intact status packet.
    check_error : bool
        Raise when a status packet flags a hardware error (overload, overheating ...).

    Returns
    -------
    dict of int to list of int
        Servo id -> the block's bytes, least significant first.

    Raises
    ------
    BusFault
        A servo without an intact status packet after ``tries`` sync reads (the message names it, what
        came back and what to check), or a hardware error.
    """
    got, pending, last = {}, list(ids), {}
    for _ in range(max(1, int(tries))):
        held, why = _read_round(driver, address, size, pending, check_error)
        got.update(held)
        last.update(why)
        pending = [i for i in pending if i not in got]
        if not pending:
            return got
    why = "; ".join(f"{driver.servo(i)}: {last.get(i, '?')}" for i in pending)
    raise BusFault(f"{driver.name}: no intact status packet from {_servos(driver, pending)} after {max(1, int(tries))} "
                   f"sync reads ({why}); {advice(driver)}")


def _read_round(driver, address, size, ids, check_error):
    """One sync read: ``(intact blocks by id, why each other servo has none)``; raises only on a hardware error."""
    _drain(driver)
    result = driver._sync_read_tx(address, size, ids)
    if result != driver.sdk.COMM_SUCCESS:
        return {}, {i: f"sync read not sent: {driver._comm(result)}" for i in ids}
    got, last = {}, {}
    for k, servo_id in enumerate(ids):
        if k and last.get(ids[k - 1]) == driver._comm(driver.sdk.COMM_RX_CORRUPT):
            # the SDK's timeout for the whole answer has run out on a damaged packet: the next servos' packets
            # may be intact in the buffer, give each its own status timeout (after a silence, nothing more comes)
            driver.handler.setPacketTimeout(size + 11)
        data, result, error = driver.packets.readRx(driver.handler, servo_id, size)
        if result != driver.sdk.COMM_SUCCESS:
            last[servo_id] = driver._comm(result)
        elif len(data) != size:
            last[servo_id] = f"a status packet of {len(data)} bytes, expected {size}"
        elif error and check_error:
            raise BusFault(f"{driver.name}: {driver.servo(servo_id)} reports {driver._hardware_error(servo_id, error)}")
        else:
            got[servo_id] = list(data)
    return got, last


def _sync_write(driver, address, size, values):
    group = driver.sdk.GroupSyncWrite(driver.handler, driver.packets, address, size)
    for servo_id, value in values.items():
        group.addParam(servo_id, list((int(value) & ((1 << 8 * size) - 1)).to_bytes(size, "little")))
    _drain(driver)
    result = group.txPacket()
    driver.sync_writes += 1
    return result


def write_unconfirmed(driver, field, values, *, tries=WRITE_TRIES, read_tries=READBACK_TRIES, check_error=True):
    """Sync-write ``field`` of several servos until each reads it back; return those that never did.

    Parameters
    ----------
    driver : BusDriver
        The open bus.
    field : str
        A key of the driver's control table (``"goal_position"``, ``"torque_enable"`` ...).
    values : dict of int to int
        Servo id -> the value to hold (in the register's units; negative values two's complement).
    tries : int
        Sync writes at most (each followed by a read-back of the servos still not confirmed).
    read_tries : int
        Sync reads at most of each read-back (a servo whose read-back is lost is asked again before it is
        written again).
    check_error : bool
        Raise when a read-back flags a hardware error (``False``: a servo in error still takes a torque off).

    Returns
    -------
    dict of int to str
        Servo id -> what the last read-back showed, for every servo not confirmed (empty: all hold their value).

    Raises
    ------
    BusFault
        ``check_error`` and a servo reports a hardware error.
    """
    address, size = driver.table[field]
    pending, last, resent = dict(values), {}, False
    for _ in range(max(1, int(tries))):
        result = _sync_write(driver, address, size, pending)
        if result != driver.sdk.COMM_SUCCESS:
            last = {i: f"sync write not sent: {driver._comm(result)}" for i in pending}
            continue
        resent = resent or len(pending) < len(values)
        pending = _not_holding(driver, address, size, pending, read_tries, check_error, last)
        if not pending and resent:
            # a resend went to some servos only: a damaged one that passed the checksum (8 bits on a Feetech bus)
            # may have written another servo's register, so every servo is read back once more
            pending = _not_holding(driver, address, size, values, read_tries, check_error, last)
            resent = False
        if not pending:
            return {}
    return {i: last.get(i, "?") for i in pending}


def _not_holding(driver, address, size, values, read_tries, check_error, last):
    """The servos of ``values`` whose register does not read back as their value (or whose read-back is lost);
    what each showed goes into ``last``."""
    mask = (1 << 8 * size) - 1
    held = {}
    for _ in range(max(1, int(read_tries))):  # a lost read-back is read again, not written again
        got, why = _read_round(driver, address, size, [i for i in values if i not in held], check_error)
        held.update(got)
        last.update({i: f"no intact status packet to its read-back ({w})" for i, w in why.items()})
        if len(held) == len(values):
            break
    pending = {}
    for servo_id, value in values.items():
        data = held.get(servo_id)
        if data is not None and int.from_bytes(bytes(data), "little") == value & mask:
            continue
        if data is not None:
            last[servo_id] = f"holds {int.from_bytes(bytes(data), 'little')}"
        pending[servo_id] = value
    return pending


def write_confirmed(driver, field, values, *, tries=WRITE_TRIES, read_tries=READBACK_TRIES, check_error=True):
    """Sync-write ``field`` of several servos, read it back and write again until every servo holds its value.

    Parameters
    ----------
    driver : BusDriver
        The open bus.
    field : str
        A key of the driver's control table.
    values : dict of int to int
        Servo id -> the value to hold.
    tries : int
        Sync writes at most.
    read_tries : int
        Sync reads at most of each read-back.
    check_error : bool
        Raise when a read-back flags a hardware error.

    Raises
    ------
    BusFault
        A servo still does not hold its value after ``tries`` writes (the message names it, what it was
        sent and what it holds), or a hardware error.
    """
    failed = write_unconfirmed(driver, field, values, tries=tries, read_tries=read_tries, check_error=check_error)
    if failed:
        what = "; ".join(f"{driver.servo(i)} was sent {int(values[i])}, {why}" for i, why in failed.items())
        raise BusFault(f"{driver.name}: {field} not confirmed after {max(1, int(tries))} sync writes and "
                       f"read-backs ({what}); {advice(driver)}")
