"""One conformance table (tests/arm/conformance_table.txt) run against every board in tests/boards.py.

The table holds raw request lines (valid and malformed) and the exact board lines each must
produce, on a freshly booted board: the virtual arm (``sim://``) and the firmware in simavr must
both give exactly these bytes (issue 13: the two boards disagreed on some raw lines).
"""

from __future__ import annotations

import codecs
from pathlib import Path

import pytest

from boards import BOARDS

pytestmark = [pytest.mark.firmware, pytest.mark.xdist_group("firmware")]

TABLE = Path(__file__).with_name("conformance_table.txt")


def load_table(path=TABLE):
    """``(ready_line, [(request bytes, [expected lines])...])`` from the table file."""
    ready, rows = None, []
    for raw in path.read_text(encoding="ascii").splitlines():
        if raw.startswith("< "):
            ready = raw[2:]
        elif raw.startswith("> ") or raw == ">":
            rows.append((codecs.escape_decode(raw[2:].encode("latin-1"))[0], []))
        elif raw.startswith("= "):
            if raw[2:] != "(none)":
                rows[-1][1].append(raw[2:])
    return ready, rows


def test_the_table_covers_what_issue_13_asks():
    ready, rows = load_table()
    assert ready.startswith("READY labkit-arm 3 ")
    requests = [r for r, _ in rows]
    assert len(rows) >= 130
    assert any(r.startswith(b"#5 MOVE 4500 9000 30") and not r.endswith(b"*") for r in requests)  # split line
    assert b"$" in requests and b"*00" in requests  # the lines sim:// used to leave unanswered
    codes = {e.split()[1] if not e.split()[1].startswith("#") else e.split()[2]
             for _, exp in rows for e in exp if e.startswith("ERR")}
    assert codes == {str(c) for c in range(1, 13) if c != 10}  # every error code but EEPROM failures


@pytest.fixture(params=sorted(BOARDS))
def board(request):
    b = BOARDS[request.param]()
    yield b
    b.close()


def test_board_answers_every_line_of_the_table_exactly(board):
    ready, rows = load_table()
    port = board.open()
    port.timeout = 60.0  # a loaded test machine can hold the simulated board back for seconds
    got_ready = port.readline()
    mismatches = []
    if got_ready.rstrip(b"\r\n").decode("latin-1") != ready:
        mismatches.append(("(power-up)", ready, got_ready))
    for request, expected in rows:
        port.write(request + b"\n")
        for want in expected:
            line = port.readline()
            if not line.endswith(b"\r\n") or line[:-2].decode("latin-1") != want:
                mismatches.append((request[:60], want, line))
    assert not mismatches, "\n".join(f"{r!r}: expected {w!r}, got {g!r}" for r, w, g in mismatches[:20])
    port.write(b"HELLO\n")  # nothing left over: the next line answers this
    tail = port.readline()
    assert tail.startswith(b"OK HELLO"), tail
