"""Firmware build, size budget, host-built core tests, parser fuzzing, and firmware-in-the-loop
acceptance measurements (issue 5) on the real binary in simavr.

The measurement functions (``measure_*``) are also used by ``benchmarks/bench_firmware.py``.
"""

from __future__ import annotations

import re
import subprocess
import threading
import time

import numpy as np
import pytest
import serial

from labkit import arm
from labkit.arm import FIRMWARE_DIR, FirmwareSim
from labkit.arm._protocol import READ_ONLY, echo, seal, unseal
from labkit.arm._protocol import wire_speed_limits
from labkit.arm.link._segments import move_duration_ms
from labkit.exceptions import DeviceError
from labkit.robot import Robot

pytestmark = [pytest.mark.firmware, pytest.mark.xdist_group("firmware")]

BAUD = 115200
BITS_PER_BYTE = 10  # 8N1


@pytest.fixture(scope="session")
def build_log():
    """Build firmware, harness, core tests and fuzz target once (make: no-op when up to date)."""
    return arm.build(("firmware", "sim", "tests"))


# ------------------------------------------------------------------------------ helpers
def line_ok(raw: bytes) -> bool:
    """A board line with CR LF and a correct *HHHHHHHH CRC-32."""
    if not raw.endswith(b"\r\n"):
        return False
    return unseal(raw[:-2]) is not None


class Client:
    """Stop-and-wait client on a raw port; keeps events (EV) apart from replies.

    State-changing commands are sent sealed (``#seq`` and CRC-32, as protocol 3 requires); their
    replies are returned without the ``#seq`` and the (checked) ``p=`` echo, e.g. ``"OK MOVE"``.
    """

    def __init__(self, port):
        self.port = port
        self.events = []
        self.seq = 0
        self.sent = ""

    def cmd(self, line: str) -> str:
        words = line.split()
        plain = line.startswith(("#", "$")) or "*" in line or words[0].upper() in READ_ONLY
        if not plain:
            self.seq += 1
            line = seal(f"#{self.seq} {line} ")
        self.sent = line
        self.port.write(line.encode() + b"\n")
        while True:
            raw = self.port.readline()
            assert line_ok(raw), f"bad or missing board line {raw!r} after {line!r}"
            text = raw[:-2].rpartition(b"*")[0].decode()
            if text.startswith(("OK", "ERR")):
                self.reply_bytes = len(raw)
                break
            self.events.append(text)
        if not plain:
            text = text.replace(f" #{self.seq}", "", 1)
            if text.startswith("OK"):
                want = echo(words[0], [int(w) for w in words[1:]])
                assert text.split()[2:3] == [want], f"wrong echo in {text!r} for {line!r}"
                text = text.replace(f" {want}", "", 1)
        return text


def start(pace=0.0, **kw):
    sim = FirmwareSim(pace=pace, **kw)
    port = serial.Serial(sim.port, BAUD, timeout=20)
    sim.run()
    boot = port.readline()
    assert line_ok(boot) and boot.startswith(b"READY labkit-arm 3 "), boot
    return sim, port


# ------------------------------------------------------------------------------ measurements
def measure_feedback_stream(rate_hz=100, sim_seconds=60.0):
    """Stream 4-channel feedback for ``sim_seconds`` of simulated time; count lost/bad frames."""
    sim, port = start(pace=0.0)
    volts = {0: 1.0, 1: 2.0, 2: 3.0, 5: 4.0}
    for pin, v in volts.items():
        sim.set_analog(pin, v)
    frames, bad, stop = [], [], threading.Event()

    def reader():
        buf = b""
        while True:
            chunk = port.read(port.in_waiting or 1)  # timeout 0.2 s
            if not chunk and stop.is_set():
                break
            buf += chunk
            *lines, buf = buf.split(b"\n")
            for raw in lines:
                raw += b"\n"
                if not line_ok(raw):
                    bad.append(raw)
                elif raw.startswith(b"FB"):
                    frames.append(raw[:-2].rpartition(b"*")[0].split())

    port.timeout = 0.2
    port.write(seal(f"#1 STREAM {rate_hz} ").encode() + b"\n")
    thread = threading.Thread(target=reader, daemon=True)
    thread.start()
    wall = time.perf_counter()
    sim.sleep(sim_seconds)
    port.write(seal("#2 STREAM 0 ").encode() + b"\n")
    sim.sleep(0.05)
    wall = time.perf_counter() - wall
    stop.set()
    thread.join(timeout=10)
    sim.close()
    port.close()
    counters = np.array([int(f[1]) for f in frames])
    values = np.array([[int(v) for v in f[3:]] for f in frames])
    expected = np.floor(np.array([volts[p] for p in (0, 1, 2, 5)]) * 1024 / 5)
    lost = int(np.sum(np.diff(counters) - 1)) if len(counters) > 1 else 0
    t_ms = np.array([int(f[2]) for f in frames])
    in_window = int(np.sum(t_ms - t_ms[0] < sim_seconds * 1000)) if len(t_ms) else 0
    return {
        "rate_hz": rate_hz,
        "sim_seconds": sim_seconds,
        "frames": len(frames),
        "expected_frames": int(rate_hz * sim_seconds),
        "frames_in_window": in_window,  # frames within sim_seconds of the first one
        "lost_frames": lost,
        "first_counter": int(counters[0]) if len(counters) else None,
        "corrupted_lines": len(bad),
        "wrong_values": int(np.sum(np.any(np.abs(values - expected) > 1, axis=1))) if len(values) else 0,
        "wall_seconds": wall,
    }


#: the speed and acceleration limits of the seed arm's robot file (300 deg/s, 1500 deg/s^2 per joint),
#: sent with LIMITS before the round trips so that the motion checks do their real work
ROUND_TRIP_LIMITS = wire_speed_limits(Robot.load("arduino_arm_3dof"))
#: the board's boot position [cdeg]: every motion line starts there (each is STOPped at once, before
#: the second servo frame, so the commanded position never leaves it)
BOOT_Q = (9000, 9000, 9000)

ROUND_TRIP_COMMANDS = {
    "PING": "PING",
    "STATUS": "STATUS",
    "MOVE": "MOVE 4500 9000 3000 60000",
    # the shortest MOVE the limits allow: every moving joint at its speed/acceleration limit
    "MOVE-timed": "MOVE 4500 9000 3000 {}".format(move_duration_ms(BOOT_Q, (4500, 9000, 3000), *ROUND_TRIP_LIMITS)),
    "SEG": "SEG 1000 3 9000 0 0 0 9000 0 0 0 9000 0 0 0",
    # rest-to-rest cubics 60 deg in 490 ms on all joints: 36000 of 36015 cdeg/s^2 (normalised time), so the
    # cheap bound sum |i (i-1) c_i| = 108000 cannot accept them
    "SEG-cubic-limit": "SEG 490 3 9000 0 18000 -12000 9000 0 18000 -12000 9000 0 -18000 12000",
    # quintics through a trajectory (non-zero velocity and acceleration at both ends), 250 ms
    "SEG-quintic": "SEG 250 5 9000 2500 1563 4375 -7188 2750 9000 -3000 -1250 -375 3000 -1375 "
                   "9000 2000 0 5188 -8375 3187",
    # cubics whose Bernstein hull leaves 0..18000 cdeg (the curves do not): the hull test is inconclusive
    "SEG-hull": "SEG 1200 3 9000 28000 -30000 1000 9000 -28000 28000 -2000 9000 0 0 0",
}


def measure_round_trip(n=40, percentile=50, clock="wall"):
    """Round trip [s] (``percentile`` of ``n``, 50: median) of typical commands vs. their wire time.

    ``clock="wall"``: paced to real time, timed with the host's wall clock (what
    ``benchmarks/bench_firmware.py`` prints; noisy on a loaded machine).
    ``clock="board"``: lockstep (the simulated CPU waits for the host after each reply), timed
    in simulated time: deterministic, it measures the firmware and the 115200-baud link only.
    The joints' speed and acceleration limits are those of the seed arm's robot file
    (:data:`ROUND_TRIP_LIMITS`), so the motion lines run the board's checks in full.
    """
    board = clock == "board"
    sim, port = start(pace=0.0 if board else 1.0)
    if board:
        sim.set_lockstep(True)
    now = sim.time if board else time.perf_counter
    client = Client(port)
    client.cmd("TIMEOUT 0")
    for j, (v, a) in enumerate(zip(*ROUND_TRIP_LIMITS)):
        assert client.cmd(f"LIMITS {j} {v} {a}") == f"OK LIMITS {j} {v} {a}"
    result = {}
    for name, line in ROUND_TRIP_COMMANDS.items():
        times, wire = [], []
        for _ in range(n):
            t0 = now()
            reply = client.cmd(line)
            times.append(now() - t0)
            wire.append((len(client.sent) + 1 + client.reply_bytes) * BITS_PER_BYTE / BAUD)
            assert reply.startswith("OK"), (name, reply)
            if name.startswith(("SEG", "MOVE")):  # both start a trajectory: STOP so that the next one is accepted
                q = [int(v) for v in client.cmd("STOP").split()[2:]]
                if q != list(BOOT_Q):  # a slow reply let a second servo frame run: move back
                    dur = move_duration_ms(q, BOOT_Q, *ROUND_TRIP_LIMITS)
                    assert client.cmd("MOVE {} {} {} {}".format(*BOOT_Q, dur)).startswith("OK MOVE"), name
                    sim.sleep(dur / 1000 + 0.05)
                    assert client.cmd("STATUS").startswith("OK STATUS state=IDLE q=9000,9000,9000 "), name
        rt = float(np.percentile(times, percentile))
        result[name] = {
            "median_s": rt,
            "wire_s": float(np.median(wire)),
            "ratio": rt / float(np.median(wire)),
        }
    sim.close()
    port.close()
    return result


def measure_segment_stream(n_segments=10_000, dur_ms=30, pace=0.0, lockstep=True):
    """Stream ``n_segments`` cubic segments (a sine on joint 0) through the queue, stop-and-wait,
    waiting half a segment of board time when the queue is full; report underruns (EV DONE before
    the end), QFULL retries and the free-memory low-water mark.

    With ``lockstep`` the simulated CPU waits for the host after each reply (a host with zero
    reaction time, see :meth:`FirmwareSim.set_lockstep`), so the result measures the firmware and
    the 115200-baud link, not the scheduling of a loaded test machine."""
    sim, port = start(pace=pace)
    if lockstep:
        sim.set_lockstep(True)
    client = Client(port)
    client.cmd("TIMEOUT 0")
    assert client.cmd("MOVE 9000 9000 3000 250") == "OK MOVE 5"
    sim.sleep(0.3)
    client.cmd("PING")
    client.events.clear()  # the MOVE's EV DONE
    q = 9000
    qfull = 0
    mem = []
    wall = time.perf_counter()
    t_sim = sim.time()
    for i in range(n_segments):
        q1 = round(9000 + 4000 * np.sin(2 * np.pi * (i + 1) / 200))
        dq = q1 - q
        line = f"SEG {dur_ms} 3 {q} 0 {3 * dq} {-2 * dq} 9000 0 0 0 3000 0 0 0"
        while True:
            reply = client.cmd(line)
            if reply.startswith("OK"):
                break
            assert reply.startswith("ERR 7 QFULL"), reply
            qfull += 1
            sim.sleep(dur_ms / 4000)
        if reply == "OK SEG 0":  # queue full: a slot frees within one segment
            sim.sleep(dur_ms / 2000)
        q = q1
        if i in (100, n_segments // 2):
            mem.append(int(re.search(r"mem=(\d+)", client.cmd("STATUS")).group(1)))
    sim.sleep(0.5)
    status = client.cmd("STATUS")
    wall = time.perf_counter() - wall
    mem.append(int(re.search(r"mem=(\d+)", status).group(1)))
    done = [e for e in client.events if e.startswith("EV DONE")]
    sim_span = sim.time() - t_sim
    sim.close()
    port.close()
    return {
        "segments": n_segments,
        "segment_ms": dur_ms,
        "pace": pace,
        "lockstep": lockstep,
        "done_events": len(done),
        # the MOVE before the stream counts as one segment of the board's done counter
        "underruns": max(0, len(done) - 1) + (0 if done and done[-1] == f"EV DONE {n_segments + 1}" else 1),
        "completed": int(re.search(r"done=(\d+)", status).group(1)),
        "final_q": re.search(r"q=([\d,-]+)", status).group(1),
        "qfull_retries": qfull,
        "mem_free_bytes": mem,
        "sim_seconds": sim_span,
        "wall_seconds": wall,
    }


# ------------------------------------------------------------------------------ build and size
def test_firmware_fits_in_half_of_the_uno(build_log):
    m = re.search(r"flash (\d+) B \(([\d.]+)% of 32768\), SRAM (\d+) B \(([\d.]+)% of 2048\)", build_log
                  + arm.build(("size",)))
    assert m, build_log
    flash, sram = int(m.group(1)), int(m.group(3))
    assert flash <= 32768 // 2, f"flash {flash} B > 50%"
    assert sram <= 2048 // 2, f"SRAM {sram} B > 50%"
    # cross-check with avr-size itself
    out = subprocess.run(["avr-size", "-A", str(arm.default_elf())], capture_output=True, text=True).stdout
    sec = {ln.split()[0]: int(ln.split()[1]) for ln in out.splitlines() if ln.startswith(".")}
    assert sec[".text"] + sec[".data"] == flash
    assert sec[".data"] + sec[".bss"] + sec.get(".noinit", 0) == sram


ARDUINO_BUILDER = [
    "arduino-builder", "-compile", "-hardware", "/usr/share/arduino-builder", "-hardware", "/usr/share/arduino/hardware",
    "-tools", "/usr/bin", "-fqbn", "arduino:avr:uno", "-prefs", "compiler.cpp.extra_flags=-DDECIMAL_DIG=17",
]


def test_arduino_builder_builds_the_sketch_within_half_of_the_uno(tmp_path):
    """The Arduino IDE's own build engine (Debian arduino-builder, arduino:avr:uno) builds the sketch as is."""
    proc = subprocess.run([*ARDUINO_BUILDER, "-build-path", str(tmp_path), str(FIRMWARE_DIR / "labkit_arm" / "labkit_arm.ino")],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    flash = int(re.search(r"Sketch uses (\d+) bytes", proc.stdout).group(1))
    sram = int(re.search(r"Global variables use (\d+) bytes", proc.stdout).group(1))
    print(f"arduino-builder (arduino:avr:uno): flash {flash} B ({100 * flash / 32768:.1f}% of 32768), "
          f"SRAM {sram} B ({100 * sram / 2048:.1f}% of 2048)")
    assert (tmp_path / "labkit_arm.ino.hex").exists()
    assert flash <= 32768 // 2 and sram <= 2048 // 2, (flash, sram)


def test_sketch_is_an_arduino_ide_sketch_with_a_portable_core(build_log):
    sketch = FIRMWARE_DIR / "labkit_arm"
    assert (sketch / "labkit_arm.ino").exists()  # folder name == sketch name
    core = (sketch / "labkit_core.c").read_text() + (sketch / "labkit_core.h").read_text()
    includes = set(re.findall(r"#include\s+[<\"]([^>\"]+)", core))
    assert includes <= {"labkit_core.h", "stdint.h", "string.h", "avr/pgmspace.h"}, includes
    assert "Arduino.h" not in core


def test_core_unit_tests_pass_on_the_host(build_log):
    proc = subprocess.run([str(FIRMWARE_DIR / "build" / "test_core")], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    m = re.search(r"core tests: (\d+) checks, 0 failed", proc.stdout)
    assert m and int(m.group(1)) >= 100, proc.stdout


def test_parser_fuzzing_finds_no_crash_or_broken_invariant(build_log, tmp_path):
    proc = subprocess.run(
        [str(FIRMWARE_DIR / "build" / "fuzz_parser"), "-runs=60000", "-seed=12345", "-max_len=400",
         f"-dict={FIRMWARE_DIR / 'tests' / 'fuzz.dict'}", f"-artifact_prefix={tmp_path}/"],
        capture_output=True, text=True, timeout=300,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "Done 60000 runs" in proc.stderr


# ------------------------------------------------------------------------------ harness and hook
def test_on_tick_hook_closes_the_loop_with_a_python_model(build_log):
    ticks = []

    def servo_pots(t, pulses):
        """Ideal servos: the pot tap voltage follows the commanded pulse (0.5 V .. 4.5 V)."""
        ticks.append(t)
        return {ch: 0.5 + (pulses[ch] - 500) / 2000 * 4.0 for ch in (0, 1, 2) if ch in pulses}

    sim, port = start(pace=0.0, on_tick=servo_pots, tick_period=0.002)
    client = Client(port)
    assert client.cmd("MOVE 4500 9000 13500 250") == "OK MOVE 5"
    sim.sleep(0.35)
    counts = [int(c) for c in client.cmd("READ").split()[2:]]
    sim.close()
    port.close()
    volts = 0.5 + np.array([0.25, 0.5, 0.75]) * 4.0
    assert np.all(np.abs(np.array(counts[:3]) - volts * 1024 / 5) <= 2), counts
    period = np.diff(ticks)
    assert len(ticks) > 40 and np.allclose(period, 0.002, atol=1e-5)


def test_pulse_widths_are_exact_within_half_a_microsecond(build_log):
    sim, port = start(pace=0.0)
    client = Client(port)
    assert client.cmd("MOVE 0 9000 18000 250") == "OK MOVE 5"
    sim.sleep(0.3)
    client.cmd("GRIP 1234")
    t0 = sim.time()
    sim.sleep(1.0)
    widths = {ch: [e.width_us for e in sim.pulse_events(t0) if ch == e.channel] for ch in range(4)}
    last = sim.pulses()
    sim.close()
    port.close()
    for ch, want in {0: 500.0, 1: 1500.0, 2: 2500.0, 3: 1234.0}.items():
        assert abs(last[ch] - want) <= 0.5, (ch, last[ch])
        # every pulse after the first frame at the new width: within 0.5 us (no ISR jitter)
        assert np.all(np.abs(np.array(widths[ch][1:]) - want) <= 0.5), (ch, widths[ch][:8])


def test_simavr_url_handler_opens_a_booted_board(build_log):
    import labkit.arm.urlhandler

    labkit.arm.urlhandler.register()
    port = serial.serial_for_url("simavr://?pace=0", baudrate=BAUD, timeout=20)
    try:
        assert port.readline().startswith(b"READY labkit-arm 3 ")
        port.write(b"#1 HELLO\n")
        assert port.readline().startswith(b"OK #1 HELLO labkit-arm")
        assert port.sim.pulses()[3] == pytest.approx(1500, abs=0.5)
    finally:
        port.close()
    with pytest.raises(serial.SerialException, match="unknown option"):
        serial.serial_for_url("simavr://?speed=3", baudrate=BAUD)


# ------------------------------------------------------------------------------ acceptance
@pytest.mark.slow
def test_feedback_stream_100hz_for_60s_loses_nothing(build_log):
    r = measure_feedback_stream(100, 60.0)
    assert r["corrupted_lines"] == 0 and r["lost_frames"] == 0 and r["wrong_values"] == 0, r
    assert r["first_counter"] == 0 and abs(r["frames_in_window"] - r["expected_frames"]) <= 1, r


def test_round_trip_within_1_5x_wire_time_in_board_time(build_log):
    r = measure_round_trip(5, percentile=100, clock="board")  # the slowest of 5
    # the motion lines that make the board's checks work hardest are among them (issue 13)
    assert {"MOVE-timed", "SEG-cubic-limit", "SEG-quintic", "SEG-hull"} <= set(r)
    for name, m in r.items():
        assert m["ratio"] <= 1.5, (name, m)
        assert m["ratio"] >= 1.0, (name, m)  # no reply can beat the wire: the clock is board time


@pytest.mark.slow
def test_10000_segments_stream_without_underrun_or_memory_growth(build_log):
    r = measure_segment_stream(10_000, 30)
    assert r["underruns"] == 0 and r["done_events"] == 1, r
    assert r["completed"] == 1 + 10_000, r  # the MOVE to the start, then the segments
    # static allocation only: the stack low-water mark (canary) stays far from the heap start
    first, *_, last = r["mem_free_bytes"]
    assert last > 500 and first - last < 64, r
    assert r["final_q"].split(",")[0] == "9000"  # sine back at its start after 50 periods


def test_a_failing_on_tick_hook_is_reported_not_swallowed(build_log):
    def broken(t, pulses):
        raise RuntimeError("model diverged")

    sim, port = start(pace=0.0, on_tick=broken, tick_period=0.01)
    try:
        time.sleep(0.2)  # a few ticks run (the CPU keeps going; voltages unchanged)
        with pytest.raises(DeviceError, match="model diverged"):
            sim.time()
        assert sim.time() > 0.0  # reported once; the simulator still works
    finally:
        sim.close()
        port.close()


# ------------------------------------------------------------------------------ RC linear servos
def test_an_rc_linear_servo_moves_on_the_firmware_and_a_pulse_past_its_range_is_refused(build_log, tmp_path):
    """The bundled L16-R rig on the real binary (issue 42): its lift (100 mm) and reach (50 mm) count 1/18000 of
    their strokes on the wire and the firmware emits their 1000-2000 us; a robot file whose reach limits run past
    the 50 mm stroke has a position refused on the host, naming the joint and pulse_us, and nothing moves."""
    import math

    from labkit.arm import Arm
    from labkit.data import robots_dir
    from labkit.exceptions import JointLimitError

    src = (robots_dir() / "cylindrical_l16.toml").read_text().replace("limits = [0, 50]", "limits = [0, 60]")
    path = tmp_path / "cylindrical_l16.toml"
    path.write_text(src)
    robot = Robot.load(path)
    q = np.array([math.radians(30.0), 0.0625, 0.03125])
    with Arm(robot, f"simavr://?physics={path}&seed=0") as arm:
        arm.move_joints(q, wait=True, tol=1e-3, max_wait=30.0)
        assert np.allclose(arm.commanded_joints(), q, rtol=0, atol=1e-9)
        sim = arm.port.sim
        pulses = sim.pulses()
        for j in (1, 2):  # measured on the pins: the calibration's pulse within the firmware's 0.5 us
            assert abs(pulses[j] - float(robot.links[j].servo.pulse_us(q[j]))) <= 0.5, (j, pulses[j])
        true = arm.port.physics.model.true_q
        # within one 0.5 us step of rod travel (50 um of the lift, 25 um of the reach)
        assert np.all(np.abs(true[1:] - q[1:]) <= 0.5 * np.array([0.100, 0.050]) / 1000), (true - q) * 1000
        before, t0 = arm.status(), sim.time()
        with pytest.raises(JointLimitError, match=r"joint 3 \('reach'\): 55 mm needs a pulse of 2100\.0 us, "
                                                  r"outside its servo's pulse_us 1000\.\.2000 us"):
            arm.move_joints([q[0], q[1], 0.055])
        arm.sleep(0.2)
        after = arm.status()
        assert after.last == before.last and np.array_equal(after.q, before.q)
        assert not [e for e in sim.pulse_events(t0) if e.channel == 2], "the reach's pulse never changed"
