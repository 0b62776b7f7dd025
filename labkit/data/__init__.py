"""Data shipped with labkit: the bundled robot files and the seed measurement tables.

Found through :mod:`importlib.resources`, so the same calls work from a source
checkout, an editable install and an installed wheel.

Examples
--------
>>> {'arduino_arm_3dof', 'planar3r_seed003'} <= set(robot_files())
True
>>> measurement_file("seed000_ik_table4.csv").name
'seed000_ik_table4.csv'
"""

from __future__ import annotations

from pathlib import Path

from labkit.exceptions import LabkitError

__all__ = ["robots_dir", "robot_files", "measurements_dir", "measurement_file", "measurement_files"]


def _dir(name):
    from importlib import resources  # 10 ms: only when data is asked for, not at `import labkit`

    # labkit is installed as a directory tree (wheel or source), so the traversable is a real path
    return Path(str(resources.files(__name__) / name))


def robots_dir():
    """The directory of the bundled robot files (``*.toml``).

    Returns
    -------
    pathlib.Path
    """
    return _dir("robots")


def robot_files():
    """Bundled robot files by name.

    Returns
    -------
    dict
        ``{name: Path}`` sorted by name (the file stem, e.g. ``"puma560"``).
    """
    return {p.stem: p for p in sorted(robots_dir().glob("*.toml"))}


def measurements_dir():
    """The directory of the bundled measurement tables (seed lab reports, CSV).

    Returns
    -------
    pathlib.Path
    """
    return _dir("measurements")


def measurement_files():
    """Names of the bundled measurement tables.

    Returns
    -------
    list of str
        File names such as ``"seed000_fk_tables1-3.csv"``, sorted.
    """
    return sorted(p.name for p in measurements_dir().glob("*.csv"))


def measurement_file(name):
    """Path of a bundled measurement table.

    Parameters
    ----------
    name : str
        File name, e.g. ``"seed000_published_calculated.csv"``.

    Returns
    -------
    pathlib.Path

    Raises
    ------
    LabkitError
        No bundled table has that name (the message lists the ones there are).
    """
    path = measurements_dir() / str(name)
    if not path.is_file():
        raise LabkitError(f"expected one of the bundled measurement tables {measurement_files()}, got {name!r}")
    return path
