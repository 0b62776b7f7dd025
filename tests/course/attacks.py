"""Crafted submissions against the grader (issue 23 and more), for tests/course/test_attacks.py.

Each is the code of the tiny lab's solution cell (tests/course/course_lab.py). None does
the work honestly, so each must score 0 points, and the honest submissions graded in
the same batch must keep their 4 points. ``docs/course.md`` lists them.
"""

import os


def deep_folder(top, depth) -> int:
    """Make ``top/d/d/.../d`` ``depth`` folders deep under descriptors (the path is longer than PATH_MAX); return an
    open descriptor of the deepest folder (the caller closes it)."""
    fd = os.open(top, os.O_RDONLY | os.O_DIRECTORY)
    for _ in range(depth):
        os.mkdir("d", dir_fd=fd)
        child = os.open("d", os.O_RDONLY | os.O_DIRECTORY, dir_fd=fd)
        os.close(fd)
        fd = child
    return fd


#: the honest answer, computed only where an attack found the instructor's solution or a victim's work
_USE_FOUND = """
def _use(text):
    import json
    nb = json.loads(text)
    for c in nb["cells"]:
        src = "".join(c["source"]) if isinstance(c["source"], list) else c["source"]
        if "x = float" in src:
            exec(src, globals())
"""


def snoop_code(roots) -> str:
    """Walk the whole file system for the instructor's notebook and other students' files; use them."""
    return _USE_FOUND + f"""
import os
found = []
for top in ["/"] + {list(map(str, roots))!r}:
    for dirpath, dirnames, filenames in os.walk(top):
        if dirpath.startswith(("/proc", "/sys", "/usr/lib", "/usr/share", "/usr/include", "/usr/bin")):
            dirnames[:] = []
            continue
        for name in filenames:
            path = os.path.join(dirpath, name)
            if name == "private_notes.txt" and not path.startswith(os.getcwd()):
                found.append(path)
            if name.endswith(".ipynb") and not path.startswith(os.getcwd()):
                try:
                    text = open(path, errors="replace").read()
                except OSError:
                    continue
                if "SECRET-HIDDEN-MARKER" in text or "x = float(T[0, 3])" in text:
                    found.append(path)
                    _use(text)
print("SNOOPED", found)
"""


def cross_kernel_code() -> str:
    """Look for other kernels (connection files, TCP ports, /proc) for 5 s and tell them to shut down."""
    return """
import glob, json, os, socket, time
hits = []
deadline = time.time() + 5
while time.time() < deadline:
    files = set()
    for pattern in ["/tmp/**/*.json", "/var/tmp/**/*.json", "/run/**/*.json", os.path.expanduser("~") + "/**/*.json",
                    "/root/.local/share/jupyter/runtime/*.json"]:
        files |= set(glob.glob(pattern, recursive=True))
    for pid in os.listdir("/proc"):
        if pid.isdigit() and int(pid) != os.getpid():
            try:
                args = open(f"/proc/{pid}/cmdline", "rb").read().split(b"\\0")
            except OSError:
                continue
            files |= {a.decode() for a in args if a.endswith(b".json")}
    for f in files:
        try:
            info = json.load(open(f))
        except Exception:
            continue
        if "shell_port" not in info:
            continue
        if os.path.dirname(f) == os.path.dirname(os.environ.get("JPY_PARENT_PID", "")):
            continue
        from jupyter_client import BlockingKernelClient
        kc = BlockingKernelClient()
        kc.load_connection_info(info)
        kc.start_channels()
        kc.shutdown()
        hits.append(f)
    for port in range(8000, 8100):
        s = socket.socket()
        s.settimeout(0.01)
        try:
            s.connect(("127.0.0.1", port))
            hits.append(port)
        except OSError:
            pass
        finally:
            s.close()
    time.sleep(0.2)
print("KERNELS", hits)
"""


def unix_socket_code(paths) -> str:
    """Connect to Unix sockets the test listens on outside the sandbox."""
    return f"""
import socket
for path in {list(map(str, paths))!r}:
    s = socket.socket(socket.AF_UNIX)
    try:
        s.connect(path)
        s.sendall(b"hello from the sandbox")
    except OSError as exc:
        print("refused", path, exc)
"""


def symlink_escape_code(victim_notebook) -> str:
    """Read a symlink the submission brought (pointing at a victim's notebook)."""
    return _USE_FOUND + """
import os
for name in os.listdir("."):
    if os.path.islink(name) or name == "peek.ipynb":
        try:
            _use(open(name).read())
        except OSError as exc:
            print("no", exc)
"""


def memory_attacks(limit_bytes, *, ram_disks_work=True) -> dict:
    """Submissions that do the work, then go over ``limit_bytes`` in all (each piece under it).

    ``forked_memory``: four forked children holding 0.4 of the limit each; ``ram_disks``: the limit
    written to each of ``/tmp`` and ``/dev/shm`` (RAM disks: their pages are memory too). Under the
    watchdog the RAM disks are an eighth of the limit (a full one is no overrun): there
    ``ram_disks_work=False``, the attack does not do the work.
    """
    work = "T = fk(arm, q)\nx = float(T[0, 3])\n"
    child = int(0.4 * limit_bytes)
    fill = int(limit_bytes) // 2**20
    return {
        "forked_memory": work + f"""import os, time
kids = []
for _ in range(4):
    pid = os.fork()
    if pid == 0:
        ballast = bytearray(b'm') * {child}
        time.sleep(4)
        os._exit(0)
    kids.append(pid)
for pid in kids:
    os.waitpid(pid, 0)
""",
        "ram_disks": (work if ram_disks_work else "") + f"""for d in ('/tmp', '/dev/shm'):
    try:
        with open(d + '/fill', 'wb') as f:
            for _ in range({fill}):
                f.write(b'z' * 2**20)
    except OSError as exc:
        print(d, exc)
""",
    }


CHECKS_ATTACKS = {
    # issue 23: the six ways to full marks in the student's own kernel
    "patch_assert_all": "from labkit.reports import Checks\nChecks.assert_all = lambda self: None\n"
                        "Checks.check = lambda self, *a, **k: None",
    "replace_checks": "class Yes:\n    def check(self, *a, **k):\n        pass\n    def assert_all(self):\n        pass\n"
                      "    def __getattr__(self, name):\n        return lambda *a, **k: None\nchecks = Yes()",
    "custom_exc": "get_ipython().set_custom_exc((BaseException,), lambda shell, etype, evalue, tb, tb_offset=None: None)",
    "showtraceback": "sh = get_ipython()\nsh.showtraceback = lambda *a, **k: None\nsh._showtraceback = lambda *a, **k: None",
    "post_run_clear": "from IPython.display import clear_output\n"
                      "get_ipython().events.register('post_run_cell', lambda result: clear_output())",
    "run_cell_hijack": "sh = get_ipython()\nasync def nothing(*a, **k):\n    return None\n"
                       "sh.run_cell = lambda *a, **k: None\nsh.run_cell_async = nothing\n"
                       "sh.should_run_async = lambda *a, **k: False",
    # more of our own
    "fake_export": "from IPython.display import publish_display_data\nimport labkit.course._wire as w\n"
                   "fake = w.dumps({'key': 'hidden-x', 'values': {'x': {'__dataclass__': 'builtins:eval'},"
                   " 'fk': {'__exception__': 'builtins:SystemExit', 'args': [0]}, 'np': 'os', 'abs': 0}})\n"
                   "w.export = lambda ns, names, key: publish_display_data({w.MIME: fake})",
    "shadow_builtins": "abs = lambda v: 0\nfloat = lambda v: 0.0\nnp.isfinite = lambda v: True\n"
                       "fk = lambda *a, **k: np.zeros((4, 4))\nT = np.zeros((4, 4))\nAssertionError = None",
    "huge_export": "x = 'a' * 40_000_000",
    "deep_nesting": "x = []\nfor _ in range(100_000):\n    x = [x]",
    "plant_modules": "for name in ('numpy.py', 'labkit.py', 'sitecustomize.py', 'usercustomize.py', 'json.py'):\n"
                     "    open(name, 'w').write('raise SystemExit(3)\\n')",
    "flood_output": "for _ in range(200):\n    print('y' * 100_000)\nfrom IPython.display import HTML, display\n"
                    "display(HTML('<img src=x onerror=alert(1)>' * 20000))",
    "html_injection": "from IPython.display import HTML, display\ndisplay(HTML('<script>alert(\"pwned\")</script>'))\n"
                      "raise ValueError('<script>alert(\"in detail\")</script>')",
    "self_kill": "import os, signal\nos.kill(os.getpid(), signal.SIGKILL)",
    "kill_everything": "import os, signal\nfor pid in range(1, 5000):\n    try:\n        os.kill(pid, signal.SIGKILL)\n"
                       "    except OSError:\n        pass",
    "process_flood": "import subprocess\nps = [subprocess.Popen(['sleep', '60']) for _ in range(100)]",
    "orphan_process": "import subprocess\nsubprocess.Popen(['sleep', '987654'], start_new_session=True)",
    "write_outside": "import labkit, os\nfor path in (os.path.dirname(labkit.__file__) + '/x.py', '/usr/x', '/etc/x'):\n"
                     "    try:\n        open(path, 'w').write('x')\n    except OSError as exc:\n        print(exc)",
    "baseline_values": "port = 'sim://'\nx = float('nan')",
}

#: expected status of the attacks whose run does not end "ok"/"error"
STATUS = {"self_kill": "crash", "kill_everything": "crash", "process_flood": "crash", "forked_memory": "memory",
          "run_cell_hijack": None}


def runtime_escape_code(append_to, overwrite, secret, sockets=()) -> str:
    """Issue 37's escape: links and planted files in every folder of the kernel's runtime the kernel can write.

    ``kernel.log`` linked to ``append_to`` (the grader appended the next kernel's stderr to it) and to
    ``secret`` (the grader read its last lines into the feedback), the font cache linked to
    ``overwrite`` (the grader copied over it), an IPython startup file and a ``usercustomize.py``
    that hand the next notebook the right ``x``, and the kernel's socket files replaced by links to
    ``sockets`` (Unix sockets of the host: a reconnect by name would reach them) before it dies.
    """
    return f"""
import os, sys, glob
answer = '''
def _fill(*a, **k):
    ns = get_ipython().user_ns
    if 'arm' in ns and 'q' in ns:
        from labkit.kinematics import fk
        ns['x'] = float(fk(ns['arm'], ns['q'])[0, 3])
        ns['T'] = fk(ns['arm'], ns['q'])
get_ipython().events.register('pre_run_cell', _fill)
'''
conn = next((a for a in sys.argv if a.endswith('.json')), '')
folders = {{os.environ.get('JUPYTER_RUNTIME_DIR', ''), os.path.dirname(conn), os.environ.get('MPLCONFIGDIR', ''),
           os.environ.get('IPYTHONDIR', ''), os.path.expanduser('~'), os.path.dirname(os.environ.get('JUPYTER_RUNTIME_DIR', ''))}}
folders.discard('')
for d in sorted(folders):
    fonts = {{os.path.basename(p) for p in glob.glob(os.path.join(d, 'fontlist-*.json'))}} | {{'fontlist-v390.json'}}
    for name, target in [('kernel.log', {str(append_to)!r}), ('kernel.err', {str(secret)!r})] + [
            (font, {str(overwrite)!r}) for font in sorted(fonts)]:
        path = os.path.join(d, name)
        try:
            if os.path.lexists(path):
                os.remove(path)
            os.symlink(target, path)
        except OSError as exc:
            print('no link', path, exc)
    for sub in ('profile_default/startup', 'ipython/profile_default/startup'):
        try:
            os.makedirs(os.path.join(d, sub), exist_ok=True)
            open(os.path.join(d, sub, '00-answer.py'), 'w').write(answer.replace('get_ipython()', '__import__("IPython").get_ipython()'))
        except OSError as exc:
            print('no startup', d, exc)
site = os.path.expanduser('~/.local/lib/python%d.%d/site-packages' % sys.version_info[:2])
os.makedirs(site, exist_ok=True)
open(os.path.join(site, 'usercustomize.py'), 'w').write('import sys\\nsys.stderr.write("APPENDED-BY-THE-STUDENT\\\\n")\\n')
open('zmq.py', 'w').write('open("/home/student/zmq-shadow-ran", "w").write("1")\\nraise SystemExit(3)\\n')
runtime = os.environ.get('JUPYTER_RUNTIME_DIR', '')
links = {list(map(str, sockets))!r}
if runtime and links:
    for i, path in enumerate(sorted(glob.glob(os.path.join(runtime, 'kernel-*')))):
        os.rename(path, path + '.moved')
        os.symlink(links[i % len(links)], path)
    os._exit(0)
"""


def deep_tree_code(depth=3000) -> str:
    """Leave trees ``depth`` folders deep in the working copy and the socket folder, with folders this user may not
    enter, list or change at the bottom and the working copy itself read-only: what the grader removes afterwards."""
    return f"""
import os
for start in ('.', os.environ.get('JUPYTER_RUNTIME_DIR', '.')):
    fd = os.open(start, os.O_RDONLY | os.O_DIRECTORY)
    for _ in range({depth}):
        os.mkdir('d', dir_fd=fd)
        child = os.open('d', os.O_RDONLY | os.O_DIRECTORY, dir_fd=fd)
        os.close(fd)
        fd = child
    os.mkdir('locked', dir_fd=fd)
    open(os.open('locked/f', os.O_WRONLY | os.O_CREAT, 0o600, dir_fd=fd), 'w').write('x')
    os.chmod(f'/proc/self/fd/{{fd}}/locked', 0)
    os.chmod(f'/proc/self/fd/{{fd}}', 0o500)
    os.close(fd)
os.chmod('.', 0o500)
"""


def task_dies_on(value, die):
    """A batch task (labkit.course.run_tasks) that returns ``value``, or kills its own worker process if ``die``."""
    import os
    import signal

    if die:
        os.kill(os.getpid(), signal.SIGKILL)
    return value
