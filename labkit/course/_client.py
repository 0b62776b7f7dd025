"""The grader's side of a sandboxed kernel's channels: every message measured as it arrives.

:func:`client_class` is nbclient's ``NotebookClient`` with four changes: an output message
that would take its cell over ``Limits.output_bytes``, or the notebook over
``Limits.notebook_output_bytes``, is dropped with a note (the export step's values excepted: up to
``Limits.message_bytes`` per check cell); widget (``comm``) messages are dropped unread (grading has no front end;
nbclient would keep every widget state a kernel sends); the heartbeat channel is not started (it would
reconnect by name to a socket file the sandbox can replace); and once a channel was closed (a
message over ``Limits.message_bytes``: ZeroMQ's ``ZMQ_MAXMSGSIZE`` drops the connection before
the grader holds the message) the notebook stops. :data:`KERNEL_MAIN` is the kernel's launcher.
"""

from __future__ import annotations

from labkit.exceptions import needs_extra

__all__ = ["ChannelClosed", "KERNEL_MAIN", "client_class", "runtime_folder"]

#: longest path of a Unix socket the kernel can bind (``sun_path`` is 108 bytes with its NUL) [bytes]
_MAX_SOCKET_PATH = 107
#: the longest socket name in a runtime folder: ``sockets/kernel-<port>`` (jupyter_client's ipc names)
_SOCKET_NAME = "sockets/kernel-65535"
#: the name of a runtime folder inside a folder of the grader's (gone with it: no owner in the name)
_PRIVATE_PREFIX = "labkit-run-"


class ChannelClosed(Exception):
    """The grader closed a kernel channel: a message over ``Limits.message_bytes`` arrived on it."""


def _content_bytes(content) -> int:
    """Characters of text in a message's content (iteratively; a message is at most ``message_bytes``)."""
    total, stack = 0, [content]
    while stack:
        item = stack.pop()
        if isinstance(item, (str, bytes)):
            total += len(item)
        elif isinstance(item, dict):
            stack.extend(item.keys())
            stack.extend(item.values())
        elif isinstance(item, (list, tuple)):
            stack.extend(item)
        else:
            total += 8
    return total


#: the kernel's launcher: no user site and no working folder on the path until its sockets are bound (nothing
#: of the submission's runs before that), then the working folder where IPython would put it
KERNEL_MAIN = ("import sys\nfrom ipykernel import kernelapp\n"
                "def init_path(self):\n"
                "    at = next((i for i, p in enumerate(sys.path) if p.endswith(('site-packages', 'dist-packages'))), 0)\n"
                "    sys.path.insert(at, '')\n"
                "kernelapp.IPKernelApp.init_path = init_path\nkernelapp.launch_new_instance()\n")
_OUTPUT_TYPES = ("stream", "display_data", "update_display_data", "execute_result", "error")


def client_class():
    """nbclient's ``NotebookClient`` with the caps described in this module (built when called).

    Returns
    -------
    type
        A subclass taking ``output_bytes``, ``notebook_output_bytes`` and ``message_bytes`` [bytes] as keywords
        (an export step's values: at most ``message_bytes`` per check cell); its ``dropped`` lists
        ``(cell index, size)`` of every message dropped, ``closed()`` says whether a channel was closed.
    """
    with needs_extra("course"):
        from nbclient import NotebookClient
        from nbclient.util import ensure_async

    from labkit.course._wire import MIME

    class CappedClient(NotebookClient):
        """Measures every output message as it arrives: one that would take its cell over ``output_bytes`` or the
        notebook over ``notebook_output_bytes`` is dropped with a note (an export step's values may fill a
        message); widget messages are dropped; no heartbeat channel (it would reconnect by name); a closed
        channel (a message over ``message_bytes``) stops the notebook."""

        def __init__(self, *args, output_bytes, notebook_output_bytes, message_bytes, **kw):
            super().__init__(*args, **kw)
            self.output_bytes, self.notebook_output_bytes = int(output_bytes), int(notebook_output_bytes)
            self.message_bytes = int(message_bytes)
            self.held, self.exported, self.total, self.dropped, self.monitors = {}, {}, 0, [], []

        async def async_start_new_kernel_client(self):
            self.kc = self.km.client()
            try:
                await ensure_async(self.kc.start_channels(hb=False))
                await ensure_async(self.kc.wait_for_ready(timeout=self.startup_timeout))
            except Exception:
                await self._async_cleanup_kernel()
                raise
            self.kc.allow_stdin = False
            self.monitors = [_disconnect_monitor(ch.socket) for ch in (self.kc.iopub_channel, self.kc.shell_channel)]
            return self.kc

        def closed(self) -> bool:
            return any(m.poll(0) for m in self.monitors)

        async def async_execute_cell(self, cell, cell_index, *args, **kw):
            if self.closed():
                raise ChannelClosed(cell_index)
            return await super().async_execute_cell(cell, cell_index, *args, **kw)

        def process_message(self, msg, cell, cell_index):
            if str(msg.get("msg_type", "")).startswith("comm"):
                return None  # widget state: nothing grading reads, and nbclient would keep all of it
            if msg.get("msg_type") in _OUTPUT_TYPES:
                content = msg.get("content") or {}
                size = _content_bytes(content)
                export = cell.get("metadata", {}).get("labkit", {}).get("export") is not None
                if export and msg["msg_type"] == "display_data" and isinstance(content.get("data"), dict) \
                        and MIME in content["data"]:  # the checks' values: one message's worth per check cell
                    if self.exported.get(cell_index, 0) + size > self.message_bytes:
                        self.dropped.append((cell_index, size))
                        return None
                    self.exported[cell_index] = self.exported.get(cell_index, 0) + size
                    return super().process_message(msg, cell, cell_index)
                if msg["msg_type"] == "error" and size > 4096:  # keep the error, not its size
                    msg["content"] = content = {"ename": str(content.get("ename", "Error"))[:200],
                                                "evalue": str(content.get("evalue", ""))[:1000], "traceback": []}
                    size = _content_bytes(content)
                held = self.held.get(cell_index, 0)
                first_error = msg["msg_type"] == "error" and not any(
                    o.get("output_type") == "error" for o in cell.get("outputs", []))  # what the run's status reads
                if not first_error and (held + size > self.output_bytes or
                                        self.total + size > self.notebook_output_bytes):
                    self.dropped.append((cell_index, size))
                    outs = cell.setdefault("outputs", [])
                    if not any(o.get("name") == "labkit-truncated" for o in outs):
                        with needs_extra("course"):
                            from nbformat.v4 import new_output

                        note = "[labkit grade: further output dropped]\n"
                        outs.append(new_output("stream", name="stderr", text=note))
                        outs[-1]["name"] = "labkit-truncated"
                    return None
                self.held[cell_index] = held + size
                self.total += size
            return super().process_message(msg, cell, cell_index)

    return CappedClient


def runtime_folder(private=None):
    """A new folder of the grader's (``0700``) for one kernel's connection file and socket folder.

    Made in ``private`` (default the system's temporary folder), unless the kernel's socket paths
    would be too long for a Unix socket there (a long ``TMPDIR``, such as a Slurm job's): then in
    the first of ``/tmp``, ``/var/tmp``, ``/dev/shm`` (:data:`labkit.course._leftovers.TEMP_PLACES`).
    One made in a shared temporary folder is named after this process
    (:func:`labkit.course._leftovers.new_folder`), so a later batch removes it if this process is
    killed outright; in ``private`` it goes with that folder.

    Parameters
    ----------
    private : str or os.PathLike, optional
        A folder of the grader's where to make it.

    Returns
    -------
    pathlib.Path

    Raises
    ------
    LabkitError
        If no such folder gives short enough paths.
    """
    import os
    import tempfile
    from pathlib import Path

    from labkit.course._leftovers import TEMP_PLACES, new_folder, owner_prefix
    from labkit.exceptions import LabkitError

    def fits(folder, prefix):
        name = prefix + "x" * 8  # mkdtemp's random part
        return len(os.fsencode(os.path.join(os.path.abspath(folder), name, _SOCKET_NAME))) <= _MAX_SOCKET_PATH

    if private is not None and fits(private, _PRIVATE_PREFIX):
        return Path(tempfile.mkdtemp(prefix=_PRIVATE_PREFIX, dir=private))
    chosen = tempfile.gettempdir()
    if private is not None or not fits(chosen, owner_prefix("run")):
        short = [d for d in TEMP_PLACES if os.path.isdir(d) and os.access(d, os.W_OK | os.X_OK)]
        if not short:
            raise LabkitError(f"expected a folder for the kernel's sockets whose paths fit a Unix socket "
                              f"({_MAX_SOCKET_PATH} bytes), got {private or chosen!r}; set TMPDIR to a short folder")
        chosen = short[0]
    return new_folder("run", chosen)


def _disconnect_monitor(sock):
    """A PAIR socket that becomes readable when ``sock`` loses its peer (checked with ``poll(0)``)."""
    import uuid

    with needs_extra("course"):
        import zmq

    address = f"inproc://labkit-monitor-{uuid.uuid4().hex}"
    sock.monitor(address, zmq.EVENT_DISCONNECTED)
    pair = zmq.Context.shadow(sock.context.underlying).socket(zmq.PAIR)
    pair.linger = 0
    pair.connect(address)
    return pair
