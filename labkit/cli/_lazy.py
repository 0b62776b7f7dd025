"""A subcommand parser that adds its arguments only when it is used (private).

``labkit --help`` lists every subcommand but needs none of their arguments;
some arguments take their choices or defaults from the library
(``labkit.measure.COMBINE_RULES``, ``labkit.reports.CELL_TIMEOUT``), whose
import pulls NumPy and more. A :class:`LazyParser` runs its ``build`` function
(which imports what it needs) the first time it parses or prints help, so the
top-level help stays fast.
"""

from __future__ import annotations

import argparse

from labkit.cli._types import OneLineErrors


class LazyParser(OneLineErrors, argparse.ArgumentParser):
    """An :class:`argparse.ArgumentParser` whose arguments are added on first use.

    Parameters
    ----------
    *args
        As :class:`argparse.ArgumentParser`.
    build : callable, optional
        ``build(parser)`` adds the arguments; called once, before the parser
        first parses or formats its help or usage.
    **kwargs
        As :class:`argparse.ArgumentParser`.
    """

    def __init__(self, *args, build=None, **kwargs):
        super().__init__(*args, **kwargs)
        self._build = build

    def _ensure_built(self):
        build, self._build = self._build, None
        if build is not None:
            build(self)

    def parse_known_args(self, args=None, namespace=None):
        """Build the arguments if not yet done, then parse as argparse does.

        Parameters
        ----------
        args : list of str, optional
            Arguments to parse (default ``sys.argv[1:]``).
        namespace : argparse.Namespace, optional
            Object to store the values on.

        Returns
        -------
        tuple
            ``(namespace, remaining_args)``.
        """
        self._ensure_built()
        return super().parse_known_args(args, namespace)

    def format_help(self):
        """Build the arguments if not yet done, then format the help text.

        Returns
        -------
        str
            The help text.
        """
        self._ensure_built()
        return super().format_help()

    def format_usage(self):
        """Build the arguments if not yet done, then format the usage line.

        Returns
        -------
        str
            The usage line.
        """
        self._ensure_built()
        return super().format_usage()
