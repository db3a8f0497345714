"""Run the slow planners (DSB) in processes of their own, started in milliseconds.

TangentBug is mostly Python: run in a thread next to the VG/SVG lane it would hold the
interpreter lock for long stretches and slow every redraw during a drag (measured: the
fast lane's p50 went from about 7 ms to 30 ms). The planners are pure functions on
picklable values (scenes, shapely polygons, frozen results), so one worker process per
session computes them on another core; a scene goes in, the results come back pickled
(about 1 ms each way). The planners' registry travels inside the pickled function; the
child keeps its own :class:`planners.Memo` from call to call.

The worker talks pickles over its stdin and stdout: first the function to call, then
``(scene, keywords)`` per call, each answered with ``(ok, result or error text)``
(:func:`child_main`). It is not a :mod:`multiprocessing` process: "spawn" would re-run the
caller's main script in the child (a lecturer's notebook or a script without a
``__main__`` guard), and "fork" is unsafe in a process that runs threads (viser, the
controller).

**The template.** A worker started from nothing imports numpy, shapely, networkx, trimesh
and numba and loads the compiled loops: about 1.9 s of CPU before its first answer. A
process starts one for each session, again after every computation given up, and one
for every worker of a classroom's pools. On Linux one single-threaded *template*
process does that once, and each worker is a ``fork`` of it: ready in a few
milliseconds, sharing the template's imports and loops (copy on write). The template
exits on its own after :data:`LINGER_S` seconds without workers, or when the process
that started it closes its control socket. Only Linux has what this needs
(``os.pidfd_open``, to wait for a process that is not our child); elsewhere each worker
is a fresh ``python -c`` interpreter.

Data flow::

    ProcessLane -> start_worker(nice) -> Template.fork: a request on a socketpair
        (SOCK_SEQPACKET: one request, one message, its file descriptors with it),
        with the worker's ends of its two pipes passed as file descriptors
        -> serve (the template): fork; the child runs child_main on those pipes
        <- the child's pid, read when first asked for (Forked.pid)
"""

from __future__ import annotations

__all__ = [
    "ANSWER_TIMEOUT_S",
    "LINGER_S",
    "Forked",
    "Interrupted",
    "ProcessLane",
    "Template",
    "child_main",
    "picklable",
    "spawn_worker",
    "start_worker",
    "template_pid",
]

import atexit
import contextlib
import errno
import logging
import os
import pickle
import select
import signal
import socket
import struct
import subprocess
import sys
import threading
import time
import traceback
from collections.abc import Callable
from pathlib import Path
from typing import IO, Any

logger = logging.getLogger(__name__)


class Interrupted(RuntimeError):
    """A call given up on: :meth:`ProcessLane.interrupt` stopped the worker computing it."""


def picklable(fn: Callable[..., Any]) -> bool:
    """Whether ``fn`` (and the registry it carries) can be sent to a worker process.

    Module-level functions pickle by name, and so do :class:`planners.PlannerSpec` records
    whose ``run`` is one; a lambda or a closure (a test's stand-in) cannot, and then the
    caller keeps the slow lane in a thread.
    """
    try:
        pickle.dumps(fn)
    except Exception:
        return False
    return True


class ProcessLane:
    """Call ``fn(scene, memo=..., **keywords)`` in a worker process; one call at a time.

    Parameters
    ----------
    fn
        A picklable function (module-level, or a ``functools.partial`` of one, e.g.
        ``functools.partial(default_plan, which=("dsb",), registry=dict(registry))``:
        the registry travels inside it, so the child knows the same planners as the
        parent). It must accept a ``memo`` keyword: the child passes its own
        :class:`planners.Memo`, kept from call to call.
    start
        Start the process now (else on the first call).
    nice
        How much lower the child's scheduling priority is than ours (``os.nice``): a
        classroom's students' copies plan at a lower priority than the presenter.
    """

    def __init__(
        self, fn: Callable[..., Any], *, start: bool = True, nice: int = 0
    ) -> None:
        self._payload = pickle.dumps(fn)
        self._nice = max(0, int(nice))
        self._lock = threading.Lock()
        self._start_lock = threading.Lock()
        self._proc: subprocess.Popen[bytes] | None = None
        self._closed = False
        if start:  # else on the first call (a worker few sessions need)
            self._start()

    def _start(self) -> None:
        self._proc = start_worker(self._nice)
        stdin = self._pipe("stdin")
        stdin.write(self._payload)
        stdin.flush()

    def _pipe(self, name: str) -> IO[bytes]:
        proc = self._proc
        pipe = None if proc is None else getattr(proc, name)
        if pipe is None:  # stopped by interrupt() or close() meanwhile
            raise OSError("the planner process was stopped")
        return pipe

    def __call__(
        self,
        scene: Any,
        abandoned: Callable[[], bool] | None = None,
        **keywords: Any,
    ) -> Any:
        """Compute ``fn(scene, **keywords)`` in the worker; restart it once if it has died.

        ``abandoned`` (optional) tells whether the caller has given up on this call: it
        is asked before the worker starts on it and when the worker stops; if it says
        yes, the call raises :class:`Interrupted` instead of starting again. A caller
        gives up on a call by setting its flag, then calling :meth:`interrupt`.
        """
        with self._lock:
            ok, value = False, "the planner process did not answer"
            for attempt in (1, 2):
                if self._closed:
                    raise RuntimeError("the planner process is closed")
                try:
                    answers = self._send(scene, keywords, abandoned)
                    ok, value = pickle.load(answers)
                    break
                except (EOFError, OSError, pickle.UnpicklingError, ValueError):
                    if abandoned is not None and abandoned():
                        raise Interrupted("the computation was given up") from None
                    if attempt == 2 or self._closed:
                        raise RuntimeError("the planner process stopped") from None
                    logger.warning("the planner process stopped; starting a new one")
                    with self._start_lock:  # the next attempt starts a new one
                        self._stop_process()
            if not ok:
                raise RuntimeError(value)
            return value

    def _send(
        self,
        scene: Any,
        keywords: dict[str, Any],
        abandoned: Callable[[], bool] | None,
    ) -> IO[bytes]:
        """Hand one call to the worker, unless given up; return its answer's pipe.

        The worker is chosen under the start lock, like :meth:`interrupt`: a caller sets
        its flag before it interrupts, so a call given up is either refused here or
        written to the worker that the interrupt then stops -- never to the fresh one.
        The call is written outside the lock: a worker still importing reads a big scene
        only when it is ready, and an interrupt meanwhile must not wait for that (the
        write then fails on the stopped worker's pipe, and so does the answer's read).
        """
        with self._start_lock:
            if abandoned is not None and abandoned():
                raise Interrupted("the computation was given up")
            if self._proc is None and not self._closed:
                self._start()
            stdin, stdout = self._pipe("stdin"), self._pipe("stdout")
        pickle.dump((scene, keywords), stdin, protocol=pickle.HIGHEST_PROTOCOL)
        stdin.flush()
        return stdout

    def _stop_process(self) -> None:
        proc, self._proc = self._proc, None
        if proc is None:
            return
        if proc.poll() is None:
            proc.terminate()
        try:
            proc.wait(timeout=5)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(timeout=5)
        for pipe in (proc.stdin, proc.stdout):
            if pipe is not None:
                try:
                    pipe.close()
                except OSError:
                    pass

    def interrupt(self) -> None:
        """Stop the worker now (a call in progress ends) and start a fresh one.

        A long computation cannot be stopped half-way inside the worker; stopping the
        process can. The new worker starts at once (its imports take a moment), so the
        next call rarely waits for it. Its :class:`planners.Memo` starts empty.
        """
        # Not under the call lock: the call in progress holds it while it waits for the
        # child. Under the start lock, so that close() and a call's hand-over do not
        # interleave with the restart (no worker outlives close()).
        with self._start_lock:
            self._stop_process()
            if not self._closed:
                self._start()

    @property
    def pid(self) -> int | None:
        """Process id of the worker (None once closed)."""
        return None if self._proc is None else self._proc.pid

    def close(self) -> None:
        """Stop the worker process (a call in progress ends with an error)."""
        # Not under the call lock: a call may be waiting for the child; stopping the
        # child ends that wait with EOFError. Under the start lock: an interrupt() or a
        # call's hand-over in progress finishes first and starts nothing after this.
        with self._start_lock:
            self._closed = True
            self._stop_process()


# --------------------------------------------------------------------------- worker processes


LINGER_S = 30.0
"""Seconds the template waits, without any planner process, for the next one before it
exits: an app started again within half a minute (a notebook's cell run again, the next
test) reuses it instead of paying the imports again. Meanwhile it holds about 180 MB
resident, half of it pages of the libraries' files."""

ANSWER_TIMEOUT_S = 120.0
"""Longest wait for the template's answer [s]: its first one comes once it has loaded
the planners and compiled loops (seconds; a minute where numba's cache is cold)."""

_PID = struct.Struct("<q")
_MAX_REQUEST = 1 << 20

_TEMPLATE = "from app.session.lanes import serve; serve({fd}, {linger!r})"


def _readable(fd: int, timeout: float | None) -> bool:
    """Whether ``fd`` becomes readable (or its peer hangs up) within ``timeout`` seconds.

    None waits for it. ``poll``, not ``select``: a server with a hall's websockets open
    holds more than ``select``'s 1024 file descriptors, and a worker started then gets a
    number above it. OSError (EBADF) for a descriptor that is not open.
    """
    poller = select.poll()
    poller.register(fd, select.POLLIN)
    events = poller.poll(None if timeout is None else max(0.0, timeout * 1e3))
    if any(mask & select.POLLNVAL for _, mask in events):
        raise OSError(errno.EBADF, f"file descriptor {fd} is not open")
    return bool(events)


class Forked:
    """A planner process forked from the template: the part of ``subprocess.Popen`` lanes use.

    Its pipes work at once; its pid is the template's answer, read when first asked for
    (the first template of a process answers only once it has loaded everything, and
    nobody should wait for that before the first call). It is the template's child, not
    ours: it is waited for through a pidfd, and the template reaps it.
    """

    def __init__(
        self,
        template: Template,
        ticket: tuple[int, int],
        stdin: IO[bytes],
        stdout: IO[bytes],
    ) -> None:
        self.stdin: IO[bytes] | None = stdin
        self.stdout: IO[bytes] | None = stdout
        self.returncode: int | None = None
        self._template = template
        self._ticket: tuple[int, int] | None = ticket
        self._lock = threading.Lock()
        self._pid: int | None = None
        self._pidfd: int | None = None

    @property
    def pid(self) -> int | None:
        """The process's id (None if the template ended before it forked it)."""
        with self._lock:
            if self._ticket is not None:
                ticket, self._ticket = self._ticket, None
                self._pid = self._template.answer(ticket)
                if self._pid is not None:
                    with contextlib.suppress(OSError):  # gone already: it ended
                        self._pidfd = os.pidfd_open(self._pid)
                if self._pidfd is None:
                    self.returncode = 0
            return self._pid

    def poll(self) -> int | None:
        """None while it runs, else 0 (its exit status is the template's to read)."""
        return self.wait(0.0, raising=False)

    def wait(self, timeout: float | None = None, *, raising: bool = True) -> int | None:
        """Wait until the process ended; ``subprocess.TimeoutExpired`` if it did not."""
        if self.pid is not None and self.returncode is None and self._pidfd is not None:
            if _readable(self._pidfd, timeout):
                self.returncode = 0
                os.close(self._pidfd)
                self._pidfd = None
            elif raising:
                raise subprocess.TimeoutExpired(
                    f"planner process {self._pid}", timeout or 0.0
                )
        return self.returncode

    def terminate(self) -> None:
        """Ask it to end (SIGTERM)."""
        self._signal(signal.SIGTERM)

    def kill(self) -> None:
        """End it (SIGKILL)."""
        self._signal(signal.SIGKILL)

    def _signal(self, sig: int) -> None:
        if self.pid is not None and self._pidfd is not None:
            with contextlib.suppress(OSError):
                signal.pidfd_send_signal(self._pidfd, sig)


class Template:
    """The parent's end of the template process (one per process, started on demand).

    Requests are numbered; the template answers each with the forked pid, in order.
    A ticket is (generation, number): a new template (the old one lingered out or died)
    starts a new generation, and tickets of the old one get no pid.
    """

    def __init__(self, linger: float = LINGER_S) -> None:
        self.linger = linger
        """Seconds the template lingers without planner processes (:data:`LINGER_S`)."""
        self._lock = threading.Lock()
        self._proc: subprocess.Popen[bytes] | None = None
        self._sock: socket.socket | None = None
        self._generation = 0
        self._sent = 0
        self._read = 0
        self._pids: dict[int, int] = {}

    def fork(self, nice: int) -> Forked:
        """Ask for a planner process; start the template first if there is none."""
        with self._lock:
            for attempt in (1, 2):
                if self._proc is not None and self._proc.poll() is not None:
                    # It lingered out or died. Asked anyway, it might not refuse: a
                    # worker it forked an instant before holds its end of the socket
                    # until that worker closes it, and the request would get no pid.
                    # (One that dies after this check still takes the request and
                    # answers nothing: its Forked has no pid and counts as ended.)
                    self._stop()
                if self._sock is None:
                    self._start()
                try:
                    return self._request(nice)
                except OSError:
                    self._stop()  # it exited (lingered out) or died: a new one
                    if attempt == 2:
                        raise
        raise AssertionError("unreachable")

    def answer(self, ticket: tuple[int, int]) -> int | None:
        """Return the pid forked for ``ticket``; None if its template ended without one."""
        generation, number = ticket
        with self._lock:
            while generation == self._generation and self._sock is not None:
                if number in self._pids:
                    return self._pids.pop(number)
                if number <= self._read:
                    return None
                try:  # one answer, one message (SOCK_SEQPACKET); b"": it exited
                    (pid,) = _PID.unpack(self._sock.recv(_PID.size))
                except (OSError, struct.error):
                    self._stop()
                    return None
                self._read += 1
                self._pids[self._read] = pid
            return None

    def pid(self) -> int | None:
        """Return the template's process id (None when none runs)."""
        with self._lock:
            return None if self._proc is None else self._proc.pid

    def _start(self) -> None:
        ours, theirs = socket.socketpair(socket.AF_UNIX, socket.SOCK_SEQPACKET)
        with theirs:
            self._proc = subprocess.Popen(
                [
                    sys.executable,
                    "-c",
                    _TEMPLATE.format(fd=theirs.fileno(), linger=self.linger),
                ],
                stdin=subprocess.DEVNULL,
                pass_fds=(theirs.fileno(),),
                env=_child_env(),
                cwd=os.getcwd(),
            )
        # A template that never answers (hung) is given up on, not waited for forever.
        ours.settimeout(ANSWER_TIMEOUT_S)
        self._sock = ours
        self._generation += 1
        self._sent = self._read = 0
        self._pids.clear()

    def _request(self, nice: int) -> Forked:
        sock = self._sock
        assert sock is not None
        child_in, to_child = os.pipe()
        from_child, child_out = os.pipe()
        try:
            request = pickle.dumps((nice, list(sys.path), os.getcwd()))
            socket.send_fds(sock, [request], [child_in, child_out])
        except OSError:
            os.close(to_child)
            os.close(from_child)
            raise
        finally:
            os.close(child_in)
            os.close(child_out)
        self._sent += 1
        return Forked(
            self,
            (self._generation, self._sent),
            os.fdopen(to_child, "wb"),
            os.fdopen(from_child, "rb"),
        )

    def close(self) -> None:
        """Let the template go (it exits; its workers go on until their stdin closes)."""
        with self._lock:
            self._stop()

    def _stop(self) -> None:
        sock, proc = self._sock, self._proc
        self._sock = self._proc = None
        if sock is not None:
            sock.close()  # the template exits when it reads the end
        if proc is not None:
            try:
                proc.wait(timeout=5)
            except subprocess.TimeoutExpired:  # hung: it does not read its socket
                proc.kill()
                proc.wait(timeout=5)


_template = Template()
# Let it go when this process exits, rather than leave it to notice the closed socket
# (Python would warn of a child still running and a socket left open).
atexit.register(_template.close)


def start_worker(nice: int = 0) -> Any:
    """Start a planner process running :func:`child_main`.

    Returns a :class:`Forked` (Linux) or a ``subprocess.Popen`` (elsewhere); either has
    ``pid``, ``stdin``, ``stdout``, ``poll``, ``wait``, ``terminate`` and ``kill``.

    Parameters
    ----------
    nice
        How much lower the process's scheduling priority is than ours (``os.nice``).
    """
    if hasattr(os, "pidfd_open") and hasattr(socket, "send_fds"):
        return _template.fork(nice)
    return spawn_worker(nice)


def template_pid() -> int | None:
    """Process id of this process's template (None when none runs)."""
    return _template.pid()


def spawn_worker(nice: int = 0) -> subprocess.Popen[bytes]:
    """Start the planner process from nothing (where processes cannot be forked safely)."""
    child = "from app.session.lanes import child_main; child_main()"
    if nice:
        child = f"import os; os.nice({nice}); {child}"
    return subprocess.Popen(
        [sys.executable, "-c", child],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        env=_child_env(),
        cwd=os.getcwd(),
    )


def _child_env() -> dict[str, str]:
    """Our environment, with our import path: a new interpreter finds what we find."""
    paths = [p for p in sys.path if p and Path(p).is_dir()]
    return {**os.environ, "PYTHONPATH": os.pathsep.join(paths)}


# --------------------------------------------------------------------------- the template


def serve(fd: int, linger: float = LINGER_S) -> None:
    """Run the template process: load what planners need, then fork workers on request."""
    # Ctrl-C in the lecturer's terminal reaches the whole process group: the template
    # and its workers end with the app (their pipes close), without tracebacks.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    prepare_worker(warm_up_now=True)
    sock = socket.socket(fileno=fd)
    idle_since: float | None = None
    while True:
        if _readable(sock.fileno(), 1.0):
            try:
                message, fds, _, _ = socket.recv_fds(sock, _MAX_REQUEST, 2)
            except OSError:
                return
            if not message or len(fds) != 2:
                return  # the parent closed its end (or exited)
            sys.stdout.flush()
            pid = _fork_child(sock, pickle.loads(message), fds)
            try:
                sock.sendall(_PID.pack(pid))
            except OSError:
                return  # the parent is gone: so is the worker's stdin, and the worker
        if _children_left():
            idle_since = None
        elif idle_since is None:
            idle_since = time.monotonic()
        elif time.monotonic() - idle_since > linger:
            if not _readable(sock.fileno(), 0.0):
                return  # (a request that arrives after this finds the socket closed)


def _fork_child(sock: socket.socket, request: Any, fds: list[int]) -> int:
    nice, paths, cwd = request
    pid = os.fork()
    if pid:
        for fd in fds:
            os.close(fd)
        return pid
    # The planner process: the pipes become its stdin and stdout. It never returns into
    # the template's loop: whatever happens, it ends here.
    code = 1
    try:
        sock.close()
        os.dup2(fds[0], 0)
        os.dup2(fds[1], 1)
        for fd in fds:
            os.close(fd)
        if nice:
            os.nice(nice)
        sys.path[:0] = [p for p in paths if p not in sys.path]
        with contextlib.suppress(OSError):  # (the caller's folder was removed)
            os.chdir(cwd)
        child_main(warm_up=False)
        code = 0
    except BaseException:
        traceback.print_exc()
    finally:
        sys.stderr.flush()
        os._exit(code)


def _children_left() -> bool:
    """Reap the planner processes that ended; whether any still runs."""
    while True:
        try:
            pid, _ = os.waitpid(-1, os.WNOHANG)
        except ChildProcessError:
            return False
        if pid == 0:
            return True


# --------------------------------------------------------------------------- inside a worker


def prepare_worker(*, warm_up_now: bool) -> None:
    """Ready this process to plan: the allocator's settings, numba and the compiled loops.

    ``warm_up_now``: load the loops before returning (the template planner processes are
    forked from); else in a thread, while the worker waits for its first scene.
    """
    from planners.allocator import keep_freed_memory  # noqa: PLC0415 - the worker's

    keep_freed_memory()
    # The compiled loops (TangentBug's sweep; a big scene's graphs) load from numba's
    # cache before the first scene, not during it.
    if warm_up_now:
        _warm_up()
    else:
        threading.Thread(target=_warm_up, name="warm-up", daemon=True).start()


def child_main(*, warm_up: bool = True) -> None:
    """Worker process: read ``fn``, then answer (scene, keywords) until stdin closes.

    ``warm_up``: ready the process first (:func:`prepare_worker`); a process forked from
    the template (:func:`serve`) is ready already.
    """
    from planners.allocator import freeze_long_lived  # noqa: PLC0415 - the worker's
    from planners.memo import Memo  # noqa: PLC0415 - only the child needs it here

    if warm_up:
        prepare_worker(warm_up_now=False)
    stdin, stdout = sys.stdin.buffer, sys.stdout.buffer
    # Anything a planner prints must not corrupt the pickles on stdout.
    sys.stdout = sys.stderr
    try:
        fn = pickle.load(stdin)
    except EOFError:
        return
    # The child's own caches, kept across calls: while the start or goal is dragged the
    # configuration space is the same scene after scene (planners keep no state).
    memo = Memo()
    frozen = False
    while True:
        try:
            scene, keywords = pickle.load(stdin)
        except (EOFError, OSError):
            return
        try:
            reply: tuple[bool, Any] = (True, fn(scene, memo=memo, **keywords))
            data = pickle.dumps(reply, protocol=pickle.HIGHEST_PROTOCOL)
        except Exception as error:  # sent back and shown in the panel
            data = pickle.dumps((False, f"{type(error).__name__}: {error}"))
        stdout.write(data)
        stdout.flush()
        if not frozen:  # the planners' imports are done: out of the collector's sight
            frozen = freeze_long_lived() > 0


def _warm_up() -> None:
    """Load numba and the compiled loops (:func:`planners.kernels.warm_up`)."""
    from planners.kernels import warm_up  # noqa: PLC0415 - the child's, in a thread

    warm_up()
