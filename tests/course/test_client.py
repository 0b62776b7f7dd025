"""The grader's side of a kernel's channels (issue 37, item 3): what a run's messages can make the grader hold.

No kernel: the messages a sandboxed kernel could send are fed to the client as they would arrive.
"""

import pytest

from conftest import require

CELL, NOTEBOOK, MESSAGE = 1000, 5000, 3000


def _client(cells):
    nbformat = require("nbformat")
    require("nbclient")
    from labkit.course._client import client_class

    nb = nbformat.v4.new_notebook(cells=[nbformat.v4.new_code_cell("pass", id=f"c{i}") for i in range(cells)])
    nb.cells[-1].metadata = {"labkit": {"export": "check"}}
    client = client_class()(nb, km=None, output_bytes=CELL, notebook_output_bytes=NOTEBOOK, message_bytes=MESSAGE)
    client.reset_execution_trackers()  # as async_execute and async_execute_cell do
    client.clear_before_next_output = False
    return nb, client


def _send(client, nb, index, msg_type, content):
    client.process_message({"msg_type": msg_type, "content": content, "header": {"msg_type": msg_type},
                            "parent_header": {}, "metadata": {}}, nb.cells[index], index)


def _held(nb) -> int:
    """Characters of output the notebook holds (the drop notes aside)."""
    from labkit.course._client import _content_bytes

    return sum(_content_bytes(o) for c in nb.cells for o in c.get("outputs", []) if o.get("name") != "labkit-truncated")


def test_many_cells_each_under_the_cell_cap_stop_at_the_notebook_cap():
    """40 cells of 900 characters each (under the cell cap of 1000): the grader keeps at most the notebook's cap
    (5000), drops the rest and says so; an error after that is still kept (the run's status reads it)."""
    nb, client = _client(41)
    for i in range(40):
        _send(client, nb, i, "stream", {"name": "stdout", "text": "y" * 900})
    assert _held(nb) <= NOTEBOOK + 40 * 20, _held(nb)  # + the names of the streams
    assert len(client.dropped) >= 34, client.dropped
    _send(client, nb, 39, "error", {"ename": "ValueError", "evalue": "late", "traceback": []})
    assert [o["ename"] for o in nb.cells[39].outputs if o["output_type"] == "error"] == ["ValueError"]
    _send(client, nb, 39, "error", {"ename": "ValueError", "evalue": "again " * 200, "traceback": []})
    assert sum(o["output_type"] == "error" for o in nb.cells[39].outputs) == 1  # a second one is output like any


@pytest.mark.parametrize("msg_type", ["comm_open", "comm_msg"])
def test_widget_messages_are_not_kept(msg_type):
    """nbclient keeps every widget state a kernel sends (``widget_state``): the grader keeps none."""
    nb, client = _client(2)
    for k in range(50):
        _send(client, nb, 0, msg_type, {"comm_id": f"w{k}", "target_name": "jupyter.widget",
                                        "data": {"state": {"value": "z" * 2000}, "buffer_paths": []}})
    assert not client.widget_state and not getattr(client, "comm_objects", {}), client.widget_state.keys()
    assert not nb.cells[0].outputs


def test_a_check_cell_hands_out_one_message_worth_of_values():
    """The export step's values pass the output caps, but a kernel that sends many of them (a patched export)
    gets only ``message_bytes`` of them held per check cell."""
    from labkit.course._wire import MIME

    nb, client = _client(2)
    for _ in range(20):
        _send(client, nb, 1, "display_data", {"data": {MIME: "v" * 1400}, "metadata": {}})
    held = [o for o in nb.cells[1].outputs if o.get("output_type") == "display_data"]
    assert len(held) == 2 and len(client.dropped) == 18, (len(held), client.dropped)


@pytest.mark.slow
@pytest.mark.xdist_group("grading-loop")  # beside the attack batches (tests/course/test_attacks.py says why)
def test_a_long_tmpdir_still_runs_kernels(tmp_path, monkeypatch):
    """A TMPDIR too long for a Unix socket's path (a Slurm job's, say): the kernel's runtime folder goes to a short
    system folder and the notebook runs (ZeroMQ refused the socket: every kernel failed to start)."""
    nbformat = require("nbformat")
    import tempfile
    from pathlib import Path

    from labkit.course import Limits, run_untrusted
    from labkit.course._client import runtime_folder
    from labkit.course._safefs import remove_tree

    long = tmp_path / ("slurm-job-" + "7" * 60) / "tmp"
    long.mkdir(parents=True)
    monkeypatch.setattr(tempfile, "tempdir", str(long))
    folder = runtime_folder()
    try:
        assert folder.parent != long and len(str(folder / "sockets" / "kernel-65535")) <= 107, folder
    finally:
        remove_tree(folder)
    kept = runtime_folder("/var/tmp")  # short enough: where it was asked for
    try:
        assert kept.parent == Path("/var/tmp"), kept
    finally:
        remove_tree(kept)
    nb = nbformat.v4.new_notebook(cells=[nbformat.v4.new_code_cell("print(6 * 7)")])
    status, detail, _ = run_untrusted(nb, tmp_path, private=long,
                                      limits=Limits(cpu_seconds=20, memory_bytes=2 * 2**30, wall_seconds=60))
    assert (status, nb.cells[0].outputs[0]["text"]) == ("ok", "42\n"), detail
