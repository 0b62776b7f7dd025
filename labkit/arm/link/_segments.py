"""Trajectories as protocol segments (private; re-exported by :mod:`labkit.arm`).

The board's ``SEG`` command takes one polynomial per joint over normalised
time, with integer coefficients in the joint's wire units (centidegrees; an RC linear servo:
1/18000 of its stroke, :class:`labkit.arm.WireUnits`; ``docs/protocol.md``).
:func:`segments_from_trajectory` turns a sampled trajectory into such
segments (a polynomial too wide for one request line as pieces of it in time);
:func:`feed_segments` streams them into the board's queue for
:meth:`labkit.arm.Arm.run_trajectory`, which reports a :class:`TrajectoryReport`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from labkit.exceptions import DeviceError, JointLimitError, OptionError, TrajectoryError
from labkit.arm._segment_check import segment_position_ok, segment_speed_ok
from labkit.arm._protocol import (CommandRejected, MAX_LINE, SERVO_FULL, WireUnits, check_request, request_length,
                                  wire_calibrations)

__all__ = ["TrajectoryReport", "segments_from_trajectory"]


@dataclass(frozen=True)
class TrajectoryReport:
    """Outcome of :meth:`Arm.run_trajectory`: segments sent, retries, underruns, board time [s]."""

    segments: int
    retries: int
    queue_full_waits: int
    underruns: int
    duration: float


def _hermite(d0, v0, a0, d1, v1, a1, order):
    """Hermite polynomials over normalised time, one row a joint, shape (n, order + 1) [wire units], not rounded.

    ``d0``, ``d1`` are the end positions, ``v0``, ``v1`` the rates times the duration ``T`` and ``a0``, ``a1``
    the accelerations times ``T^2`` (shape (n,), wire units); ``order`` 3 matches position and velocity, 5 also
    acceleration."""
    h = d1 - d0
    if order == 3:
        return np.stack([d0, v0, 3 * h - 2 * v0 - v1, -2 * h + v0 + v1], axis=1)
    return np.stack([d0, v0, a0 / 2, 10 * h - 6 * v0 - 4 * v1 - 1.5 * a0 + 0.5 * a1,
                     -15 * h + 8 * v0 + 7 * v1 + 1.5 * a0 - a1, 6 * h - 3 * v0 - 3 * v1 - 0.5 * a0 + 0.5 * a1], axis=1)


def _piece(rows, s0, s1):
    """The polynomials ``rows`` (n, k + 1) on ``s0 <= s <= s1`` over their own normalised time: ``p(s0 + (s1 - s0) u)``."""
    k = rows.shape[1] - 1
    w = s1 - s0
    shift = np.zeros((k + 1, k + 1))  # shift[i, m]: coefficient of u^m in (s0 + w u)^i
    for i in range(k + 1):
        for m in range(i + 1):
            shift[i, m] = math.comb(i, m) * s0 ** (i - m) * w ** m
    return rows @ shift


def _integer_rows(rows, start, end):
    """``rows`` rounded to integers, shape (n, k + 1), starting at ``start`` and ending at ``end`` exactly (shape (n,))."""
    c = np.round(rows).astype(np.int64)
    c[:, 0] = start
    c[:, -1] = end - c[:, :-1].sum(axis=1)
    return c


def _split(rows, dur_ms, order, start, end, pieces):
    """``SEG`` segments of ``rows`` (n, order + 1) over ``dur_ms`` in ``pieces`` of whole milliseconds, as equal as can be.

    Each piece is the same polynomial over its own normalised time (exact but for rounding its coefficients to
    integers), its end the next one's start; the first starts at ``start``, the last ends at ``end``. A generator:
    whoever only checks the pieces stops at the first that fails."""
    cuts = [dur_ms * i // pieces for i in range(pieces + 1)]
    begin = start
    for i, (a, b) in enumerate(zip(cuts[:-1], cuts[1:])):
        finish = end if i == pieces - 1 else np.round(np.polynomial.polynomial.polyval(b / dur_ms, rows.T)).astype(
            np.int64)
        yield b - a, order, _integer_rows(_piece(rows, a / dur_ms, b / dur_ms), begin, finish).ravel().tolist()
        begin = finish


def _line_fits(seg):
    return request_length("SEG", [seg[0], seg[1], *seg[2]]) <= MAX_LINE


def _fitting_pieces(rows, dur_ms, order, start, end):
    """The fewest equal pieces of ``rows`` over ``dur_ms`` whose ``SEG`` lines all fit :data:`MAX_LINE` (1 if it fits).

    Pieces of a polynomial have smaller coefficients (all but the first scale with the duration), so the count is
    searched by doubling, then bisected; ``None`` if even pieces of 1 ms (the shortest ``SEG``) do not fit."""
    fits = lambda m: all(_line_fits(seg) for seg in _split(rows, dur_ms, order, start, end, m))  # noqa: E731
    low, high = 0, 1  # low does not fit (0 pieces: nothing tried yet)
    while not fits(high):
        if high >= dur_ms:
            return None
        low, high = high, min(2 * high, dur_ms)
    while high - low > 1:
        mid = (low + high) // 2
        low, high = (low, mid) if fits(mid) else (mid, high)
    return list(_split(rows, dur_ms, order, start, end, high))


def _wire_units(traj, n, units):
    """Joint values or rates [rad | m, per s^k], shape (..., n) -> wire units (not rounded), as a function.

    ``units`` (a :class:`WireUnits`) or, when ``None``, centidegrees, which is right for revolute joints only."""
    if units is None:
        revolute = tuple(getattr(traj, "revolute", ()) or ())
        prismatic = [j + 1 for j, r in enumerate(revolute) if not r]
        if prismatic:
            raise OptionError(
                f"expected units=WireUnits(robot) for a trajectory with prismatic joints, got units=None and "
                f"prismatic joint(s) {prismatic}: a prismatic joint's wire unit depends on its actuator (an RC linear "
                f"servo: 1/18000 of its stroke; none: metres read as radians, docs/protocol.md 3); "
                f"Arm.run_trajectory passes its robot's units")
        return lambda x: np.degrees(x) * 100
    if len(units.metres) != n:
        raise OptionError(f"expected units of {n} joints (the trajectory's), got units of {len(units.metres)}")
    return lambda x: np.array([units.value(j, v) for j, v in enumerate(x)])


def segments_from_trajectory(traj, *, order=3, min_duration=0.05, units=None):
    """Protocol segments ``(dur_ms, order, coefficients)`` of a sampled trajectory.

    Consecutive samples (merged until at least ``min_duration`` apart) become
    one Hermite polynomial each, matching position and velocity (and
    acceleration for ``order=5``) at both ends; coefficients are integers in
    the joints' wire units over normalised time, the end point of each segment is
    the exact start of the next. A polynomial whose ``SEG`` line would be longer than the
    protocol's :data:`~labkit.arm.MAX_LINE` (a fast quintic of 6 to 8 joints) is sent as
    the fewest equal pieces of whole milliseconds whose lines fit: the same polynomial over
    each piece's own normalised time, so the board runs the same motion (to within rounding
    the coefficients to integers, a few wire units at most; ``docs/protocol.md`` 4.3).

    Parameters
    ----------
    traj : labkit.motion.Trajectory
        Samples ``t`` (m,), ``q``/``qd``/``qdd`` (m, n) [s, rad | m, per s, per s^2].
    order : {3, 5}
    min_duration : float
        Shortest segment [s] (before splitting one whose line is too long).
    units : WireUnits, optional
        The robot's wire units (``WireUnits(robot)``; :meth:`labkit.arm.Arm.run_trajectory` passes its
        own). Default centidegrees, right for every revolute joint; a trajectory with a prismatic joint
        (``traj.revolute``) needs them: its unit depends on the joint's actuator.

    Returns
    -------
    list of tuple
        ``(dur_ms, order, coefficients)`` with ``n * (order + 1)`` coefficients.

    Raises
    ------
    OptionError
        ``order`` is neither 3 nor 5; ``units`` missing for a trajectory with a prismatic joint, or of
        another number of joints; a segment whose line does not fit even in pieces of 1 ms (the
        shortest ``SEG``).

    Examples
    --------
    >>> from labkit.motion import joint_trajectory
    >>> traj = joint_trajectory(None, [0.0], [math.pi / 2], 1.0, law="quintic", dt=0.5)
    >>> segments_from_trajectory(traj, order=5, min_duration=1.0)
    [(1000, 5, [0, 0, 0, 90000, -135000, 54000])]
    """
    if order not in (3, 5):
        raise OptionError(f"expected order 3 or 5, got {order!r}")
    t = np.asarray(traj.t, float)
    q, qd = np.asarray(traj.q, float), np.asarray(traj.qd, float)
    qdd = np.asarray(traj.qdd, float) if traj.qdd is not None else np.zeros_like(q)
    wire = _wire_units(traj, q.shape[1], units)
    keep = [0]
    for k in range(1, len(t)):
        if t[k] - t[keep[-1]] >= min_duration - 1e-9 or k == len(t) - 1:
            keep.append(k)
    segs = []
    for a, b in zip(keep[:-1], keep[1:]):
        T = round((t[b] - t[a]) * 1000) / 1000
        if T <= 0:
            continue
        d0, d1 = wire(q[a]), wire(q[b])
        rows = _hermite(d0, wire(qd[a]) * T, wire(qdd[a]) * T * T, d1, wire(qd[b]) * T, wire(qdd[b]) * T * T, order)
        dur_ms = int(round(T * 1000))
        start, end = np.round(d0).astype(np.int64), np.round(d1).astype(np.int64)
        pieces = _fitting_pieces(rows, dur_ms, order, start, end)
        if pieces is None:
            widest = max(request_length("SEG", [d, o, *c]) for d, o, c in _split(rows, dur_ms, order, start, end,
                                                                                dur_ms))
            raise OptionError(
                f"expected SEG lines of at most {MAX_LINE} bytes (docs/protocol.md 2.1), got the segment at "
                f"t = {t[a]:g}..{t[b]:g} s ({dur_ms} ms, {q.shape[1]} joints of order {order}) {widest} bytes wide "
                f"even in pieces of 1 ms (the shortest SEG): nothing was sent - use order=3, or fewer joints")
        segs += pieces
    return segs


def check_segment_speeds(robot, segs, vmax, amax):
    """Raise if a segment breaks a joint's speed or acceleration limit, exactly as the board checks it.

    Parameters
    ----------
    robot : labkit.Robot
        For the joint names in the message.
    segs : list of tuple
        ``(dur_ms, order, coefficients)`` (coefficients joint by joint [wire units]).
    vmax, amax : sequence of int
        Per-joint limits [units/s], [units/s^2] (0: unchecked), as sent with ``LIMITS``.

    Raises
    ------
    TrajectoryError
        Names the segment and joint; nothing has been sent.
    """
    units = WireUnits(robot)
    for k, (dur, order, coef) in enumerate(segs):
        for j in range(robot.n):
            row = coef[j * (order + 1):(j + 1) * (order + 1)]
            if not segment_speed_ok(row, dur, vmax[j], amax[j]):
                raise TrajectoryError(
                    f"segment {k} ({dur} ms): joint {j + 1} ({robot.links[j].name}) exceeds its speed limit "
                    f"{units.show(j, vmax[j])}/s or acceleration limit {units.show(j, amax[j])}/s^2 (0: unchecked); "
                    f"nothing was sent - slow the trajectory down")


def check_segment_lines(segs):
    """Raise if a segment's ``SEG`` request would be longer than the protocol's line limit (before any is sent).

    Checked with the widest sequence id (``#65535``), so whether a trajectory is refused does not depend on
    how many requests were sent before it.

    Parameters
    ----------
    segs : list of tuple
        ``(dur_ms, order, coefficients)``.

    Raises
    ------
    OptionError
        Names the segment, the command, its number of values, the line length, the limit and what to do;
        nothing has been sent.
    """
    for k, (dur, order, coef) in enumerate(segs):
        try:
            check_request("SEG", [dur, order, *coef])
        except OptionError as exc:
            raise OptionError(f"segment {k} of {len(segs)} ({dur} ms): {exc}") from None


def feasible_ranges(robot):
    """Each joint's range on the board [wire units]: its limits within its servo's travel (what ``SEG`` checks).

    Parameters
    ----------
    robot : labkit.Robot
        Joint limits [rad | m] and servo calibrations, as :meth:`labkit.arm.Arm.sync_calibration` sends
        them (:func:`labkit.arm.wire_calibrations`); a joint without a servo is an ideal actuator over its limits.

    Returns
    -------
    list of tuple of int
        ``(lo, hi)`` per joint [wire units: cdeg, or 1/18000 of an RC linear servo's stroke].
    """
    units, (rows, _) = WireUnits(robot), wire_calibrations(robot)
    ranges = []
    for j, (lk, row) in enumerate(zip(robot.links, rows)):
        lo, hi = (int(round(units.value(j, v))) for v in lk.limits)
        if row is None:  # a servo bus (its limits checked against the ticks at load) or an ideal actuator
            ranges.append((lo, hi))
            continue
        zero, direction = row[2], row[3]
        a, b = (-zero, SERVO_FULL - zero) if direction > 0 else (zero - SERVO_FULL, zero)
        ranges.append((max(a, lo), min(b, hi)))
    return ranges


def check_segment_positions(robot, segs):
    """Raise if a segment leaves a joint's range anywhere (also between trajectory samples), as the board checks it.

    Parameters
    ----------
    robot : labkit.Robot
        Joint limits, servo calibrations and joint names.
    segs : list of tuple
        ``(dur_ms, order, coefficients)`` (coefficients joint by joint [wire units]).

    Raises
    ------
    JointLimitError
        Names the segment and joint; nothing has been sent.
    """
    ranges, units = feasible_ranges(robot), WireUnits(robot)
    for k, (dur, order, coef) in enumerate(segs):
        for j, (lo, hi) in enumerate(ranges):
            row = coef[j * (order + 1):(j + 1) * (order + 1)]
            if lo > hi or not segment_position_ok(row, lo, hi):
                raise JointLimitError(
                    f"segment {k} ({dur} ms): joint {j + 1} ({robot.links[j].name}) leaves its range "
                    f"{units.show(j, lo)}..{units.show(j, hi)} between the trajectory's samples (the board would "
                    f"refuse it); nothing was sent - keep the trajectory further inside the limits", joint=j)


def move_segment(q0, q1, dur_ms):
    """Per-joint coefficients [cdeg] of the rest-to-rest cubic a ``MOVE`` runs (``docs/protocol.md`` 4.2).

    Parameters
    ----------
    q0, q1 : sequence of int, shape (n,)
        Commanded position before the move and its target [cdeg].
    dur_ms : int
        Duration of the move [ms].

    Returns
    -------
    tuple
        ``(dur_ms, 3, coefficients)`` as :func:`check_segment_speeds` takes it,
        coefficients ``q0, 0, 3 dq, -2 dq`` joint by joint (shape (4 n,)) [cdeg].

    Examples
    --------
    >>> move_segment([4500], [9000], 500)
    (500, 3, [4500, 0, 13500, -9000])
    """
    coef = []
    for a, b in zip(q0, q1):
        coef += [int(a), 0, 3 * (int(b) - int(a)), -2 * (int(b) - int(a))]
    return int(dur_ms), 3, coef


def move_duration_ms(q0, q1, vmax, amax):
    """Shortest ``MOVE`` duration [ms] that keeps every joint within its speed and acceleration limits.

    The rest-to-rest cubic peaks at ``1.5 |dq| / T`` [cdeg/s] and ``6 |dq| / T^2``
    [cdeg/s^2]; the result is then confirmed with the board's own check (``docs/protocol.md`` 4.3),
    one millisecond longer while that cannot prove it.

    Parameters
    ----------
    q0, q1 : sequence of int, shape (n,)
        Commanded position before the move and its target [cdeg].
    vmax, amax : sequence of int, shape (n,)
        Per-joint limits [units/s], [units/s^2] (0: unchecked), as sent with ``LIMITS``.

    Returns
    -------
    int
        Duration [ms], 1..60000.

    Raises
    ------
    TrajectoryError
        The move would need longer than 60 s (the longest ``MOVE``).

    Examples
    --------
    >>> move_duration_ms([4500], [9000], [30000], [0])  # 45 deg at 300 deg/s: 1.5 * 45 / 300 s
    225
    """
    t = 0.0
    for a, b, v, acc in zip(q0, q1, vmax, amax):
        d = abs(int(b) - int(a))
        if v:
            t = max(t, 1.5 * d / v)
        if acc:
            t = max(t, math.sqrt(6.0 * d / acc))
    dur = max(1, math.ceil(t * 1000 - 1e-9))
    while dur <= 60000:
        _, _, coef = move_segment(q0, q1, dur)
        if all(segment_speed_ok(coef[4 * j:4 * j + 4], dur, vmax[j], amax[j]) for j in range(len(vmax))):
            return dur
        dur += 1
    raise TrajectoryError(f"expected a move that the speed limits allow within 60 s, got {list(q0)} -> "
                          f"{list(q1)} cdeg with vmax {list(vmax)} cdeg/s, amax {list(amax)} cdeg/s^2")


def feed_segments(arm, segs, *, progress=None, wait=True):
    """Stream ``segs`` to the board's segment queue through ``arm``, keeping the queue fed.

    A full queue (``ERR 7 QFULL``) is waited out, an acknowledgement lost on
    the wire is settled by asking ``STATUS`` (the segment is never blindly
    sent twice), and ``EV DONE`` before the last segment counts as an underrun.

    Parameters
    ----------
    arm : labkit.arm.Arm
        The open link.
    segs : list of tuple
        ``(dur_ms, order, coefficients)`` from :func:`segments_from_trajectory`.
    progress : callable or bool, optional
        ``progress(done, total)`` after each queued segment, or ``True`` for a tqdm bar.
    wait : bool
        Wait until the board has run every segment.

    Returns
    -------
    TrajectoryReport

    Raises
    ------
    DeviceError
        A segment rejected or lost, or the board held (host-silence timeout).
    """
    bar = None
    if progress is True:
        from tqdm.auto import tqdm

        bar = tqdm(total=len(segs), unit="seg")
        progress = lambda k, n: bar.update(1)  # noqa: E731
    st = arm.status()
    accepted = st.done + st.queue
    t_start = st.t
    retries0, qfull, underruns = arm.stats.retries, 0, 0
    dones_seen = len([e for e in arm.events if e[0] == "DONE"])
    for k, (dur, order_k, coef) in enumerate(segs):
        def verify(seq, expected=accepted):
            s, ran = arm._verify_status(seq)
            if s.state == "HOLD":
                raise DeviceError(f"{arm.name}: the board halted the trajectory (host-silence timeout)")
            total = s.done + s.queue
            if total != expected + ran:
                arm._wire.hold(f"SEG #{seq}: segment bookkeeping lost (board {total}, host {expected + ran})")
            return ran

        while True:
            try:
                r = arm._transact("SEG", dur, order_k, *coef, motion=True, verify=verify)
                break
            except CommandRejected as exc:
                if exc.code != 7:
                    raise
                qfull += 1
                arm.sleep(min(dur / 2000.0, 0.1))
                arm.ping()  # a rejected SEG does not reset the board's host-silence timer
        accepted += 1
        if len([e for e in arm.events if e[0] == "DONE"]) > dones_seen and k < len(segs):
            underruns += 1
            dones_seen = len([e for e in arm.events if e[0] == "DONE"])
        if progress:
            progress(k + 1, len(segs))
        free = int(r.tokens[2]) if len(r.tokens) > 2 and r.tokens[2].isdigit() else 1
        if free == 0:
            arm.sleep(min(dur / 1000.0, 0.1))
            arm.ping()
    if bar is not None:
        bar.close()
    if wait:
        end_needed = accepted
        while True:
            st = arm.status()
            if st.state == "HOLD":
                raise DeviceError(f"{arm.name}: the board halted the trajectory (host-silence timeout)")
            if st.state == "IDLE" and st.done >= end_needed:
                break
            arm.sleep(0.1)
    return TrajectoryReport(len(segs), arm.stats.retries - retries0, qfull, underruns,
                            arm.status().t - t_start if wait else float("nan"))
