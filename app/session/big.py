"""Big scenes: the fast planners in a worker process, with progress, cancelled by edits.

A floor plan from a CAD export or a generated maze has thousands of vertices; building
its visibility graph (section 9.4) takes seconds, not the few milliseconds of a lecture
scene. Computed in the fast lane's thread that would hold the interpreter lock against
the server (every browser would freeze) and keep the user's next edit waiting. So when a
scene has more than :data:`BIG_SCENE_VERTICES` vertices, the scheduler
(:mod:`app.session.scheduler`) hands the fast planners to a :class:`BigJob`: a worker process
(:class:`app.session.lanes.ProcessLane`) computes them while the fast lane's thread draws a
progress frame every :data:`PROGRESS_S` -- the scene as edited, the last plans greyed,
"Computing VG, SVG... (10,000 vertices, 2.3 s)" in the panel. The next edit gives the job
up: the worker is stopped (a fresh one starts at once), and its result can never be
drawn. Small scenes keep the in-process path and its few-millisecond budget.

Data flow::

    scheduler round, scene big:
      job = BigJob(key, scene, which, workers)    # a thread leases a worker, waits
      while not job.done:  draw progress frame (old plans, stale=True); wait
        a newer edit -> return; the next round: job.cancel() -> worker.interrupt()
                                    (still waiting for a pool's worker: the wait ends)
      plans = job.result                          # for exactly this key
"""

from __future__ import annotations

__all__ = [
    "BIG_SCENE_VERTICES",
    "PROGRESS_S",
    "SETTLE_S",
    "BigJob",
    "BigWorkers",
    "OwnWorker",
    "SharedWorkers",
    "progress_text",
    "scene_vertices",
]

import contextlib
import threading
import time
from collections.abc import Callable, Hashable, Iterator
from typing import Any, Protocol

from app.session.lanes import Interrupted, ProcessLane
from app.session.pool import WorkerPool
from planners.scene import Scene

BIG_SCENE_VERTICES = 1000
"""A scene with more vertices than this (obstacles and walls) is planned in a worker."""
PROGRESS_S = 0.25
"""Time between two progress frames while a big scene is computed [s]."""
SETTLE_S = 0.25
"""During a drag of a big scene, the computation starts once the mouse rests this long
[s]: a job per mouse event would only start and stop workers."""


def scene_vertices(scene: Scene) -> int:
    """Count the vertices of the scene's obstacles and walls (before expansion).

    Examples
    --------
    >>> from shapely import Polygon
    >>> import planners
    >>> square = Polygon([(1, 1), (2, 1), (2, 2), (1, 2)])
    >>> scene_vertices(planners.Scene(obstacles=(square,), start=(0, 0), goal=(3, 3)))
    4
    """
    rings = [o.exterior for o in scene.obstacles]
    if scene.boundary is not None:
        rings.append(scene.boundary.exterior)
    return sum(max(len(r.coords) - 1, 0) for r in rings)


class BigWorkers(Protocol):
    """Where a session's big scenes are computed: workers it leases one call at a time."""

    def lease(
        self, abandoned: Callable[[], bool]
    ) -> contextlib.AbstractContextManager[ProcessLane]:
        """Hold a worker for one job (it may interrupt it meanwhile).

        Raises :class:`app.session.lanes.Interrupted` when ``abandoned`` says the job was given
        up before it held one (it never waits for a worker it would not use).
        """
        ...

    def wake(self) -> None:
        """Have a lease that waits for a worker ask again (a job was given up)."""
        ...

    @property
    def pid(self) -> int | None:
        """The process id of a worker started, or None while none is."""
        ...

    def close(self) -> None:
        """Stop what the session owns (nothing of a shared pool)."""
        ...


class OwnWorker:
    """A session's own worker process for big scenes, started on first use."""

    def __init__(self, worker: ProcessLane) -> None:
        self.worker = worker

    @contextlib.contextmanager
    def lease(self, abandoned: Callable[[], bool]) -> Iterator[ProcessLane]:
        """Hold the session's worker: one job at a time is the scheduler's rule.

        Nothing waits here; a job given up before its call never starts (the worker
        asks ``abandoned`` first).
        """
        yield self.worker

    def wake(self) -> None:
        """Nothing waits for the session's own worker."""

    @property
    def pid(self) -> int | None:
        """The worker's process id, or None until the first big scene."""
        return self.worker.pid

    def close(self) -> None:
        """Stop the worker."""
        self.worker.close()


class SharedWorkers:
    """The private copies' big scenes computed in a classroom's bounded pool.

    The classroom owns and closes the pool; a copy closing leaves it running.
    """

    def __init__(self, pool: WorkerPool) -> None:
        self.pool = pool

    def lease(
        self, abandoned: Callable[[], bool]
    ) -> contextlib.AbstractContextManager[ProcessLane]:
        """Hold a free worker of the pool (waiting for one) for one job."""
        return self.pool.lease(abandoned)

    def wake(self) -> None:
        """Let the copies' jobs waiting for the pool see which were given up."""
        self.pool.wake()

    @property
    def pid(self) -> int | None:
        """None: the pool's workers are the classroom's (see ``pool.processes``)."""
        return None

    def close(self) -> None:
        """Leave the pool to the classroom."""


def progress_text(names: tuple[str, ...], vertices: int, seconds: float) -> str:
    """Say what is computed and for how long, for the panel.

    Examples
    --------
    >>> progress_text(("vg", "svg"), 10004, 2.34)
    'Computing VG, SVG... (10,004 vertices, 2.3 s)'
    """
    what = ", ".join(n.upper() for n in names) or "the plans"
    return f"Computing {what}... ({vertices:,} vertices, {seconds:.1f} s)"


class BigJob:
    """One computation of the fast planners for one scene, in a worker process.

    Parameters
    ----------
    key
        What the result is for (the scheduler's scene version and planners on).
    scene
        The scene to plan.
    which
        The planners to run.
    workers
        Where to compute: the job leases a worker for its call; :meth:`cancel`
        interrupts the worker while the job holds it.
    on_done
        Called (from the job's thread) when the job ends, however it ends.
    """

    def __init__(
        self,
        key: Hashable,
        scene: Scene,
        which: tuple[str, ...],
        workers: BigWorkers,
        on_done: Callable[[], None],
    ) -> None:
        self.key = key
        self.scene = scene
        self.which = which
        self.vertices = scene_vertices(scene)
        self.started = time.monotonic()
        self.result: Any = None
        """The planners' results (set once :attr:`done` and not cancelled)."""
        self.error: BaseException | None = None
        """What the worker raised, if it did."""
        self.done = threading.Event()
        self._workers = workers
        self._held: ProcessLane | None = None  # the worker while this job holds it
        self._held_lock = threading.Lock()
        self._on_done = on_done
        self._cancelled = False
        self._thread = threading.Thread(target=self._run, name="big-scene", daemon=True)
        self._thread.start()

    @property
    def cancelled(self) -> bool:
        """Whether the job was given up (its result, if any, is never used)."""
        return self._cancelled

    def elapsed(self) -> float:
        """Time since the job started [s]."""
        return time.monotonic() - self.started

    def progress(self) -> str:
        """Return the panel's words for this job now."""
        return progress_text(self.which, self.vertices, self.elapsed())

    def cancel(self) -> None:
        """Give the job up: stop the worker if it computes this job's scene.

        Only while the job holds the worker: once handed back, a shared pool's worker
        may compute another session's scene, which this must never stop. A job given up
        while it waits for a worker ends at once, without one (a student dragging a big
        scene gives up a job per edit: none of them lingers in the pool's queue); one
        given up as it gets one never starts (the worker asks ``abandoned`` first).
        """
        with self._held_lock:
            self._cancelled = True
            if self._held is not None:
                self._held.interrupt()
        self._workers.wake()

    def _run(self) -> None:
        try:
            with self._workers.lease(lambda: self._cancelled) as worker:
                with self._held_lock:
                    self._held = worker
                try:
                    result = worker(
                        self.scene, abandoned=lambda: self._cancelled, which=self.which
                    )
                finally:
                    with self._held_lock:
                        self._held = None
            if not self._cancelled:
                self.result = result
        except Interrupted:
            pass
        except Exception as error:  # shown as the planners' failure, never raised here
            if not self._cancelled:
                self.error = error
        finally:
            self.done.set()
            self._on_done()
