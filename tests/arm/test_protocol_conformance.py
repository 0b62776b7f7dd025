"""Protocol conformance suite (docs/protocol.md), run against every board in tests/boards.py.

Every test talks to the board only through its serial port, and checks what the servos are
really commanded through ``board.pulses()``/``board.pulse_history()``: a rejected command must
never move anything, and the board must keep answering after any input.
"""

from __future__ import annotations

import re

import numpy as np
import pytest

from boards import BOARDS
from labkit.arm._protocol import MAX_LINE, READ_ONLY, echo, seal, unseal

pytestmark = [pytest.mark.firmware, pytest.mark.xdist_group("firmware")]

US_PER_CDEG = 2000 / 18000  # default calibration: 500..2500 us over 0..180 deg


def checked(line: str) -> str:
    """Append the CRC-32 to a request line."""
    return seal(line)


def sealed(line: str, seq: int) -> str:
    """A state-changing request as protocol 3 requires it: ``#seq``, the line, a space, ``*CRC``."""
    return seal(f"#{seq} {line} ")


def pulse_of(q_cdeg, pmin=500, pmax=2500):
    return pmin + q_cdeg * (pmax - pmin) / 18000


class Host:
    """Minimal stop-and-wait client: verifies every board line's checksum, collects events."""

    def __init__(self, port):
        self.port = port
        self.events: list[str] = []
        self.frames: list[str] = []
        self.replies: list[str] = []
        self.seq = 0

    def readline(self) -> str:
        raw = self.port.readline()
        assert raw.endswith(b"\r\n"), f"board line not terminated by CR LF (timeout?): {raw!r}"
        body = unseal(raw[:-2])
        assert body is not None, f"no or bad CRC on board line {raw!r}"
        assert len(raw) - 2 <= MAX_LINE
        return body.decode("ascii")

    def read_reply(self) -> str:
        while True:
            line = self.readline()
            if line.startswith("EV"):
                self.events.append(line)
            elif line.startswith("FB"):
                self.frames.append(line)
            else:
                assert line.startswith(("OK", "ERR")), f"unexpected board line {line!r}"
                self.replies.append(line)
                return line

    def send_raw(self, data: bytes):
        self.port.write(data)

    def cmd(self, line: str) -> str:
        """Send ``line``; a state-changing command typed plainly (``"MOVE 1 2 3"``) is sealed with the
        next ``#seq`` and its reply returned without that seq and its (checked) ``p=`` echo."""
        words = line.split()
        if line.startswith(("#", "$")) or "*" in line or not words or words[0].upper() in READ_ONLY:
            self.port.write(line.encode("latin-1") + b"\n")
            return self.read_reply()
        self.seq += 1
        self.port.write(sealed(line, self.seq).encode() + b"\n")
        reply = self.read_reply().replace(f" #{self.seq}", "", 1)
        if reply.startswith("OK"):
            want = echo(words[0], [int(w) for w in words[1:]])
            assert reply.split()[2:3] == [want], f"{line!r}: wrong echo in {reply!r}, expected {want}"
            reply = reply.replace(f" {want}", "", 1)
        return reply

    def ok(self, line: str) -> list[str]:
        reply = self.cmd(line)
        assert reply.startswith("OK"), f"{line!r} -> {reply!r}"
        return reply.split()[1:]

    def err(self, line, code: int) -> str:
        reply = self.cmd(line) if isinstance(line, str) else (self.send_raw(line), self.read_reply())[1]
        words = [w for w in reply.split() if not w.startswith("#")]
        assert words[:2] == ["ERR", str(code)], f"{line!r}: expected ERR {code}, got {reply!r}"
        return reply

    def wait_event(self, prefix: str) -> str:
        for ev in self.events:
            if ev.startswith(prefix):
                self.events.remove(ev)
                return ev
        while True:
            line = self.readline()
            if line.startswith(prefix):
                return line
            (self.frames if line.startswith("FB") else self.events).append(line)

    def status(self) -> dict:
        fields = self.ok("STATUS")[1:]
        return dict(f.split("=", 1) for f in fields)

    def move(self, board, q: str, dur_ms: int = 250):
        """``MOVE q dur_ms`` (a rest-to-rest cubic, docs/protocol.md 4.2) run to its end."""
        assert self.ok(f"MOVE {q} {dur_ms}") == ["MOVE", "5"]
        board.advance(dur_ms / 1000 + 0.05)
        self.wait_event("EV DONE")


@pytest.fixture(params=sorted(BOARDS))
def board(request):
    b = BOARDS[request.param]()
    yield b
    b.close()


@pytest.fixture
def host(board):
    h = Host(board.open())
    ready = h.wait_event("READY")
    assert ready.startswith("READY labkit-arm 3 fw=")
    return h


def assert_pulses(board, expected: dict, tol=1.5):
    got = board.pulses()
    for ch, us in expected.items():
        assert ch in got and abs(got[ch] - us) <= tol, f"channel {ch}: expected {us:.1f} us, got {got.get(ch)}"


# ------------------------------------------------------------------------------ handshake
def test_boot_line_and_hello(board, host):
    fields = host.ok("HELLO")
    assert fields[:2] == ["HELLO", "labkit-arm"]
    kv = dict(f.split("=") for f in fields[2:])
    assert kv["proto"] == "3" and re.fullmatch(r"\d+\.\d+\.\d+", kv["fw"])
    assert kv["joints"] == "3" and kv["channels"] == "4"
    assert int(kv["queue"]) >= 2 and kv["maxline"] == str(MAX_LINE)
    # boot position: middle of the limits, gripper in the middle of its pulse range
    board.advance(0.05)
    assert_pulses(board, {0: 1500, 1: 1500, 2: 1500, 3: 1500})


def test_sequence_id_and_checksum_are_echoed(host):
    assert host.cmd(checked("#42 PING")).startswith("OK #42 PING ")
    assert host.cmd("$" + checked("#7 ping")).startswith("OK #7 PING ")
    assert host.cmd("#65535 hello").startswith("OK #65535 HELLO")
    t1 = int(host.ok("PING")[1])
    t2 = int(host.ok("PING")[1])
    assert t2 >= t1
    assert host.cmd("  status  \t").startswith("OK STATUS")


# ------------------------------------------------------------------------------ moves and limits
def test_move_sets_servo_pulses(board, host):
    assert host.ok("MOVE 4500 9000 3000 400") == ["MOVE", "5"]  # free segment slots, as SEG
    assert host.status()["state"] == "RUN"
    board.advance(0.2)
    q0 = int(host.status()["q"].split(",")[0])
    assert 5500 < q0 < 8000  # a rest-to-rest cubic, about half way (s ~ 0.5: 6750)
    board.advance(0.25)
    assert host.wait_event("EV DONE").split()[2] == "1"  # a MOVE counts as one segment
    assert_pulses(board, {0: pulse_of(4500), 1: 1500, 2: pulse_of(3000), 3: 1500})
    status = host.status()
    assert status["q"] == "4500,9000,3000" and status["state"] == "IDLE"


@pytest.mark.parametrize(
    "line, code",
    [
        ("MOVE 4500 19000 3000 250", 6),
        ("MOVE -1 9000 3000 250", 6),
        ("MOVE 4500 9000 18001 250", 6),
        ("MOVE 4500 9000 3000", 2),  # the duration is required
        ("MOVE 4500 9000 3000 250 3000", 2),
        ("MOVE 4500 9000 3000.5 250", 2),
        ("MOVE 4500,9000,3000,250", 2),
        ("MOVE 45deg 9000 3000 250", 2),
        ("MOVE 99999999999 9000 3000 250", 2),
        ("MOVE 4500 9000 3000 0", 5),
        ("MOVE 4500 9000 3000 60001", 5),
        ("MOVE 13500 9000 3000 50", 11),  # issue 13: 90 deg in 50 ms = 2700 deg/s > 600 deg/s
        ("MOVE 4500 9000 9000 100", 11),  # joint 2: 60 deg in 0.1 s = 900 deg/s
        ("GRIP 3000", 5),
        ("GRIP", 2),
    ],
)
def test_rejected_commands_move_nothing(board, host, line, code):
    host.move(board, "4500 9000 3000")
    board.advance(0.05)
    before = board.pulses()
    reply = host.err(line, code)
    assert reply.split()[2] == {2: "SYNTAX", 5: "RANGE", 6: "LIMIT", 11: "SPEED"}[code]
    board.advance(0.06)
    assert_pulses(board, before, tol=1.0)
    assert host.status()["q"] == "4500,9000,3000"


def test_gripper_and_calibration_mapping(board, host):
    assert host.ok("GRIP 1900") == ["GRIP", "1900"]
    # joint 0 reversed: servo angle = 18000 - q; pulses 600..2400
    assert host.ok("CAL 0 600 2400 18000 -1 0 18000") == ["CAL", "0", "600", "2400", "18000", "-1", "0", "18000"]
    host.move(board, "4500 9000 9000")
    board.advance(0.05)
    assert_pulses(board, {0: 600 + 13500 * 1800 / 18000, 3: 1900})
    # new limits must keep the current position valid, else nothing changes
    host.err("CAL 1 500 2500 0 1 0 8000", 6)
    host.err("CAL 1 500 2500 0 2 0 8000", 5)
    host.err("CAL 9", 5)
    assert host.ok("CAL 1")[1:] == ["1", "500", "2500", "0", "1", "0", "18000"]


# ------------------------------------------------------------------------------ bad input
BAD_LINES = [
    (b"#3 PING*0000\n", 1),          # wrong checksum
    (b"#3 PING*00\n", 1),            # malformed checksum (protocol 1's two digits)
    (b"PING*1\n", 1),
    (b"PING*XYZW\n", 1),
    (b"MOVE 0 0 0*ZZZZ\n", 1),
    (b"MOVE 4500 9000 3000\n", 1),    # state-changing without #seq and CRC
    (b"#4 MOVE 4500 9000 3000\n", 1),  # ... without CRC
    (b"FLY\n", 3),
    (b"#12 FLY 1 2\n", 3),
    (b"#123456 PING\n", 2),          # seq out of range
    (b"#x PING\n", 2),
    (b"#5\n", 2),                    # seq without command
    (b"$\n", 2),
    (b"PING 1\n", 2),
    (b"PI\x00NG\n", 2),              # binary garbage
    (b"\xff\xfe\xfd\n", 2),
    (b"MOVE " + b"1 " * 100 + b"\n", 4),  # 205 bytes: too long
    (b"X" * 1000 + b"\n", 4),
    ("SEG 1000 3 " + "0 " * 40, 2),  # too many arguments (sealed)
    ("STREAM 500", 5),
    ("TIMEOUT 10", 5),
    ("SEG 0 3 0 0 0 0 0 0 0 0 0 0 0 0", 5),
    ("SEG 1000 4 0 0 0 0 0", 5),
    ("MOVE -2147483648 0 0 250", 2),  # int32 without its minimum
]


def test_bad_input_of_every_kind(board, host):
    host.move(board, "4500 9000 3000")
    board.advance(0.05)
    before = board.pulses()
    for data, code in BAD_LINES:
        host.err(data.strip() if isinstance(data, str) else data, code)
    # empty and blank lines get no reply at all: the next reply belongs to HELLO
    host.send_raw(b"\n\r\n   \n\t\r")
    assert host.cmd("#9 HELLO").startswith("OK #9 HELLO")
    board.advance(0.06)
    assert_pulses(board, before, tol=1.0)
    status = host.status()
    assert status["q"] == "4500,9000,3000" and status["state"] == "IDLE"
    assert int(status["flags"], 16) & 0x10  # an over-long line was recorded


def test_random_garbage_never_moves_or_crashes(board, host, rng):
    host.move(board, "4500 9000 3000")
    board.advance(0.05)
    before = board.pulses()
    alphabet = np.frombuffer(b" \t*#$-+0123456789ABCDEFMOVESEGTIMabc\x00\x7f\xff", dtype=np.uint8)
    for _ in range(60):
        n = int(rng.integers(1, 200))
        body = bytes(rng.choice(alphabet, size=n)).replace(b"\n", b" ").replace(b"\r", b" ")
        data = b"~" + body + b"\n"  # a '~' first: never a valid command
        host.send_raw(data)
        assert host.read_reply().startswith("ERR"), data
    assert host.cmd("HELLO").startswith("OK HELLO")
    board.advance(0.06)
    assert_pulses(board, before, tol=1.0)


# ------------------------------------------------------------------------------ timed segments
def cubic_coeffs(q0, q1):
    dq = q1 - q0
    return [q0, 0, 3 * dq, -2 * dq]


def quintic_coeffs(q0, q1):
    dq = q1 - q0
    return [q0, 0, 0, 10 * dq, -15 * dq, 6 * dq]


def seg_line(dur_ms, per_joint):
    order = len(per_joint[0]) - 1
    return f"SEG {dur_ms} {order} " + " ".join(str(int(c)) for cs in per_joint for c in cs)


def fit_trajectory(history, channel, t_from, dur, q_of_s, search=0.3):
    """Max error [us] of measured widths vs the polynomial, at the best start time."""
    ev = np.array([(t, w) for t, ch, w in history if ch == channel and t >= t_from])
    assert len(ev) > 10, "too few pulse changes recorded"
    t, w = ev[:, 0], ev[:, 1]
    best = None
    for t0 in np.arange(t_from - 0.05, t_from + search, 0.0005):
        s = np.clip((t - t0) / dur, 0, 1)
        inside = (t >= t0) & (t <= t0 + dur)
        if inside.sum() < 10:
            continue
        err = np.max(np.abs(w[inside] - pulse_of(q_of_s(s[inside]))))
        if best is None or err < best[0]:
            best = (err, t0)
    return best


@pytest.mark.parametrize("order", [3, 5])
def test_timed_segment_pulses_follow_the_polynomial(board, host, order):
    host.ok("TIMEOUT 0")
    host.move(board, "4500 9000 3000")
    board.advance(0.05)
    make = cubic_coeffs if order == 3 else quintic_coeffs
    c0 = make(4500, 13500)
    t_send = board.time()
    free = int(host.ok(seg_line(800, [c0, make(9000, 9000), make(3000, 3000)]))[1])
    assert free >= 1
    board.advance(0.85)
    assert host.wait_event("EV DONE").split()[2] == "2"  # the MOVE, then the segment
    board.advance(0.05)
    assert_pulses(board, {0: pulse_of(13500), 1: 1500, 2: pulse_of(3000)})
    err, _ = fit_trajectory(board.pulse_history(t_send), 0, t_send, 0.8, lambda s: np.polyval(c0[::-1], s))
    assert err < 2.0, f"measured pulses deviate {err:.2f} us from the {order}-order polynomial"
    status = host.status()
    assert status["state"] == "IDLE" and status["q"] == "13500,9000,3000" and status["done"] == "2"


def test_segment_limits_and_continuity_rejected_without_motion(board, host):
    host.ok("TIMEOUT 0")
    host.move(board, "4500 9000 3000")
    board.advance(0.05)
    before = board.pulses()
    still = [9000, 0, 0, 0], [3000, 0, 0, 0]
    # overshoots 180 deg in the middle (c2 large): sampled check rejects it
    host.err(seg_line(500, [[4500, 0, 120000, -120000], *still]), 6)
    # starts at 60 deg while the joint is at 45 deg
    host.err(seg_line(500, [[6000, 0, 0, 0], *still]), 9)
    host.err("SEG 500 3 4500 0 0 0 9000 0 0 0 3000 0 0", 2)  # 11 coefficients, not 12
    host.err(seg_line(500, [[4500, 0, 0, 99999999], *still]), 5)
    board.advance(0.1)
    assert_pulses(board, before, tol=1.0)
    assert host.status()["state"] == "IDLE"


def test_queue_overflow_is_rejected_and_recovers(board, host):
    depth = int(dict(f.split("=") for f in host.ok("HELLO")[2:])["queue"])
    host.ok("TIMEOUT 0")
    host.move(board, "4500 9000 3000")
    hold = seg_line(400, [[4500, 0, 0, 0], [9000, 0, 0, 0], [3000, 0, 0, 0]])
    frees = [int(host.ok(hold)[1]) for _ in range(depth)]
    assert frees == list(range(depth - 1, -1, -1))
    host.err(hold, 7)
    host.err(hold, 7)
    status = host.status()
    assert status["queue"] == str(depth) and status["free"] == "0" and status["state"] == "RUN"
    host.err("MOVE 4500 9000 3000 250", 8)  # busy while running
    board.advance(0.5)
    assert int(host.ok(hold)[1]) == 0  # one slot freed and refilled
    board.advance(0.4 * depth)
    assert host.wait_event("EV DONE").split()[2] == str(1 + depth + 1)  # the MOVE and depth + 1 segments


def test_stop_halts_at_once_and_clears_queue(board, host):
    host.ok("TIMEOUT 0")
    host.move(board, "4500 9000 3000")
    host.ok(seg_line(2000, [cubic_coeffs(4500, 13500), [9000, 0, 0, 0], [3000, 0, 0, 0]]))
    host.ok(seg_line(2000, [cubic_coeffs(13500, 4500), [9000, 0, 0, 0], [3000, 0, 0, 0]]))
    board.advance(0.6)
    held = [int(v) for v in host.ok("STOP")[1:]]
    assert 4500 < held[0] < 13500 and held[1:] == [9000, 3000]
    board.advance(0.05)
    p1 = board.pulses()
    board.advance(0.3)
    assert_pulses(board, p1, tol=1.0)
    assert abs(p1[0] - pulse_of(held[0])) <= 1.5
    status = host.status()
    assert status["state"] == "IDLE" and status["queue"] == "0"
    assert not any(e.startswith("EV DONE") for e in host.events)


def test_host_silence_holds_position(board, host):
    host.move(board, "4500 9000 3000")
    assert host.ok("TIMEOUT 200") == ["TIMEOUT", "200"]
    host.ok(seg_line(3000, [cubic_coeffs(4500, 13500), [9000, 0, 0, 0], [3000, 0, 0, 0]]))
    board.advance(1.0)  # host silent for 1 s > 200 ms
    ev = host.wait_event("EV HOLD").split()
    held = int(ev[2])
    assert 4500 < held < 13500
    p1 = board.pulses()
    board.advance(0.3)
    assert_pulses(board, p1, tol=1.0)
    status = host.status()
    assert status["state"] == "HOLD" and int(status["flags"], 16) & 0x02 and status["queue"] == "0"
    # MOVE (or a new SEG/STOP) leaves HOLD
    assert host.ok(f"MOVE {held} 9000 3000 100") == ["MOVE", "5"]
    assert host.status()["state"] == "RUN"
    board.advance(0.12)
    host.wait_event("EV DONE")
    assert host.status()["state"] == "IDLE"


def test_keepalive_prevents_the_hold(board, host):
    host.move(board, "4500 9000 3000")
    host.ok("TIMEOUT 200")
    host.ok(seg_line(1000, [cubic_coeffs(4500, 9000), [9000, 0, 0, 0], [3000, 0, 0, 0]]))
    for _ in range(14):
        board.advance(0.08)
        host.ok("PING")
    host.wait_event("EV DONE")
    assert not any(e.startswith("EV HOLD") for e in host.events)
    assert host.status()["q"] == "9000,9000,3000"


# ------------------------------------------------------------------------------ feedback
def test_read_and_stream_feedback(board, host):
    volts = {0: 0.5, 1: 2.5, 2: 4.5, 5: 1.0}
    for pin, v in volts.items():
        board.set_analog(pin, v)
    board.advance(0.01)
    counts = [int(c) for c in host.ok("READ")[1:]]
    expected = np.floor(np.array([0.5, 2.5, 4.5, 1.0]) * 1024 / 5)  # +-1 count allowed
    assert len(counts) == 4 and np.all(np.abs(np.array(counts) - expected) <= 1), counts
    assert host.ok("STREAM 50") == ["STREAM", "50"]
    board.advance(0.5)
    host.ok("STREAM 0")
    frames = [f.split() for f in host.frames]
    n_after_stop = len(frames)
    assert 22 <= len(frames) <= 28, len(frames)
    assert [int(f[1]) for f in frames] == list(range(len(frames)))  # no lost frames
    times = np.array([int(f[2]) for f in frames])
    assert np.all(np.abs(np.diff(times) - 20) <= 2)  # jitter <= 2 ms (docs/protocol.md 4.5)
    assert abs((times[-1] - times[0]) / (len(times) - 1) - 20) < 0.5  # no drift
    assert all(np.all(np.abs(np.array([int(c) for c in f[3:]]) - expected) <= 1) for f in frames)
    board.advance(0.1)
    assert host.cmd("PING").startswith("OK PING")
    assert len(host.frames) == n_after_stop  # stream stopped


# ------------------------------------------------------------------------------ EEPROM
def test_calibration_persists_across_reset_only_when_saved(board, host):
    assert int(host.status()["flags"], 16) & 0x01  # fresh board: EEPROM invalid, defaults in use
    host.ok("CAL 2 600 2400 18000 -1 0 17000")
    host.ok("TIMEOUT 1500")
    assert host.ok("SAVE")[0] == "SAVE"
    host.ok("CAL 2 500 2500 0 1 0 18000")  # changed again but not saved
    board.reset()
    boot = host.wait_event("READY")
    assert "eeprom=OK" in boot
    assert host.ok("CAL 2")[1:] == ["2", "600", "2400", "18000", "-1", "0", "17000"]
    assert host.ok("TIMEOUT") == ["TIMEOUT", "1500"]
    status = host.status()
    assert not int(status["flags"], 16) & 0x01
    # boot position: middle of the stored limits (8500 -> servo 9500 cdeg -> 1550 us)
    board.advance(0.05)
    assert_pulses(board, {2: 600 + 9500 * 1800 / 18000})
    host.ok("DEFAULTS")
    host.ok("SAVE")
    board.reset()
    host.wait_event("READY")
    assert host.ok("CAL 2")[1:] == ["2", "500", "2500", "0", "1", "0", "18000"]


# ------------------------------------------------------------------------------ speed limits
def test_out_of_speed_segments_are_rejected_without_motion(board, host):
    """Issue 13: a 500 ms segment whose duration lost "00" ran 100x too fast; now both boards refuse it."""
    host.ok("TIMEOUT 0")
    host.move(board, "4500 9000 3000")
    assert host.ok("LIMITS 0") == ["LIMITS", "0", "60000", "0"]  # factory: 600 deg/s, acceleration unchecked
    assert host.ok("LIMITS 0 30000 150000") == ["LIMITS", "0", "30000", "150000"]
    board.advance(0.05)
    before = board.pulses()
    still = [9000, 0, 0, 0], [3000, 0, 0, 0]
    up = cubic_coeffs(4500, 9000)
    assert host.err(seg_line(5, [up, *still]), 11).split()[-2:] == ["joint", "0"]  # 6750 deg/s
    host.err(seg_line(250, [up, *still]), 11)  # 270 deg/s but 4320 deg/s^2
    host.err("LIMITS 0 -1 0", 5)
    host.err("LIMITS 3", 5)
    board.advance(0.1)
    assert_pulses(board, before, tol=1.0)
    status = host.status()
    assert status["q"] == "4500,9000,3000" and status["state"] == "IDLE" and status["queue"] == "0"
    host.ok(seg_line(1000, [up, *still]))  # 67.5 deg/s, 270 deg/s^2: runs
    board.advance(1.1)
    assert host.wait_event("EV DONE")
    assert host.status()["q"] == "9000,9000,3000"


def test_limits_broken_between_the_old_samples_are_refused_without_motion(board, host):
    """Issue 13: firmware 2.1.0 sampled dq/ds at s = k/16 and q at s = k/32, so a peak between samples passed;
    now both boards prove every limit on the whole segment (docs/protocol.md 4.3)."""
    host.ok("TIMEOUT 0")
    board.advance(0.05)
    before = board.pulses()
    still = [9000, 0, 0, 0]
    peak_between = [9000, 0, 10200, -6400]  # |dq/ds|: 5400 at s = 8/16 and 9/16, 5418.75 at s = 17/32
    # 90 ms at the factory 600 deg/s allow 5400
    assert host.err(seg_line(90, [still, peak_between, still]), 11).split()[-2:] == ["joint", "1"]
    # q: 17994 at s = 16/32 and 17/32, 18002 at s = 0.5156, beyond the servo's 18000
    assert host.err(seg_line(1000, [still, still, [9000, 34917, -33859, 0]]), 6).split()[-2:] == ["joint", "2"]
    board.advance(0.1)
    assert_pulses(board, before, tol=1.0)
    status = host.status()
    assert status["q"] == "9000,9000,9000" and status["state"] == "IDLE" and status["queue"] == "0"
    host.ok(seg_line(91, [still, peak_between, still]))  # 5460 allowed: runs
    board.advance(0.2)
    assert host.wait_event("EV DONE")
    assert host.status()["q"] == "9000,12800,9000"
