"""Change a few values of a robot file in place, keeping everything else (comments, order, layout).

A calibration measures a handful of numbers (each bus servo's ``zero`` and ``direction``, a joint's
``limits``); the rest of the file is the author's: sources in comments, units, inertias. The file
is edited through ``tomlkit`` (which keeps comments and formatting), only the values given change,
the new text is parsed back with the loader before anything is written (a file labkit could not
load is never written), and the old file is kept as a numbered backup.
"""

from __future__ import annotations

import math
import os
import tomllib
from pathlib import Path

from labkit.exceptions import OptionError, RobotFileError, needs_extra
from labkit.robot.types import _ANGLE_UNITS
from labkit.robot._files import _read_text, _resolve, parse
from labkit.robot._model import Robot

__all__ = ["edit_bus_calibration"]

#: decimals of a limit written back, per angle unit (1e-4 rad = 0.006 deg, 0.01 deg)
_DECIMALS = {"rad": 4, "deg": 2}


def _inward(value, decimals, up):
    """``value`` rounded to ``decimals`` towards the inside of a range (up for a lower limit)."""
    scale = 10 ** decimals
    x = math.ceil(value * scale - 1e-9) if up else math.floor(value * scale + 1e-9)
    return round(x / scale, decimals)


def _backup_path(path):
    for k in range(1, 1000):
        candidate = path.with_name(f"{path.name}.bak{'' if k == 1 else k}")
        if not candidate.exists():
            return candidate
    raise RobotFileError(path, "<file>", "expected a free backup name (robot.toml.bak .. .bak999), got none")


def edit_bus_calibration(source, changes, *, out=None, backup=True):
    """Write each joint's new ``bus`` zero and direction and ``limits`` into a robot file, keeping the rest.

    Parameters
    ----------
    source : str or os.PathLike
        A robot file (or bundled robot name: then ``out`` is required, labkit's own files are never changed).
    changes : sequence of dict, one per joint in file order
        ``{"zero": int, "direction": 1 or -1, "limits": (lower, upper) [rad]}``; a key left out keeps the
        file's value.
    out : str or os.PathLike, optional
        Where to write; default ``source`` itself (in place, the old file kept as ``<name>.bak``,
        ``.bak2`` ...).
    backup : bool
        Keep the old file when writing in place.

    Returns
    -------
    before : str
        The old text.
    after : str
        The new text (parsed back by the loader before it was written).
    backup_path : pathlib.Path or None
        The backup written, if any.

    Raises
    ------
    RobotFileError
        The file cannot be read or parsed, has not one ``[[joint]]`` per change, or the new values make
        a file the loader refuses (the message is the loader's).
    OptionError
        In place on a bundled robot, or ``changes`` not a sequence of dicts.

    Examples
    --------
    >>> before, after, _ = edit_bus_calibration("my_arm.toml", [{"zero": 1990, "direction": -1}])  # doctest: +SKIP
    """
    path = _resolve(source)
    bundled = Path(os.fspath(source)) != path and not Path(os.fspath(source)).is_file()
    if out is None and bundled:
        raise OptionError(f"expected a robot file path (or an output file) to write the calibration to, got the "
                          f"bundled robot {str(source)!r}: labkit's own robot files are never changed")
    target = path if out is None else Path(os.fspath(out))
    if target.exists() and not target.is_file():
        raise OptionError(f"expected a regular file to write the robot file to, got {str(target)!r}")
    before = _read_text(path)
    with needs_extra("bus"):
        import tomlkit
        from tomlkit.exceptions import TOMLKitError

    try:
        doc = tomlkit.parse(before)
        fields = parse(tomllib.loads(before), path)
    except (TOMLKitError, tomllib.TOMLDecodeError) as exc:
        raise RobotFileError(path, "<toml>", f"not valid TOML: {exc}") from None
    joints = doc.get("joint")
    if not isinstance(changes, (list, tuple)) or not all(isinstance(c, dict) for c in changes):
        raise OptionError(f"expected one dict of changes per joint, got {changes!r}")
    if joints is None or len(joints) != len(changes):
        raise RobotFileError(path, "joint", f"expected {len(changes)} [[joint]] tables to calibrate, "
                             f"got {0 if joints is None else len(joints)}")
    unit = fields["angle_unit"]
    scale, decimals = _ANGLE_UNITS[unit], _DECIMALS.get(unit, 4)
    for table, change in zip(joints, changes):
        bus = table.get("bus")
        if ("zero" in change or "direction" in change) and not isinstance(bus, dict):
            raise RobotFileError(path, "joint.bus", f"expected bus = {{ id = ..., zero = ..., direction = ... }} "
                                 f"to calibrate, got {bus!r}")
        if "zero" in change:
            bus["zero"] = int(change["zero"])
        if "direction" in change:
            bus["direction"] = int(change["direction"])
        if "limits" in change:
            lo, hi = (v / scale for v in change["limits"])
            old = table.get("limits")
            same = old is not None and all(math.isclose(float(v), w, rel_tol=1e-9, abs_tol=1e-12)
                                           for v, w in zip(old, (lo, hi)))
            if not same:  # a limit the calibration moved: rounded inwards to the file's precision
                table["limits"] = [_inward(lo, decimals, True), _inward(hi, decimals, False)]
    after = tomlkit.dumps(doc)
    try:
        Robot(**parse(tomllib.loads(after), target))  # every check of Robot.load, before anything is written
    except tomllib.TOMLDecodeError as exc:  # pragma: no cover - tomlkit writes valid TOML
        raise RobotFileError(target, "<toml>", f"the edited file is not valid TOML: {exc}") from None
    saved = None
    if out is None and backup:
        saved = _backup_path(path)
        saved.write_text(before, encoding="utf-8")
    tmp = target.with_name(f".{target.name}.tmp{os.getpid()}")
    tmp.write_text(after, encoding="utf-8")
    os.replace(tmp, target)
    return before, after, saved
