"""Run the slow planners (DSB) in a process of their own.

TangentBug is mostly Python: run in a thread next to the VG/SVG lane it would hold the
interpreter lock for long stretches and slow every redraw during a drag (measured: the
fast lane's p50 went from about 7 ms to 30 ms). The planners are pure functions on
picklable values (scenes, shapely polygons, frozen results), so one worker process per
session computes them on another core; a scene goes in, the results come back pickled
(about 1 ms each way). The planners' registry travels inside the pickled function; the
child keeps its own :class:`planners.Memo` from call to call.

The worker is a plain ``python -c`` subprocess talking pickles over its stdin and stdout,
not :mod:`multiprocessing`: "spawn" would re-run the caller's main script in the child
(a lecturer's notebook or a script without a ``__main__`` guard), and "fork" is unsafe in
a process that runs threads (viser, the controller).
"""

from __future__ import annotations

__all__ = ["Interrupted", "ProcessLane", "picklable"]

import logging
import os
import pickle
import subprocess
import sys
import threading
from collections.abc import Callable
from pathlib import Path
from typing import IO, Any

logger = logging.getLogger(__name__)

_CHILD = "from app.session.lanes import _child_main; _child_main()"


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


def _child_main() -> None:
    """Worker process: read ``fn``, then answer (scene, keywords) until stdin closes."""
    from planners.allocator import (  # noqa: PLC0415 - the child's
        freeze_long_lived,
        keep_freed_memory,
    )
    from planners.memo import Memo  # noqa: PLC0415 - only the child needs it here

    keep_freed_memory()
    # The compiled loops (TangentBug's sweep; a big scene's graphs) load from numba's
    # cache while the worker waits for its first scene, not during it.
    threading.Thread(target=_warm_up, name="warm-up", daemon=True).start()

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
        # The child finds the same modules as we do (the project, a test's helpers).
        paths = [p for p in sys.path if p and Path(p).is_dir()]
        env = {**os.environ, "PYTHONPATH": os.pathsep.join(paths)}
        child = f"import os; os.nice({self._nice}); {_CHILD}" if self._nice else _CHILD
        self._proc = subprocess.Popen(
            [sys.executable, "-c", child],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            env=env,
            cwd=os.getcwd(),
        )
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
