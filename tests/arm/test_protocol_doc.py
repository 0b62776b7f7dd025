"""The worked examples of docs/protocol.md are true: every sealed line shown there carries the CRC-32 of its
body, and the example sessions of its section 7, replayed on a virtual board, give exactly the board lines shown.
"""

from __future__ import annotations

import re
from pathlib import Path

from labkit.arm import VirtualBoard
from labkit.arm._protocol import checksum, echo, old_protocol

DOCS = Path(__file__).resolve().parents[2] / "docs"
#: a request or board line in a session block: direction, the line, an optional note after two blanks
SESSION_LINE = re.compile(r"^([<>]) (.*?\S)?(?: {2,}\((.*)\))?$")
#: a line sealed with eight hex digits, in a session block or between backticks
SEALED = re.compile(r"(?:^[<>] |`)([\x20-\x5f\x61-\x7e]*?)\*([0-9A-F]{8})(?=`|\s|$)", re.M)


def session_blocks(text):
    """The code blocks of section 7 (``## 7.``) as lists of ``(direction, line, note)``."""
    section = text[text.index("## 7."):]
    return [[SESSION_LINE.match(ln).groups() for ln in block.splitlines() if ln[:2] in ("< ", "> ")]
            for block in re.findall(r"```\n(.*?)```", section, re.S)]


def replay(blocks):
    """Run the sessions' requests in order on one freshly booted virtual board; the board lines it sends.

    A request noted ``(<t> s later)`` is sent ``t`` s of board time after the one before; a board line that has
    not come yet (an event noted ``(... s after ...)`` or ``(... s later)``) is waited for, up to 5 s.

    Returns
    -------
    list of list of str
        Per block, the board line standing where each ``<`` line of the block stands.
    """
    board = VirtualBoard("arduino_arm_3dof")
    board.advance_to(0.2)
    pending = []
    out = []
    for block in blocks:
        got = []
        for direction, line, note in block:
            pending += [ln for ln in board.take_output().decode("ascii").split("\r\n") if ln]
            if direction == ">":
                later = re.fullmatch(r"([\d.]+) s later", note or "")
                if later:
                    board.advance(float(later.group(1)))
                board.receive(line.encode("ascii") + b"\n")
                continue
            for _ in range(500):
                pending += [ln for ln in board.take_output().decode("ascii").split("\r\n") if ln]
                if pending:
                    break
                board.advance(0.01)
            got.append(pending.pop(0) if pending else "(nothing)")
        out.append(got)
    return out


def test_every_sealed_line_in_the_protocol_docs_has_its_crc32():
    for name in ("protocol.md", "link.md"):
        text = (DOCS / name).read_text(encoding="utf-8")
        found = SEALED.findall(text)
        for body, crc in found:
            assert f"{checksum(body):08X}" == crc, (name, body, crc)
        if name == "protocol.md":
            assert len(found) >= 30
    # no protocol-2 line is left over as an example, except the one that says how an old board is recognised
    old = [m for m in re.findall(r"[<>`] ?([\x20-\x5f\x61-\x7e]+\*[0-9A-F]{4})(?=`|\s|$)",
                                 (DOCS / "protocol.md").read_text(encoding="utf-8"), re.M)
           if old_protocol(m.encode()) == 2]
    assert not old, old


def test_the_echoes_in_the_sessions_are_those_of_their_requests():
    blocks = session_blocks((DOCS / "protocol.md").read_text(encoding="utf-8"))
    checked = 0
    for block in blocks:
        sent = {}
        for direction, line, _ in block:
            words = line.rpartition("*")[0].split() if "*" in line else line.split()
            if direction == ">" and words[:1] and words[0].startswith("#"):
                sent[words[0]] = words[1:]
            elif direction == "<" and words[:1] == ["OK"] and len(words) > 3 and words[3].startswith("p="):
                name, *args = sent[words[1]]
                assert words[3] == echo(name, [int(a) for a in args]), line
                checked += 1
    assert checked >= 7


def test_the_example_sessions_replay_exactly_on_the_virtual_board():
    blocks = session_blocks((DOCS / "protocol.md").read_text(encoding="utf-8"))
    assert len(blocks) == 4 and sum(d == ">" for b in blocks for d, _, _ in b) >= 15
    shown = [[line for d, line, _ in block if d == "<"] for block in blocks]
    assert replay(blocks) == shown


def test_the_conformance_table_is_as_long_as_the_docs_say():
    table = (Path(__file__).with_name("conformance_table.txt")).read_text(encoding="ascii").splitlines()
    said = re.search(r"conformance_table.txt` lists (\d+) raw lines", (DOCS / "protocol.md").read_text(encoding="utf-8"))
    assert said and int(said.group(1)) == sum(ln.startswith("> ") or ln == ">" for ln in table)
