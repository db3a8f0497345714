"""The planning scheduler: two lanes, coalescing (latest version wins), frames.

Data flow on an edit (docs/architecture.md)::

    session: scene version v, lock.notify_all()
      fast lane (a thread of this process): the "graph" planners (VG, SVG) + expansion
           snapshot = state.snapshot_locked()            # under the lock
           plans = fast.run(scene, enabled graph names)  # planners.plan_all, outside it
           frame = build_frame(snapshot, plans + the slow lane's newest results)
           views.render(frame)                           # only versions newer than drawn
      slow lane (a thread waiting on a worker process, app.session.lanes): the "trace" planners
           results for the newest version it has not tried; stored as SlowResults, the
           fast lane draws them in its next round

Coalescing: edits are applied to the scene at once, so nothing a user does is dropped;
while a lane computes version 5, edits 6, 7 and 8 arrive, and its next round computes only
version 8. One thread computes and draws frames, in version order: a stale result never
overwrites a newer one. A slow result for an older version is shown only marked "updating"
(:attr:`Frame.lagging`) and only when it tells the same story as the fast lane.

Which planners run: the registry's ``kind`` decides the lane ("graph" fast, "trace" slow);
the session's ``enabled`` set decides which of them (the registry's defaults at first).
Each lane owns its :class:`planners.Memo` (the process lane's child keeps its own).
"""

from __future__ import annotations

__all__ = [
    "Failed",
    "Lane",
    "Pending",
    "PlanFn",
    "Scheduler",
    "SlowResults",
    "big_plan",
    "default_plan",
    "lanes_for",
    "merge_slow",
]

import contextlib
import dataclasses
import functools
import logging
import math
import threading
import time
from collections.abc import Callable, Iterable, Iterator, Mapping
from typing import Any

import numpy as np
import numpy.typing as npt
from shapely import Polygon

import planners
from app.session._state import SessionState, Snapshot
from app.session.big import (
    BIG_SCENE_VERTICES,
    PROGRESS_S,
    SETTLE_S,
    BigJob,
    BigWorkers,
    OwnWorker,
    scene_vertices,
)
from app.session.frames import Frame, Views, build_frame
from app.session.lanes import Interrupted, ProcessLane, picklable
from app.session.playback import Playback
from app.session.pool import Runner, Turns
from planners.registry import REGISTRY, PlannerSpec, planners_of_kind
from planners.scene import Scene

logger = logging.getLogger(__name__)

PlanFn = Callable[[Scene], Mapping[str, Any]]
"""Scene -> planner name -> result (plus ``"cspace"``), like :func:`planners.plan_all`."""

# A slow lane in a thread of this process (planners that cannot be sent to a worker
# process) shares the interpreter lock with the fast lane: it starts on a new scene once
# the fast lane has drawn it, or after this [s]. A worker process starts at once.
_SLOW_LANE_YIELD_S = 0.03
GIVE_UP_AFTER_S = 1.0
"""A big scene's slow call is given up for a newer edit only once it has run this long
[s]. Stopping the worker costs its restart and its memo: during a drag of a start or a
goal on a map the slow planners' answers, a few tenths of a second each, would never
arrive. A longer computation still stops (a later round, or the timer, gives it up)."""
SLOW_NICE = 10
"""How much lower the slow planners' worker's priority is than the server's
(``os.nice``). On a busy machine (a lecture hall's server, the lecturer's own browser
drawing beside it) the round that redraws VG and SVG under the mouse, with the tighter
budget, goes first; DSB takes what is left, its newest scene when it gets there. With
a core free, as on a quiet laptop, it runs as fast as before."""
ROBOT_LAG_S = 0.15
"""During a drag, the robot's trajectory may wait for the edit no newer one overtakes,
but never longer than this after the robot was last drawn [s]."""


def default_plan(
    scene: Scene,
    which: Iterable[str] | None = None,
    registry: Mapping[str, PlannerSpec] = REGISTRY,
    memo: planners.Memo | None = None,
) -> dict[str, Any]:
    """Run the planners ``which`` (default: the registry's default ones) on ``scene``.

    If running them all together fails (a bug in one planner), each planner is run on its
    own, so one broken planner never takes the others down with it.
    """
    which = (
        tuple(n for n, spec in registry.items() if spec.default)
        if which is None
        else tuple(which)
    )
    try:
        return dict(planners.plan_all(scene, which, memo=memo, registry=registry))
    except Exception:
        logger.exception("plan_all failed; running the planners one by one")
    results: dict[str, Any] = {}
    for name in which:
        try:
            results.update(
                planners.plan_all(scene, (name,), memo=memo, registry=registry)
            )
        except Exception as error:
            logger.exception("planner %s failed", name)
            results[name] = Failed(name, _failure(name, error))
    return results


def _failure(name: str, error: BaseException) -> str:
    return f"{name.upper()} failed: {type(error).__name__}: {error}"


@dataclasses.dataclass(frozen=True, eq=False)
class Pending:
    """A slow planner's place-holder while it computes: no path yet, never a stale one."""

    planner: str
    status: str = "computing"
    reason: str | None = None
    length: float | None = None
    path: npt.NDArray[np.float64] = dataclasses.field(
        default_factory=lambda: np.zeros((0, 2))
    )
    ms: float = 0.0


@dataclasses.dataclass(frozen=True, eq=False)
class Failed(planners.InvalidResult):
    """A planner that raised: no path, and the error in words (a bug, not a result)."""

    status: str = "error"


# --------------------------------------------------------------------------- lanes


@dataclasses.dataclass(frozen=True)
class Lane:
    """The planners one lane computes, and how."""

    names: tuple[str, ...]
    """The planners this lane can compute, in registry order."""
    run: Callable[[Scene, tuple[str, ...]], Mapping[str, Any]]
    """(scene, names to run) -> results."""
    follows_enabled: bool = True
    """Run only the enabled ones of :attr:`names` (False: a caller's fixed function)."""
    process: ProcessLane | None = None
    """The worker process the lane runs in, if any (closed with the scheduler)."""
    big: BigWorkers | None = None
    """Where a big scene's plans are computed (:mod:`app.session.big`): the session's own worker
    process or a classroom's shared pool; None: in the lane's thread."""

    def which(self, enabled: frozenset[str]) -> tuple[str, ...]:
        """Return the names to run when the ``enabled`` planners are switched on."""
        if not self.follows_enabled:
            return self.names
        return tuple(n for n in self.names if n in enabled)


def _fixed(plan: PlanFn, names: tuple[str, ...]) -> Lane:
    """Wrap a caller's plan function (a test's): always the same planners."""
    return Lane(names, lambda scene, which: plan(scene), follows_enabled=False)


def lanes_for(
    registry: Mapping[str, PlannerSpec],
    *,
    plan: PlanFn | None = None,
    slow_plan: PlanFn | None = None,
    slow_names: Iterable[str] | None = None,
    slow_process: bool | Callable[[Scene, tuple[str, ...]], Any] = True,
    big_workers: BigWorkers | None = None,
    fast_process: Callable[[Scene, tuple[str, ...]], Any] | None = None,
) -> tuple[Lane, Lane | None]:
    """Build the fast and slow lanes for ``registry`` (or the caller's plan functions).

    The "graph" planners form the fast lane and the "trace" planners the slow one, each
    with its own :class:`planners.Memo`. The slow lane runs in a worker process when its
    planners can be pickled (``slow_process``), else in a thread. A caller's ``plan``
    replaces the fast lane; ``slow_plan`` (computing ``slow_names``) the slow one;
    passing ``plan`` alone means no slow lane. A callable ``slow_process`` (a shared
    :class:`app.session.pool.WorkerPool`) runs the slow lane instead of a process of its own,
    and ``big_workers`` (:class:`app.session.big.SharedWorkers`) a big scene's fast planners.
    A ``fast_process`` (a shared pool too) runs the fast lane's planners: a student's
    copy never plans in the interpreter that serves the presenter.
    """
    fast_names = planners_of_kind("graph", registry=registry)
    slow = planners_of_kind("trace", registry=registry)
    if plan is not None:
        fast = _fixed(plan, fast_names)
        if slow_plan is None:
            return fast, None
    else:
        memo = planners.Memo()
        run = functools.partial(_run, registry=registry, memo=memo)
        big = big_workers if big_workers is not None else _big_worker(registry)
        fast = Lane(fast_names, fast_process or run, big=big)
    if slow_plan is not None:
        names = slow if slow_names is None else tuple(slow_names)
        return fast, _fixed(slow_plan, names)
    if not slow:
        return fast, None
    if callable(slow_process):
        return fast, Lane(slow, slow_process)
    fn = functools.partial(default_plan, which=slow, registry=dict(registry))
    if slow_process and picklable(fn):
        # A process of its own: TangentBug would otherwise hold the GIL against the
        # VG/SVG lane (see app.session.lanes). Its child keeps its own Memo.
        process = ProcessLane(fn, nice=SLOW_NICE)
        return fast, Lane(slow, _remote(process), process=process)
    memo = planners.Memo()
    return fast, Lane(slow, functools.partial(_run, registry=registry, memo=memo))


def big_plan(registry: Mapping[str, PlannerSpec]) -> functools.partial[Any]:
    """Return the function a big scene's worker computes: the fast lane's planners."""
    names = planners_of_kind("graph", registry=registry)
    return functools.partial(default_plan, which=names, registry=dict(registry))


def _big_worker(registry: Mapping[str, PlannerSpec]) -> OwnWorker | None:
    """Make the worker for big scenes' fast planners (started on first use).

    None when there are none, or when they cannot be sent to a process.
    """
    fn = big_plan(registry)
    if not fn.keywords["which"] or not picklable(fn):
        return None
    return OwnWorker(ProcessLane(fn, start=False))


def _run(
    scene: Scene,
    which: tuple[str, ...],
    registry: Mapping[str, PlannerSpec],
    memo: planners.Memo,
) -> dict[str, Any]:
    return default_plan(scene, which, registry, memo)


def _remote(process: ProcessLane) -> Callable[[Scene, tuple[str, ...]], Any]:
    def run(scene: Scene, which: tuple[str, ...]) -> Any:
        return process(scene, which=which)

    return run


@contextlib.contextmanager
def _granted(turns: Turns, closed: Callable[[], bool]) -> Iterator[bool]:
    """Hold a turn of ``turns``; yield False instead when ``closed`` while waiting."""
    try:
        with turns.turn(closed):
            yield True
    except Interrupted:
        yield False


# --------------------------------------------------------------------------- records


@dataclasses.dataclass(frozen=True)
class _PlanKey:
    """What a lane's results were computed for: a scene version and the planners on."""

    version: int
    enabled: frozenset[str]


@dataclasses.dataclass(frozen=True)
class _Computed:
    """The fast lane's results for one key."""

    key: _PlanKey
    scene: Scene
    plans: Mapping[str, Any]
    ms: float


@dataclasses.dataclass(frozen=True)
class SlowResults:
    """The slow lane's newest results and the scene they were computed for."""

    version: int = -1
    """Scene version (-1: none yet)."""
    scene: Scene | None = None
    results: Mapping[str, Any] = dataclasses.field(default_factory=dict)


@dataclasses.dataclass(frozen=True)
class _Drawn:
    """The last frame drawn: its scene version and UI version."""

    version: int = -1
    ui_version: int = -1


@dataclasses.dataclass(frozen=True)
class _Merged:
    """A round's plans: the fast results with the slow lane's, or their stand-ins."""

    plans: dict[str, Any]
    lagging: frozenset[str]
    slow_version: int


def _outcome(status: str | None) -> str | None:
    """Say what a status tells of the goal: reached ("path"), cut off ("none"), or neither."""
    if status in ("ok", "reached"):
        return "path"
    if status == "unreachable":
        return "none"
    return None


def _may_lag(
    fast: Mapping[str, Any], shown: Scene, current: Scene, result: Any
) -> bool:
    """Whether a slow ``result`` for ``shown`` may stand in for ``current`` while it computes.

    Only during an edit of the same setting (same walls and number of obstacles, so not
    a new scenario), and only when it tells the same story as the fast planners do for
    the current scene: a path when they find one, "unreachable" when the goal is cut
    off. When the scene is invalid, or the goal was just cut off (or freed), the slow
    planner shows no path rather than an old one that would contradict the others.
    """
    if shown.boundary != current.boundary or len(shown.obstacles) != len(
        current.obstacles
    ):
        return False
    outcomes = {
        _outcome(getattr(r, "status", None)) for n, r in fast.items() if n != "cspace"
    }
    return (
        len(outcomes) == 1
        and None not in outcomes
        and outcomes == {_outcome(getattr(result, "status", None))}
    )


def _invalid_reason(fast: Mapping[str, Any]) -> str | None:
    """Return why the scene cannot be planned at all, if the fast planners found a reason.

    Such a verdict (start or goal inside an obstacle, a self-intersecting polygon) is the
    same for every planner, so the slow planners need not be waited for.
    """
    for name, result in fast.items():
        if name != "cspace" and getattr(result, "status", None) == "invalid":
            return str(getattr(result, "reason", None) or "the scene is not valid")
    return None


def merge_slow(
    computed: _Computed, slow: SlowResults, names: tuple[str, ...]
) -> _Merged:
    """Put the slow planners ``names`` beside the fast results of ``computed`` (pure).

    Each shows its result for this version when there is one; else the fast lane's
    "invalid" verdict; else, during a drag, its result for an older scene marked as
    lagging when that tells the same story; else a :class:`Pending` place-holder.
    """
    version, scene, fast = computed.key.version, computed.scene, computed.plans
    plans = dict(fast)
    lagging: set[str] = set()
    invalid = _invalid_reason(fast)
    shown = -1
    for name in names:
        result = slow.results.get(name)
        if result is not None and slow.version == version:
            plans[name], shown = result, version
        elif invalid is not None:
            # Not plannable: every planner gives this answer, no need to wait for it.
            plans[name], shown = planners.InvalidResult(name, invalid), version
        elif (
            result is not None
            and slow.scene is not None
            and _may_lag(fast, slow.scene, scene, result)
        ):
            # During a drag the slow planner (~20-50 ms) falls behind the mouse: show
            # its newest result, marked as lagging, rather than nothing.
            plans[name], shown = result, slow.version
            lagging.add(name)
        else:
            plans[name] = Pending(name)
    plans.pop("cspace", None)
    plans["cspace"] = fast.get("cspace")
    return _Merged(plans, frozenset(lagging), shown)


# --------------------------------------------------------------------------- scheduler


def _same_slow_work(lane: Lane, a: _PlanKey, b: _PlanKey) -> bool:
    """Whether the slow lane computes the same for keys ``a`` and ``b``.

    The same scene version and the same slow planners on: switching a fast planner on or
    off gives no slow call up.
    """
    return a.version == b.version and lane.which(a.enabled) == lane.which(b.enabled)


class Scheduler:
    """Plan every new version of the session's scene in two lanes and draw the frames.

    Parameters
    ----------
    state
        The session: its scene, UI state and the one lock every thread waits on.
    views
        Where frames are drawn.
    playback
        The robot: its trajectory is looked up (and planned) in each round.
    fast, slow
        The lanes (see :func:`lanes_for`); ``slow`` None for no second lane.
    turns
        Each round takes a turn of these first (a classroom's copies share them:
        :class:`app.session.pool.Turns`); None: rounds run as soon as there is work.
    runners
        Where the rounds and the slow lane's calls run: (rounds, slow calls), two
        :class:`app.session.pool.Runner` s shared by a classroom's copies, woken by every
        change of the session (:class:`app.session._state.Signalling`). None: threads of
        its own (one per lane).
    """

    def __init__(
        self,
        state: SessionState,
        views: Views,
        playback: Playback,
        fast: Lane,
        slow: Lane | None,
        *,
        turns: Turns | None = None,
        runners: tuple[Runner, Runner] | None = None,
    ) -> None:
        self._state = state
        self._turns = turns
        self._lock = state.lock
        self._views = views
        self._playback = playback
        self._fast = fast
        self._slow_lane = slow
        # Guarded by the lock:
        self._computed: _Computed | None = None
        self._slow = SlowResults()
        self._slow_tried: _PlanKey | None = None  # newest key the slow lane started on
        self._slow_busy = False
        self._drawn = _Drawn()
        self._busy = False
        self._closed = False
        self._last_frame: Frame | None = None
        self._robot_drawn_at = -math.inf  # time.monotonic() of the last robot frame
        self.robot_lag_s = ROBOT_LAG_S
        """How long the robot may stay on an older edit's trajectory during a drag [s]."""
        self._job: BigJob | None = None  # a big scene's computation (app.session.big)
        self._slow_big = False  # the slow lane computes a big scene
        # When the slow lane started on _slow_tried [monotonic s].
        self._slow_since = 0.0
        self._give_up_timer: threading.Timer | None = None
        self._slow_given_up: _PlanKey | None = None  # the slow call given up on
        # The fast lane's thread only:
        self._other: tuple[Any, tuple[Polygon, ...] | None] = (None, None)
        self._threads: list[threading.Thread] = []
        self._runners = runners
        if runners is not None:
            state.lock.listeners.append(self._wake_runners)
            with self._lock:
                self._wake_runners()  # the first frame
            return
        self._threads.append(threading.Thread(target=self._work, name="planner-worker"))
        if slow is not None:
            name = "slow-planner-worker"
            self._threads.append(threading.Thread(target=self._work_slow, name=name))
        for thread in self._threads:
            thread.daemon = True
            thread.start()

    @property
    def frame(self) -> Frame | None:
        """The last frame drawn (None before the first)."""
        with self._lock:
            return self._last_frame

    @property
    def slow_planners(self) -> tuple[str, ...]:
        """Planners computed in the second lane, shown when ready."""
        return () if self._slow_lane is None else self._slow_lane.names

    @property
    def process(self) -> ProcessLane | None:
        """The slow lane's worker process, if it has one."""
        return None if self._slow_lane is None else self._slow_lane.process

    @property
    def alive(self) -> bool:
        """Whether the fast lane runs (its thread, or its jobs on the runners)."""
        if self._runners is not None:
            return not self._closed
        return self._threads[0].is_alive()

    def redraw(self) -> None:
        """Draw the frame again (one more view was added)."""
        with self._lock:
            self._state.touch_locked()

    def wait_idle(self, timeout: float = 10.0) -> bool:
        """Block until every edit is planned and drawn; False if ``timeout`` [s] passed."""
        deadline = time.monotonic() + timeout
        with self._lock:
            while not self._idle_locked():
                remaining = deadline - time.monotonic()
                if remaining <= 0 or self._closed:
                    return self._idle_locked()
                self._lock.wait(min(remaining, 0.05))
            return True

    def close(self) -> None:
        """Stop the lanes' threads and the worker processes, and give a big job up.

        A big scene's job is cancelled, not only its worker closed: a classroom's copy
        leases a worker of a shared pool, which must go back to the others at once.
        """
        with self._lock:
            self._closed = True
            self._lock.notify_all()
            timer = self._give_up_timer
        if timer is not None:
            timer.cancel()
        self._cancel_job()
        if self.process is not None:
            self.process.close()
        if self._fast.big is not None:
            self._fast.big.close()
        for thread in self._threads:
            if thread is not threading.current_thread():
                thread.join(timeout=5.0)
        if self._runners is not None:
            with self._lock:
                self._state.lock.listeners.remove(self._wake_runners)
            self._runners[0].forget(self._round_job)
            self._runners[1].forget(self._slow_job)
        self._cancel_job()  # one the fast lane started as it was being closed

    def _cancel_job(self) -> None:
        job, self._job = self._job, None
        if job is not None:
            job.cancel()

    # ------------------------------------------------------------------ internals

    @staticmethod
    def _key(snapshot: Snapshot) -> _PlanKey:
        return _PlanKey(snapshot.version, snapshot.ui.enabled)

    def _current_locked(self) -> bool:
        s = self._state.snapshot_locked()
        return self._drawn == _Drawn(s.version, s.ui_version)

    def _idle_locked(self) -> bool:
        snapshot = self._state.snapshot_locked()
        slow_done = self._slow_lane is None or (
            not self._slow_busy and self._slow_tried == self._key(snapshot)
        )
        drawn = _Drawn(snapshot.version, snapshot.ui_version)
        return slow_done and not self._busy and self._drawn == drawn

    def _work(self) -> None:
        """Fast lane: plan the newest version and draw its frame, forever."""
        while True:
            with self._lock:
                while not self._closed and self._current_locked():
                    self._lock.wait()
                if self._closed:
                    return
            if not self._turned_round():
                return  # closed while it waited for its turn

    def _wake_runners(self) -> None:
        """Ask the runners for a round and a slow call (the session changed; lock held)."""
        assert self._runners is not None
        self._runners[0].wake(self._round_job)
        if self._slow_lane is not None:
            self._runners[1].wake(self._slow_job)

    def _round_job(self) -> None:
        """One round, if the newest snapshot is not drawn yet (a runner's thread)."""
        with self._lock:
            if self._closed or self._current_locked():
                return
        self._turned_round()

    def _slow_job(self) -> None:
        """One slow call, if the slow lane has not tried the newest key (a runner's)."""
        lane = self._slow_lane
        assert lane is not None
        with self._lock:
            snapshot = self._state.snapshot_locked()
            if self._closed or self._slow_tried == self._key(snapshot):
                return
        self._slow_once(lane, snapshot)

    def _turned_round(self) -> bool:
        """Take a turn, then one round; False if closed while waiting for the turn."""
        with self._turn() as granted:
            if granted:
                self._work_round()
        return granted

    def _turn(self) -> contextlib.AbstractContextManager[bool]:
        """Take a round's turn (:class:`app.session.pool.Turns`); False if closed first."""
        if self._turns is None:
            return contextlib.nullcontext(True)
        return _granted(self._turns, lambda: self._closed)

    def _work_round(self) -> None:
        """One round on the newest snapshot (the fast lane's thread)."""
        with self._lock:
            if self._closed or self._current_locked():
                return
            self._busy = True
            # Everything a round depends on is read together with the UI version it
            # will be recorded under: anything that changes later (an edit, a setting,
            # a slow planner's result) bumps a version, so the loop runs again.
            snapshot = self._state.snapshot_locked()
            computed, slow = self._computed, self._slow
        try:
            self._round(snapshot, computed, slow)
        except Exception:
            # The server must keep running whatever a planner or a view does.
            logger.exception("recompute failed")
            with self._lock:
                words = "Internal error while drawing; see the server log."
                self._state.say(words)
                now = self._state.snapshot_locked()
                self._drawn = _Drawn(now.version, now.ui_version)
        finally:
            with self._lock:
                self._busy = False
                self._lock.notify_all()

    def _round(
        self, snapshot: Snapshot, computed: _Computed | None, slow: SlowResults
    ) -> None:
        """Plan the snapshot's scene (unless ``computed`` already holds it) and draw it."""
        key = self._key(snapshot)
        self._give_up_stale(key)
        if computed is None or computed.key != key:
            computed = self._compute(snapshot, key)
            if computed is None:
                return  # a newer edit came first: the next round plans it
        self._draw(
            snapshot, computed, merge_slow(computed, slow, self._slow_names(key))
        )

    def _compute(self, snapshot: Snapshot, key: _PlanKey) -> _Computed | None:
        """Run the fast lane's planners on the snapshot's scene (a big one in a worker)."""
        if self._fast.big is not None and (
            scene_vertices(snapshot.scene) > BIG_SCENE_VERTICES
        ):
            return self._compute_big(snapshot, key)
        t0 = time.perf_counter()
        plans = self._fast.run(snapshot.scene, self._fast.which(key.enabled))
        ms = (time.perf_counter() - t0) * 1e3
        return _Computed(key, snapshot.scene, plans, ms)

    def _slow_names(self, key: _PlanKey) -> tuple[str, ...]:
        """Return the slow lane's planners switched on under ``key``."""
        return () if self._slow_lane is None else self._slow_lane.which(key.enabled)

    def _draw(self, snapshot: Snapshot, computed: _Computed, merged: _Merged) -> None:
        """Draw the planners' layers, then the robot on the trajectory they give."""
        scene = computed.scene
        other = (
            self._other_expansion(scene)
            if snapshot.ui.layers["other_expansion"]
            else None
        )

        def frame_with(trajectory: Any) -> Frame:
            return build_frame(
                snapshot,
                merged.plans,
                trajectory=trajectory,
                other=other,
                compute_ms=computed.ms,
                lagging=merged.lagging,
                slow_version=merged.slow_version,
            )

        lookup = self._playback.lookup(
            snapshot.version, scene, merged.plans, snapshot.ui.follow
        )
        if lookup.must_plan:
            # The planners' layers first: planning the robot's new trajectory takes up
            # to a few ms, and meanwhile the robot stays on its previous one. The frame
            # with the new trajectory follows at once (it sends only the robot's parts),
            # unless a newer edit is already there: its layers come first, and the
            # robot follows an edit no newer one overtakes -- or, in a long drag whose
            # rounds take longer than the mouse's period, the newest edit at least
            # every robot_lag_s.
            first = frame_with(self._playback.trajectory)
            with self._lock:
                self._computed = computed
            self._views.render(first)
            # Releasing the interpreter lock gives a thread that waits to hand in the
            # next edit a chance to do so now (not a promise: it may not get the lock).
            time.sleep(0)
            if (
                self._state.version != snapshot.version
                and time.monotonic() - self._robot_drawn_at < self.robot_lag_s
            ):
                with self._lock:
                    self._last_frame = first
                return
        trajectory = self._playback.plan(scene, lookup)
        frame = frame_with(trajectory)
        with self._lock:
            self._computed = computed
            pose = self._playback.settle_locked()
        self._views.render_with_robot(frame, pose)
        self._robot_drawn_at = time.monotonic()
        with self._lock:
            self._last_frame = frame
            self._drawn = _Drawn(snapshot.version, snapshot.ui_version)

    def _work_slow(self) -> None:
        """Slow lane: compute the slow planners for the newest scene, drop stale ones."""
        lane = self._slow_lane
        assert lane is not None
        while True:
            with self._lock:
                snapshot = self._wait_for_slow_work_locked(lane)
                if snapshot is None:
                    return
            self._slow_once(lane, snapshot)

    def _slow_once(self, lane: Lane, snapshot: Snapshot) -> None:
        """Compute the slow planners for ``snapshot`` and keep the results."""
        with self._lock:
            key = self._key(snapshot)
            self._slow_tried, self._slow_busy = key, True
            self._slow_since = time.monotonic()
            self._slow_given_up = None  # a call given up before is over
            self._slow_big = scene_vertices(snapshot.scene) > BIG_SCENE_VERTICES
        which = lane.which(key.enabled)
        try:
            results = self._run_slow(lane, snapshot.scene, key, which)
        except Interrupted:
            with self._lock:  # given up for a newer big scene (_give_up_stale)
                # Not tried after all: if the scene comes back to this key (a
                # planner switched off and on again), it is computed again.
                self._slow_busy, self._slow_tried = False, None
                self._lock.notify_all()
            return
        except Exception as error:
            if self._closed:
                with self._lock:
                    self._slow_busy = False
                return  # the planner process was stopped by close()
            logger.exception("slow planners failed")
            results = {n: Failed(n, _failure(n, error)) for n in which}
        with self._lock:
            self._slow_busy = False
            # Keep it if nothing newer is known. If a newer edit arrived meanwhile,
            # the result may still be shown (marked as lagging) until the round
            # for the newest scene, which starts next, replaces it.
            if key.version >= self._slow.version:
                self._slow = SlowResults(key.version, snapshot.scene, results)
                self._state.touch_locked()  # redraw the frame with them
            self._lock.notify_all()

    def _wait_for_slow_work_locked(self, lane: Lane) -> Snapshot | None:
        """Wait for a version the slow lane has not tried; None once closed."""
        while not self._closed and self._slow_tried == self._key(
            self._state.snapshot_locked()
        ):
            self._lock.wait()
        # In a thread, let the fast lane draw the newest scene first (the two would take
        # turns with the interpreter lock), but never wait more than a moment, so that
        # during a drag the slow result keeps coming. A worker process runs on the other
        # core next to the fast lane: no waiting.
        yield_s = 0.0 if lane.process is not None else _SLOW_LANE_YIELD_S
        deadline = time.monotonic() + yield_s
        while (
            not self._closed
            and self._drawn.version < self._state.snapshot_locked().version
            and time.monotonic() < deadline
        ):
            self._lock.wait(max(0.0, deadline - time.monotonic()))
        return None if self._closed else self._state.snapshot_locked()

    def _other_expansion(self, scene: Scene) -> tuple[Polygon, ...] | None:
        key = (scene.obstacles, scene.robot.radius, scene.expansion)
        if self._other[0] == key:
            return self._other[1]
        other_mode = "square" if scene.expansion == "disk" else "disk"
        try:
            polygons = tuple(
                planners.expand_polygon(o, scene.robot.radius, other_mode)
                for o in scene.obstacles
                if o.is_valid
            )
        except Exception:
            logger.exception("other expansion failed")
            polygons = None
        self._other = (key, polygons)
        return polygons

    # ------------------------------------------------------------------ big scenes

    def _run_slow(
        self, lane: Lane, scene: Scene, key: _PlanKey, which: tuple[str, ...]
    ) -> dict[str, Any]:
        """Run the slow planners; in the lane's own worker, a call that may be given up."""
        if not which:
            return {}
        if lane.process is None:
            return dict(lane.run(scene, which))

        def given_up() -> bool:
            return self._slow_given_up == key

        return dict(lane.process(scene, abandoned=given_up, which=which))

    def _give_up_stale(self, key: _PlanKey) -> None:
        """Stop the big scene's computations that are not for ``key`` (a newer edit).

        The fast lane's job, and the slow lane's call when it plans a big scene in a
        worker of its own (a small scene's slow result is still shown, marked lagging,
        during a drag: that call is left to finish).
        """
        job = self._job
        if job is not None and job.key != key:
            self._job = None
            job.cancel()
        self._give_up_slow(key)

    def _give_up_slow(self, key: _PlanKey) -> None:
        """Stop the slow lane's big call if it is not for ``key`` and has run long enough."""
        process = None
        with self._lock:
            slow = self._slow_lane
            if (
                slow is not None
                and slow.process is not None
                and self._slow_busy
                and self._slow_big
                and self._slow_tried is not None
                and self._slow_tried != self._slow_given_up
                and not _same_slow_work(slow, self._slow_tried, key)
            ):
                young = GIVE_UP_AFTER_S - (time.monotonic() - self._slow_since)
                if young > 0:
                    self._give_up_later_locked(young)
                else:
                    self._slow_given_up = self._slow_tried
                    process = slow.process
        if process is not None:
            process.interrupt()

    def _give_up_later_locked(self, delay: float) -> None:
        """Ask :meth:`_give_up_slow` again in ``delay`` s (one timer at a time)."""
        timer = self._give_up_timer
        if timer is not None and timer.is_alive():
            return
        timer = threading.Timer(delay, self._give_up_for_newest)
        timer.daemon = True
        self._give_up_timer = timer
        timer.start()

    def _give_up_for_newest(self) -> None:
        """Give the slow call up if it is not for the newest scene (the timer's call)."""
        with self._lock:
            if self._closed or self._slow_tried is None:
                return
            newest = self._key(self._state.snapshot_locked())
        self._give_up_slow(newest)

    def _compute_big(self, snapshot: Snapshot, key: _PlanKey) -> _Computed | None:
        """Plan a big scene in the worker, drawing progress frames; None if overtaken."""
        big = self._fast.big
        assert big is not None
        if snapshot.ui.dragging and self._job is None:
            # While the mouse moves, show the scene as edited and wait for it to rest.
            self._views.render(self._progress_frame(snapshot, None))
            with self._lock:
                self._lock.wait_for(
                    lambda: (
                        self._closed or self._key(self._state.snapshot_locked()) != key
                    ),
                    timeout=SETTLE_S,
                )
                if self._closed or self._key(self._state.snapshot_locked()) != key:
                    return None
        job = self._job
        if job is None:
            job = self._job = BigJob(
                key, snapshot.scene, self._fast.which(key.enabled), big, self._wake
            )
        drawn_ui, next_at = -1, 0.0
        while True:
            with self._lock:
                now = self._state.snapshot_locked()
                if self._closed or self._key(now) != key:
                    return None  # the next round gives this job up
                if job.done.is_set():
                    break
                if now.ui_version == drawn_ui and time.monotonic() < next_at:
                    self._lock.wait(max(0.0, next_at - time.monotonic()))
                    continue
            self._views.render(self._progress_frame(now, job))
            drawn_ui, next_at = now.ui_version, time.monotonic() + PROGRESS_S
        self._job = None
        if job.error is not None:
            plans = {n: Failed(n, _failure(n, job.error)) for n in job.which}
        else:
            plans = dict(job.result)
        return _Computed(key, job.scene, plans, job.elapsed() * 1e3)

    def _wake(self) -> None:
        with self._lock:
            self._lock.notify_all()

    def _progress_frame(self, snapshot: Snapshot, job: BigJob | None) -> Frame:
        """Make a frame of the scene as edited, with the last plans (stale) if of its room."""
        with self._lock:
            last = self._last_frame
        kept = last is not None and last.scene.boundary == snapshot.scene.boundary
        plans: Mapping[str, Any] = last.plans if kept and last is not None else {}
        frame = build_frame(
            snapshot,
            plans,
            trajectory=last.trajectory if kept and last is not None else None,
            other=None,
            compute_ms=0.0,
            lagging=frozenset(plans),  # an older scene's reasons are not said
        )
        words = (
            job.progress()
            if job is not None
            else "Waiting for the drag to rest before planning"
            f" ({scene_vertices(snapshot.scene):,} vertices)."
        )
        return dataclasses.replace(frame, progress=words, stale=True)
