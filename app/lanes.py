"""Run the slow planners (DSB) in a process of their own.

TangentBug is mostly Python: run in a thread next to the VG/SVG lane it would hold the
interpreter lock for long stretches and slow every redraw during a drag (measured: the
fast lane's p50 went from about 7 ms to 30 ms). The planners are pure functions on
picklable values (scenes, shapely polygons, frozen results), so one worker process per
app computes them on another core; a scene goes in, the results come back pickled
(about 1 ms each way).
"""

from __future__ import annotations

__all__ = ["ProcessLane", "picklable_registry"]

import logging
import multiprocessing
import pickle
import threading
from collections.abc import Callable, Mapping
from multiprocessing.connection import Connection
from typing import Any

import planners

logger = logging.getLogger(__name__)


def picklable_registry(registry: Mapping[str, Any]) -> dict[str, Any] | None:
    """Return ``registry`` if every planner in it can be sent to a process, else None.

    Module-level functions pickle by name; a lambda or a closure (a test's stand-in)
    cannot, and then the caller keeps the slow lane in a thread.
    """
    try:
        pickle.dumps(dict(registry))
    except Exception:
        return None
    return dict(registry)


def _serve(
    conn: Connection, fn: Callable[[Any], Any], registry: Mapping[str, Any]
) -> None:
    """Child process: register the parent's planners, then answer scenes until closed."""
    planners.PLANNERS.update(registry)
    while True:
        try:
            scene = conn.recv()
        except (EOFError, OSError):
            return
        try:
            reply: tuple[bool, Any] = (True, fn(scene))
        except Exception as error:  # sent back and shown in the panel
            reply = (False, f"{type(error).__name__}: {error}")
        try:
            conn.send(reply)
        except Exception as error:  # an unpicklable result
            conn.send(
                (False, f"cannot send the result back: {type(error).__name__}: {error}")
            )


class ProcessLane:
    """Call ``fn(scene)`` in a worker process; one call at a time.

    Parameters
    ----------
    fn
        A picklable function (module-level, or a ``functools.partial`` of one).
    registry
        Planner name -> function, installed in the child's :data:`planners.PLANNERS`
        so it knows the same planners as the parent.
    """

    def __init__(self, fn: Callable[[Any], Any], registry: Mapping[str, Any]) -> None:
        self._fn = fn
        self._registry = dict(registry)
        self._lock = threading.Lock()
        self._conn: Connection | None = None
        self._proc: Any = None
        self._closed = False
        self._start()

    def _start(self) -> None:
        # "spawn": the parent runs threads (viser, the controller); forking it is unsafe.
        ctx = multiprocessing.get_context("spawn")
        parent, child = ctx.Pipe()
        proc = ctx.Process(
            target=_serve,
            args=(child, self._fn, self._registry),
            name="slow-planners",
            daemon=True,
        )
        proc.start()
        child.close()
        self._conn, self._proc = parent, proc

    def __call__(self, scene: Any) -> Any:
        """Compute ``fn(scene)`` in the worker; restart it once if it has died."""
        with self._lock:
            if self._closed:
                raise RuntimeError("the planner process is closed")
            ok, value = False, "the planner process did not answer"
            for attempt in (1, 2):
                assert self._conn is not None
                try:
                    self._conn.send(scene)
                    ok, value = self._conn.recv()
                    break
                except (EOFError, OSError, BrokenPipeError):
                    if attempt == 2 or self._closed:
                        raise RuntimeError("the planner process stopped") from None
                    logger.warning("the planner process stopped; starting a new one")
                    self._stop_process()
                    self._start()
            if not ok:
                raise RuntimeError(value)
            return value

    def _stop_process(self) -> None:
        if self._conn is not None:
            self._conn.close()
        if self._proc is not None:
            self._proc.terminate()
            self._proc.join(timeout=5)
        self._conn, self._proc = None, None

    @property
    def pid(self) -> int | None:
        """Process id of the worker (None once closed)."""
        return None if self._proc is None else self._proc.pid

    def close(self) -> None:
        """Stop the worker process (a call in progress ends with an error)."""
        self._closed = True
        # Not under the lock: a call may be waiting for the child; terminating the child
        # ends that wait with EOFError.
        proc, conn = self._proc, self._conn
        if proc is not None:
            proc.terminate()
            proc.join(timeout=5)
        if conn is not None:
            conn.close()
