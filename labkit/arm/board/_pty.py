"""Serve a virtual board on a pseudo-terminal, for any serial tool."""

from __future__ import annotations

from dataclasses import replace

from labkit.arm.board._physics import PhysicsConfig
from labkit.arm.board._board import VirtualBoard

__all__ = ["make_board", "serve_pty"]


def make_board(robot, *, seed=0, **physics):
    """A :class:`VirtualBoard` with ``PhysicsConfig(seed=seed, **physics)``.

    Parameters
    ----------
    robot : Robot or str
        Robot file or bundled robot name.
    seed : int
        Physics seed (offsets, noise, ruler).
    **physics
        Further :class:`PhysicsConfig` fields (``deadband=0.0`` ...).

    Returns
    -------
    VirtualBoard
    """
    return VirtualBoard(robot, replace(PhysicsConfig(), seed=int(seed), **physics))


def serve_pty(board, *, time_scale=1.0, announce=print, stop=None):
    """Serve ``board`` on a new pseudo-terminal until ``stop()`` is true (or forever).

    Board time runs at ``time_scale`` times the wall clock. ``announce`` gets the
    pty's path (the port name to open).

    Parameters
    ----------
    board : VirtualBoard
        The board to serve.
    time_scale : float
        Board seconds per wall-clock second.
    announce : callable
        Called once with the pty's path (str), e.g. ``print``.
    stop : callable, optional
        Polled about every 2 ms; serving ends when it returns true. Default:
        serve until interrupted.
    """
    import os
    import select
    import time
    import tty

    master, slave = os.openpty()
    tty.setraw(slave)
    announce(os.ttyname(slave))
    t0 = time.monotonic()
    try:
        while stop is None or not stop():
            r, _, _ = select.select([master], [], [], 0.002)
            board.advance_to((time.monotonic() - t0) * time_scale)
            if r:
                try:
                    data = os.read(master, 4096)
                except OSError:
                    data = b""
                board.receive(data)
            out = board.take_output()
            if out:
                os.write(master, out)
    finally:
        os.close(master)
        os.close(slave)
