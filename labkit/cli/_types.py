"""Argument types of the ``labkit`` command line: every bad option value is one line and exit status 2.

Each function is an argparse ``type=``: it returns the parsed value or raises
:class:`argparse.ArgumentTypeError` with what was expected and what came, which argparse
prints as ``labkit <command>: error: argument --x: expected ..., got ...``.
"""

from __future__ import annotations

import argparse
import math
import re

__all__ = ["positive_float", "positive_int", "port_number", "scheduler_url", "finite_float", "bounded_float",
           "OneLineErrors"]


def _number(text, kind=float):
    try:
        return kind(text)
    except (TypeError, ValueError):
        raise argparse.ArgumentTypeError(f"expected a {'number' if kind is float else 'whole number'}, "
                                         f"got {text!r}") from None


def finite_float(text):
    """A finite number (not nan or inf).

    Parameters
    ----------
    text : str
        The option's value as typed.

    Returns
    -------
    float

    Raises
    ------
    argparse.ArgumentTypeError
        Saying what was expected and what was typed.
    """
    v = _number(text)
    if not math.isfinite(v):
        raise argparse.ArgumentTypeError(f"expected a finite number, got {text!r}")
    return v


def positive_float(text):
    """A finite number > 0.

    Parameters
    ----------
    text : str
        The option's value as typed.

    Returns
    -------
    float

    Raises
    ------
    argparse.ArgumentTypeError
        Saying what was expected and what was typed.
    """
    v = finite_float(text)
    if v <= 0:
        raise argparse.ArgumentTypeError(f"expected a finite number > 0, got {text!r}")
    return v


def bounded_float(lo, hi, unit=""):
    """An argparse type for a finite number within ``lo..hi`` (inclusive).

    Parameters
    ----------
    lo, hi : float
        Smallest and largest accepted value [unit].
    unit : str
        Unit named in the error message.

    Returns
    -------
    callable
        ``parse(text) -> float``, raising :class:`argparse.ArgumentTypeError`.
    """
    def parse(text):
        v = finite_float(text)
        if not lo <= v <= hi:
            raise argparse.ArgumentTypeError(f"expected a number within {lo:g}..{hi:g}{' ' + unit if unit else ''}, "
                                             f"got {text!r}")
        return v
    parse.__name__ = "number"
    return parse


def positive_int(text):
    """A whole number >= 1.

    Parameters
    ----------
    text : str
        The option's value as typed.

    Returns
    -------
    int

    Raises
    ------
    argparse.ArgumentTypeError
        Saying what was expected and what was typed.
    """
    v = _number(text, int)
    if v < 1:
        raise argparse.ArgumentTypeError(f"expected a whole number >= 1, got {text!r}")
    return v


def port_number(text):
    """A TCP port 1..65535.

    Parameters
    ----------
    text : str
        The option's value as typed.

    Returns
    -------
    int

    Raises
    ------
    argparse.ArgumentTypeError
        Saying what was expected and what was typed.
    """
    v = _number(text, int)
    if not 1 <= v <= 65535:
        raise argparse.ArgumentTypeError(f"expected a TCP port 1..65535, got {text!r}")
    return v


_SCHEDULER = re.compile(r"^(tcp|tls|ucx|inproc)://[^\s/:]+(:\d{1,5})?/?$")


def scheduler_url(text):
    """A dask.distributed scheduler address ``tcp://HOST:PORT``.

    Parameters
    ----------
    text : str
        The option's value as typed.

    Returns
    -------
    str

    Raises
    ------
    argparse.ArgumentTypeError
        Saying what was expected and what was typed.
    """
    if not _SCHEDULER.match(text):
        raise argparse.ArgumentTypeError(f"expected a scheduler address like tcp://HOST:PORT, got {text!r}")
    return text


class OneLineErrors:
    """Parser mixin: a usage error is one line on stderr (``prog: error: message``) and exit status 2."""

    def error(self, message):
        """Print ``message`` on one line and exit with status 2 (replaces argparse's usage dump).

        Parameters
        ----------
        message : str
            What argparse found wrong.
        """
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")
