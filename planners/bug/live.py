r"""Live DSB: the robot senses the scene as it drives, every dt (sections 9.6 and 9.7).

The planner (:mod:`planners.bug.tangent_bug`) runs TangentBug on a frozen scene and the app
replays its path. Here the robot drives instead: every ``dt`` seconds (0.05 s, section
9.7.1) :func:`step` takes the scene *as it is at that moment* (moving obstacles where they
are then, the goal where the user has put it), checks that the robot is still in free
space, takes a DSB decision, and commands velocities that the kinematics turn into
wheel rates (eq. 9.5 for the holonomic robot, eq. 9.9 for the differential one).

One decision code
    The decision is :func:`planners.bug.tangent_bug.step`, the planner's own step (goal
    seeking, boundary following and the leave rule of Fig. 9.15), on the robot's
    :class:`~planners.bug.tangent_bug.BugState`. That step is event-driven: it moves the robot
    to the next point where the decision can change, and the live robot drives that piece
    (its *plan*) in dt-steps. In a static scene nothing it senses on the way differs from
    what the step saw, so it takes the next decision where the piece ends, exactly where
    the planner does: the live path is the planner's path and the events come in the same
    order. When the scene it senses has changed (an obstacle moved, the goal was dragged)
    it decides again from where it is, carrying its memory over (the followed border is
    found again by its obstacle; where it cannot be, the robot seeks the goal afresh).
Driving (section 9.7)
    The robot stays on the piece: each dt it moves a distance d along it, and the
    commanded velocity is the chord over dt (positions at the samples lie on the DSB path,
    so they are in free space of the scene it sensed). The holonomic robot keeps its
    heading and slows where the piece turns; the differential robot (section 9.7.2)
    stops at each corner, turns in place (:math:`\dot\theta_1 = \dot\theta_2`) and drives
    straight, backwards where that turn is shorter. At the end of a piece the robot comes
    to rest: it cannot know where the next decision will send it before it senses there.
Wheel limits (section 9.7.3)
    Every command is checked wheel by wheel against :class:`kinematics.WheelLimits`
    (rate and acceleration): d is the largest distance whose command keeps each wheel
    within them and from which the robot can still stop where it must.
Safety (section 9.6: "the obstacles do not have to be static")
    If a moving obstacle reaches the robot (its expanded shape contains the robot's
    centre), the robot stops (status ``"blocked"``, :attr:`LiveState.message` in words)
    and goes on when the way is clear. If the piece it drives becomes blocked ahead of it
    within its stopping distance, it brakes on the free part, or, when that is not
    enough, stops at once (an emergency stop: the one command allowed to exceed the
    acceleration limit, recorded as an event). When the planner's step proves the goal
    unreachable, the live robot waits (``"waiting"``) for the scene to change; in a static
    scene that is the end.

:func:`run_live` runs the loop over a scene whose obstacles may move
(:func:`planners.scene.scene_at`) and returns a :class:`LiveTrace`, a record of every
step (pose, wheel rates, mode, status, the moving obstacles' offsets) with the events and
decisions, savable as JSON (:meth:`LiveTrace.to_json`).
"""

from __future__ import annotations

__all__ = [
    "LIVE_STATUSES",
    "MAX_DURATION_S",
    "LiveEvent",
    "LiveOptions",
    "LiveState",
    "LiveStep",
    "LiveTrace",
    "live_space",
    "live_start",
    "live_step",
    "record_step",
    "run_live",
]

import dataclasses
import json
import math
from typing import Any

import numpy as np
import numpy.typing as npt
import shapely
from shapely import Polygon

from kinematics.robot import RobotParams
from kinematics.wheel_limits import WheelLimits
from planners.bug._context import (
    FOLLOW,
    REACHED,
    SEEK,
    UNREACHABLE,
    BugParams,
    BugState,
    Decision,
    evolve,
    sigma_on_ring,
)
from planners.bug.tangent_bug import initial_state
from planners.bug.tangent_bug import step as bug_step
from planners.bug.trace import arclength
from planners.memo import Memo
from planners.scene import Scene, scene_at
from planners.scene.motion import motion_offset
from planners.space.border import ring_geometry
from planners.space.expansion import (
    DEFAULT_ARC_STEP,
    ConfigurationSpace,
    configuration_space,
)

FloatArray = npt.NDArray[np.float64]
Point = tuple[float, float]

LIVE_STATUSES = ("driving", "blocked", "waiting", "reached", "unreachable")
MAX_DURATION_S = 120.0
"""How long :func:`run_live` drives at most [s] unless told otherwise."""
"""``"driving"`` (moving or turning), ``"blocked"`` (an obstacle reached the robot),
``"waiting"`` (no way to the goal in the scene as it is now), and the final two."""

_TURN_EPS = 1e-9  # [rad] a vertex turning less than this is no corner
_SAME = 1e-12  # [m] pieces shorter than this are no motion
_GRID = 48  # candidate distances per step (largest feasible one is taken)
# Braking is planned with this share of the allowed speed change per step: the slack
# absorbs rounding, so the last steps before a stop stay within the wheel limits.
_PLAN = 0.99


@dataclasses.dataclass(frozen=True)
class LiveOptions:
    """How the live robot drives (section 9.7).

    Examples
    --------
    >>> LiveOptions().dt
    0.05
    """

    dt: float = 0.05
    """Control period [s] (section 9.7.1: "typically 0.05 seconds")."""
    leave_rule: str = "tangent_bug"
    """DSB leave rule, as for the planner."""
    sensor_range: float | None = None
    """R [m]; None: the scene's."""
    max_speed: float = 0.5
    """Largest speed of the centre [m/s]."""
    max_acceleration: float = 1.0
    """Largest change of the centre's velocity vector per second [m/s^2]."""
    max_turn_rate: float = math.pi / 2
    """Largest turn rate of the differential robot's rotations [rad/s]."""
    max_angular_acceleration: float = 2.0 * math.pi
    """Largest angular acceleration of those rotations [rad/s^2]."""
    wheels: WheelLimits | None = None
    """Wheel limits (section 9.7.3); None: the scene robot's (unlimited if it has none)."""
    arc_step: float = DEFAULT_ARC_STEP
    """Resolution of the disk model's arcs [rad], as for the planner."""

    def __post_init__(self) -> None:
        for name in ("dt", "max_speed", "max_acceleration", "max_turn_rate"):
            value = getattr(self, name)
            if not (value > 0 and math.isfinite(value)):
                raise ValueError(f"{name} must be a positive number, got {value!r}")


@dataclasses.dataclass(frozen=True)
class LiveEvent:
    """Something that happened during a live run, in words and at a time."""

    t: float
    """Time [s]."""
    kind: str
    """The planner's ``"hit"``, ``"leave"``, ``"local_min"``, or ``"blocked"``,
    ``"clear"``, ``"emergency_stop"``, ``"waiting"``, ``"replanned"``, ``"reached"``."""
    at: Point
    """Where the robot was [m]."""
    label: str
    """Figure label (``"H1"``, ``"M3"``, ...) or a short word."""
    text: str = ""
    """What happened, in a sentence."""


@dataclasses.dataclass(frozen=True, eq=False)
class LiveState:
    """The live robot after a step: where it is, what it commands, what it has in mind."""

    t: float
    """Time [s]."""
    pose: tuple[float, float, float]
    """(x, y, phi) [m, m, rad]; phi unwrapped."""
    velocity: tuple[float, float, float]
    """Commanded world velocity (xdot, ydot, phidot) over the last dt."""
    rates: tuple[float, ...]
    """Commanded wheel rates over the last dt [rad/s] (eq. 9.5 / 9.9)."""
    bug: BugState
    """The DSB memory (mode, followed border, M, d_followed), as the planner keeps it."""
    plan: FloatArray
    """The rest of the piece the last decision chose, (K, 2) from the robot [m]; empty
    when a decision is due."""
    plan_mode: str = SEEK
    """Mode of that piece."""
    aim: Point | None = None
    """Where the robot heads while seeking (r_next), None while following."""
    key: Any = None
    """What of the scene the plan was made for (obstacles, walls, goal, R)."""
    status: str = "driving"
    """One of :data:`LIVE_STATUSES`."""
    message: str = ""
    """The status in words, for the panel."""
    events: tuple[LiveEvent, ...] = ()
    """Events of this step."""
    decisions: tuple[Decision, ...] = ()
    """The planner's decisions taken in this step."""
    travelled: float = 0.0
    """Distance driven [m]."""
    turn_left: float = 0.0
    """Differential robot: rotation still to make before driving on [rad]."""
    over_limit: bool = False
    """This step's command exceeded a wheel limit (an emergency stop)."""


def live_start(scene: Scene, phi: float | None = None) -> LiveState:
    """Put the robot at the scene's start, at rest, seeking the goal.

    ``phi`` is the initial heading [rad]; None: facing the goal.

    Examples
    --------
    >>> from planners.scene import Scene
    >>> s = live_start(Scene(obstacles=(), start=(0, 0), goal=(0, 3)))
    >>> s.pose, s.status
    ((0.0, 0.0, 1.5707963267948966), 'driving')
    """
    x, y = float(scene.start[0]), float(scene.start[1])
    if phi is None:
        gx, gy = scene.goal
        phi = math.atan2(gy - y, gx - x) if (gx, gy) != (x, y) else math.pi / 2
    k = 2 if scene.robot.kind == "differential" else 3
    return LiveState(
        t=0.0,
        pose=(x, y, float(phi)),
        velocity=(0.0, 0.0, 0.0),
        rates=(0.0,) * k,
        bug=initial_state((x, y)),
        plan=np.zeros((0, 2)),
    )


# --------------------------------------------------------------------------- the step


def live_step(
    state: LiveState,
    scene: Scene,
    options: LiveOptions | None = None,
    memo: Memo | None = None,
) -> LiveState:
    """Advance the live robot by one control period in ``scene`` as it is now (pure).

    Parameters
    ----------
    state
        The robot after the previous step (:func:`live_start` for the first).
    scene
        The scene at this moment (static: :func:`planners.scene.scene_at`); its goal,
        obstacles and walls are what the robot senses now. The robot's start is ignored.
    options
        Control period, limits, leave rule; None means ``LiveOptions()``.
    memo
        The caller's memo for the configuration spaces (None: computed afresh).

    Returns
    -------
    LiveState
        The robot ``options.dt`` later.

    Examples
    --------
    >>> from planners.scene import Scene
    >>> scene = Scene(obstacles=(), start=(0, 0), goal=(1, 0))
    >>> s = live_start(scene)
    >>> while s.status == "driving":
    ...     s = live_step(s, scene)
    >>> s.status, s.pose[:2], round(s.t, 2)
    ('reached', (1.0, 0.0), 2.55)
    """
    options = options if options is not None else LiveOptions()
    dt = options.dt
    state = _evolve_live(state, events=(), decisions=(), over_limit=False)
    if state.status in (REACHED, UNREACHABLE):
        return _rest(state, dt)
    space = live_space(scene, options, memo)
    x = np.array(state.pose[:2])
    if bool(space.contains_blocked(x)[0]):
        return _blocked(state, space, dt)
    if state.status == "blocked":
        state = _evolve_live(
            state,
            status="driving",
            message="",
            plan=np.zeros((0, 2)),
            events=(
                *state.events,
                _event(state, "clear", "the way is clear again: driving on"),
            ),
        )
    key = _key(scene, options)
    old = None
    if key != state.key:
        old = state.plan
        state = _changed(state, space, x, key)
    if state.status == "waiting":
        return _rest(state, dt)
    before = state
    if len(state.plan) == 0 and state.turn_left == 0.0:
        state = _decide(state, scene, space, options)
        if state.status != "driving":
            return _rest(state, dt)
    out = _drive(state, scene, space, options)
    if out.over_limit and old is not None and not _at_rest(before):
        # The new decision turns too sharply for the speed the robot has: brake along
        # the way it was going (if still free) and decide again at the next step.
        braked = _brake_along(before, old, space, _Budget(scene, options))
        if braked is not None:
            return braked
    return out


def _evolve_live(state: LiveState, **changes: Any) -> LiveState:
    return dataclasses.replace(state, **changes)


def live_space(
    scene: Scene, options: LiveOptions, memo: Memo | None
) -> ConfigurationSpace:
    """Build the configuration space of the scene now, as :func:`planners.plan_all` builds it."""
    return configuration_space(
        scene.obstacles,
        scene.robot.radius,
        scene.expansion,
        scene.boundary,
        options.arc_step,
        extra_points=[scene.start, scene.goal],
        memo=memo,
    )


def _key(scene: Scene, options: LiveOptions) -> Any:
    return (
        scene.obstacles,
        scene.boundary,
        scene.robot.radius,
        scene.expansion,
        tuple(scene.goal),
        _range(scene, options),
        options.leave_rule,
    )


def _range(scene: Scene, options: LiveOptions) -> float:
    return float(
        options.sensor_range if options.sensor_range is not None else scene.sensor_range
    )


def _params(scene: Scene, options: LiveOptions) -> BugParams:
    return BugParams(
        goal=(float(scene.goal[0]), float(scene.goal[1])),
        sensor_range=_range(scene, options),
        leave_rule=options.leave_rule,
    )


def _event(state: LiveState, kind: str, text: str, label: str = "") -> LiveEvent:
    x, y, _ = state.pose
    return LiveEvent(state.t, kind, (x, y), label or kind, text)


def _at_rest(state: LiveState) -> bool:
    return not any(state.velocity)


def _rest(state: LiveState, dt: float) -> LiveState:
    """Stay where the robot is for one period (it is at rest)."""
    return _evolve_live(
        state,
        t=state.t + dt,
        velocity=(0.0, 0.0, 0.0),
        rates=(0.0,) * len(state.rates),
    )


def _blocked(state: LiveState, space: ConfigurationSpace, dt: float) -> LiveState:
    """Stop at once: an obstacle reached the robot; say so, say so, forget the piece."""
    names = ", ".join(space.blockers(state.pose[:2])) or "an obstacle"
    message = f"stopped: obstacle reached the robot ({names})"
    moving = not _at_rest(state)
    events = ()
    if state.status != "blocked":
        events = (_event(state, "blocked", message, "stop"),)
    out = _rest(state, dt)
    return _evolve_live(
        out,
        status="blocked",
        message=message,
        plan=np.zeros((0, 2)),
        turn_left=0.0,
        events=events,
        over_limit=moving,
    )


# --------------------------------------------------------------------------- deciding


def _changed(
    state: LiveState, space: ConfigurationSpace, x: FloatArray, key: Any
) -> LiveState:
    """Carry the DSB memory over to where the robot is now (the sensed scene changed)."""
    bug = _resume(state.bug, space, x, state.travelled)
    status, message = state.status, state.message
    if status == "waiting":
        status, message = "driving", ""
        bug = evolve(initial_state(x), travelled=state.travelled, steps=bug.steps)
    return _evolve_live(
        state,
        bug=bug,
        key=key,
        status=status,
        message=message,
        plan=np.zeros((0, 2)),  # chosen for another scene: decide again from here
        turn_left=0.0,
    )


def _resume(
    bug: BugState, space: ConfigurationSpace, x: FloatArray, s: float
) -> BugState:
    """Re-anchor the DSB memory at ``x`` in a new configuration space.

    Ring numbers belong to a configuration space: the blocking and the followed border
    are found again by their obstacle. Where the followed border cannot be found under
    the robot, it seeks the goal afresh from here (its memory of M is lost).
    """
    geo = ring_geometry(space)
    blocking = _ring_of(space, bug.blocking_obstacle) if bug.blocking >= 0 else -1
    bug = evolve(
        bug,
        position=(float(x[0]), float(x[1])),
        travelled=s,
        cache=None,
        moves=(),
        events=(),
        decisions=(),
        blocking=blocking,
        left=None,
    )
    if bug.mode in (REACHED, UNREACHABLE):
        # The piece it drove was the last one, for the old scene: not there yet.
        bug = evolve(bug, mode=SEEK, follow=None, reason=None, terminated=None)
    f = bug.follow
    if bug.mode != FOLLOW or f is None:
        return bug
    ring = _ring_of(space, f.obstacle)
    tol = 10.0 * space.eps
    if f.target is None:
        sigma = sigma_on_ring(geo, x, ring, tol)
        if sigma is not None:
            f = evolve(f, ring=ring, sigma=sigma, exit_sigma=None)
            return evolve(bug, follow=f)
    else:
        t_sigma = sigma_on_ring(geo, np.asarray(f.target), ring, tol)
        if t_sigma is not None:
            f = evolve(f, ring=ring, target_sigma=t_sigma, exit_sigma=None)
            return evolve(bug, follow=f)
    return evolve(bug, mode=SEEK, follow=None, blocking=-1)


def _ring_of(space: ConfigurationSpace, obstacle: int | None) -> int:
    """Find the border ring of ``space`` nearest obstacle ``obstacle`` (1-based; None: walls)."""
    rings = space.rings
    if not rings:
        return -1
    if obstacle is None:
        if space.boundary is None:
            return -1
        target = space.boundary.boundary
    elif 0 < obstacle <= len(space.expanded):
        target = space.expanded[obstacle - 1].exterior
    else:
        return -1
    lines = [shapely.LinearRing(r) for r in rings]
    return int(np.argmin(shapely.distance(np.asarray(lines, dtype=object), target)))


def _decide(
    state: LiveState, scene: Scene, space: ConfigurationSpace, options: LiveOptions
) -> LiveState:
    """Take one DSB decision where the robot is (the planner's step) and keep its piece."""
    if state.bug.mode not in (SEEK, FOLLOW):  # the last piece ended the run
        return _final(state, state.bug)
    bug = bug_step(state.bug, space, _params(scene, options))
    moves = [m for m in bug.moves if len(m.path) > 1]
    events = tuple(
        LiveEvent(state.t, e.kind, e.at, e.label, _event_text(e.kind, e.label))
        for e in bug.events
    )
    if moves:
        plan = np.vstack(
            [np.asarray(moves[0].path[:1])] + [np.asarray(m.path[1:]) for m in moves]
        )
        plan = _dedupe(plan)
    else:
        plan = np.zeros((0, 2))
    out = _evolve_live(
        state,
        bug=bug,
        plan=plan if len(plan) > 1 else np.zeros((0, 2)),
        plan_mode=moves[0].mode if moves else bug.mode,
        aim=moves[0].aim if moves else None,
        events=state.events + events,
        decisions=state.decisions + bug.decisions,
    )
    if len(out.plan) > 1:
        return out
    return _final(out, bug)


def _final(state: LiveState, bug: BugState) -> LiveState:
    """End or wait: the decision moved nothing (goal reached, or no way now)."""
    if bug.mode == REACHED:
        return _evolve_live(
            state,
            status=REACHED,
            message="reached the goal",
            events=(
                *state.events,
                _event(state, "reached", "reached the goal", "goal"),
            ),
        )
    if bug.mode == UNREACHABLE:
        text = f"waiting: no way to the goal now ({bug.reason})"
        return _evolve_live(
            state,
            status="waiting",
            message=text,
            events=(*state.events, _event(state, "waiting", text, "wait")),
        )
    return (
        state  # a step that did not move but goes on (a mode switch): drive next time
    )


def _event_text(kind: str, label: str) -> str:
    return {
        "hit": f"{label}: an obstacle blocks the way to the goal",
        "leave": f"{label}: leaves the obstacle toward the goal",
        "local_min": f"{label}: local minimum, follows the boundary",
    }.get(kind, label)


def _dedupe(path: FloatArray) -> FloatArray:
    keep = np.ones(len(path), dtype=bool)
    keep[1:] = np.hypot(*np.diff(path, axis=0).T) > _SAME
    return path[keep]


# --------------------------------------------------------------------------- driving


class _Budget:
    """Per-step limits of the robot's centre and wheels, from the options and the robot."""

    def __init__(self, scene: Scene, options: LiveOptions) -> None:
        robot = scene.robot
        self.params = RobotParams(
            kind="differential" if robot.kind == "differential" else "holonomic",
            wheel_radius=robot.wheel_radius,
            wheel_distance=robot.wheel_distance,
        )
        wheels = options.wheels
        if wheels is None:
            wheels = WheelLimits(
                max_rate=robot.max_wheel_rate or math.inf,
                max_acceleration=robot.max_wheel_acceleration or math.inf,
            )
        self.wheels = wheels
        r, L, dt = robot.wheel_radius, robot.wheel_distance, options.dt
        self.dt = dt
        # Straight motion: every wheel's rate is at most |v| / r (eq. 9.5, 9.9).
        self.v_max = min(options.max_speed, r * wheels.max_rate)
        self.dv = min(options.max_acceleration, r * wheels.max_acceleration) * dt
        # Turning in place: every wheel's rate is L |phidot| / r.
        self.w_max = min(options.max_turn_rate, r * wheels.max_rate / L)
        self.dw = (
            min(options.max_angular_acceleration, r * wheels.max_acceleration / L) * dt
        )

    def rates(self, velocity: FloatArray, phi: float) -> FloatArray:
        return self.params.inverse(
            velocity[0], velocity[1], velocity[2], phi, check=False
        )

    def ok(self, rates: FloatArray, previous: FloatArray) -> bool:
        w = self.wheels
        tol = 1e-9
        return bool(
            np.all(np.abs(rates) <= w.max_rate * (1 + tol))
            and np.all(
                np.abs(rates - previous) <= w.max_acceleration * self.dt * (1 + tol)
            )
        )


def _brake_distance(u: float, end: float, dv: float, dt: float) -> float:
    """Distance covered after this step while braking by ``dv`` per step to <= ``end``."""
    n = max(math.ceil((u - end) / dv) - 1, 0) if u > end else 0
    return dt * (n * u - dv * n * (n + 1) / 2.0)


def _drive(
    state: LiveState, scene: Scene, space: ConfigurationSpace, options: LiveOptions
) -> LiveState:
    budget = _Budget(scene, options)
    plan = state.plan
    if len(plan) < 2:
        return _rest(state, options.dt)
    if budget.params.kind == "differential":
        return _drive_differential(state, budget)
    return _drive_holonomic(state, budget)


def _plan_free(space: ConfigurationSpace, plan: FloatArray) -> bool:
    """Whether a piece is in free space (it may run along the border, within eps)."""
    line = shapely.LineString(plan)
    if space.free is not None:
        return bool(space.derive(_grown_free).covers(line))
    return not bool(space.derive(_shrunk_blocked).intersects(line))


def _grown_free(space: ConfigurationSpace) -> Any:
    assert space.free is not None
    return space.free.buffer(space.eps)


def _shrunk_blocked(space: ConfigurationSpace) -> Any:
    return space.merged.buffer(-space.eps)


def _point_at(plan: FloatArray, cum: FloatArray, s: float) -> FloatArray:
    if s >= cum[-1]:
        return plan[-1].copy()
    i = int(np.searchsorted(cum, s, side="right")) - 1
    i = min(max(i, 0), len(plan) - 2)
    f = (s - cum[i]) / (cum[i + 1] - cum[i])
    return plan[i] + f * (plan[i + 1] - plan[i])


def _rest_of(plan: FloatArray, cum: FloatArray, s: float) -> FloatArray:
    """Return the piece after arclength ``s`` (starting at that point)."""
    if s >= cum[-1]:
        return np.zeros((0, 2))
    i = int(np.searchsorted(cum, s, side="right"))
    return _dedupe(np.vstack([_point_at(plan, cum, s)[None, :], plan[i:]]))


def _cut(plan: FloatArray, cum: FloatArray, s: float) -> FloatArray:
    """Return the piece up to arclength ``s``."""
    i = int(np.searchsorted(cum, s, side="left"))
    return _dedupe(np.vstack([plan[:i], _point_at(plan, cum, s)[None, :]]))


def _turns(plan: FloatArray) -> FloatArray:
    """Turn angle at each interior vertex of the piece [rad], shape (K - 2,)."""
    d = np.diff(plan, axis=0)
    a = np.arctan2(d[:, 1], d[:, 0])
    return np.abs((np.diff(a) + math.pi) % (2 * math.pi) - math.pi)


def _drive_holonomic(state: LiveState, budget: _Budget) -> LiveState:
    """Move along the piece by the largest distance the limits allow (heading held)."""
    plan, dt = state.plan, budget.dt
    cum = arclength(plan)
    turns = _turns(plan)
    # Where the piece turns by theta, the velocity vector turns too: slow to dv / theta.
    caps = [(float(cum[-1]), 0.0)] + [
        (float(cum[j + 1]), 0.5 * budget.dv / t)
        for j, t in enumerate(turns)
        if t > _TURN_EPS
    ]
    v_prev = np.asarray(state.velocity[:2])
    r_prev = np.asarray(state.rates)
    phi = state.pose[2]
    speed = float(np.hypot(*v_prev))
    hi = min(budget.v_max, speed + budget.dv) * dt
    best = None
    for d in _candidates(hi, max(speed - budget.dv, 0.0) * dt):
        d = min(float(d), float(cum[-1]))  # noqa: PLW2901 - clipped candidate
        if not _can_stop(d / dt, d, caps, budget):
            continue
        p = _point_at(plan, cum, d)
        v = np.array([*(p - plan[0]) / dt, 0.0])
        rates = budget.rates(v, phi)
        if budget.ok(rates, r_prev):
            best = (d, p, v, rates)
            break
    if best is None:
        return _over(state, budget)
    d, p, v, rates = best
    p, rest = _advance(state, budget, plan, d, phi)
    return _moved(
        state,
        budget,
        rest=rest,
        pose=(float(p[0]), float(p[1]), phi),
        velocity=v,
        rates=rates,
        d=d,
    )


def _candidates(hi: float, lo: float) -> FloatArray:
    """Distances to try, largest first: the band the speed can reach, then below it."""
    lo = min(lo, hi)
    return np.concatenate(
        [np.linspace(hi, lo, _GRID + 1), np.linspace(lo, 0.0, _GRID + 1)[1:]]
    )


def _can_stop(
    u: float, d: float, caps: list[tuple[float, float]], budget: _Budget
) -> bool:
    """Whether, after moving ``d`` at ``u``, the robot can still meet every speed cap."""
    for at, cap in caps:
        ahead = at - d
        if ahead < -_SAME:
            if u > cap + 1e-12 and at > 0:
                return False  # this step passes the corner faster than its cap
            continue
        if _brake_distance(u, cap, _PLAN * budget.dv, budget.dt) > ahead + 1e-12:
            return False
    return True


def _moved(
    state: LiveState,
    budget: _Budget,
    *,
    rest: FloatArray,
    pose: tuple[float, float, float],
    velocity: FloatArray,
    rates: FloatArray,
    d: float = 0.0,
    turn_left: float = 0.0,
) -> LiveState:
    return _evolve_live(
        state,
        t=state.t + budget.dt,
        pose=pose,
        velocity=(float(velocity[0]), float(velocity[1]), float(velocity[2])),
        rates=tuple(float(r) for r in rates),
        plan=rest,
        travelled=state.travelled + d,
        turn_left=turn_left,
    )


def _advance(
    state: LiveState, budget: _Budget, plan: FloatArray, d: float, phi: float
) -> tuple[FloatArray, FloatArray]:
    """Return the point ``d`` along ``plan`` and the rest of the piece after it."""
    cum = arclength(plan)
    rest = _rest_of(plan, cum, d)
    if len(rest) < 2 or d >= cum[-1] - _SAME:
        return plan[-1].copy(), np.zeros((0, 2))
    return _point_at(plan, cum, d), rest


def _over(state: LiveState, budget: _Budget) -> LiveState:
    """No command keeps the wheels within their limits: stop now and say so."""
    text = "emergency stop: no command within the wheel limits"
    out = _rest(state, budget.dt)
    # The piece stays: the robot drives on along it from rest (its DSB memory is at the
    # piece's end).
    return _evolve_live(
        out,
        events=(*state.events, _event(state, "emergency_stop", text, "stop")),
        over_limit=True,
    )


def _wrap(a: float) -> float:
    return (a + math.pi) % (2.0 * math.pi) - math.pi


def _drive_differential(state: LiveState, budget: _Budget) -> LiveState:
    """Section 9.7.2: turn in place at each corner, then drive straight (or backwards)."""
    plan, phi = state.plan, state.pose[2]
    if state.turn_left != 0.0:
        return _rotate(state, budget)
    seg = plan[1] - plan[0]
    ahead = math.atan2(seg[1], seg[0])
    forward = _wrap(ahead - phi)
    backward = _wrap(ahead + math.pi - phi)
    turn = forward if abs(forward) <= abs(backward) else backward
    moving = state.velocity[0] != 0.0 or state.velocity[1] != 0.0
    if abs(turn) > _TURN_EPS and not moving:
        return _rotate(_evolve_live(state, turn_left=turn), budget)
    if abs(turn) > _TURN_EPS:
        # Still rolling at the slow speed it arrived with: come to rest, then turn.
        zero = np.zeros(len(state.rates))
        if not budget.ok(zero, np.asarray(state.rates)):
            return _over(state, budget)
        return _moved(
            state,
            budget,
            rest=plan,
            pose=state.pose,
            velocity=np.zeros(3),
            rates=zero,
        )
    # Drive the first segment: a corner (or the piece's end) is where it must stop.
    return _translate(state, budget, plan[:2], phi)


def _translate(
    state: LiveState, budget: _Budget, leg: FloatArray, phi: float
) -> LiveState:
    dt = budget.dt
    length = float(np.hypot(*(leg[1] - leg[0])))
    caps = [(length, 0.0)]
    speed = float(np.hypot(*state.velocity[:2]))
    hi = min(budget.v_max * dt, (speed + budget.dv) * dt, length)
    r_prev = np.asarray(state.rates)
    for d in _candidates(hi, min(max(speed - budget.dv, 0.0) * dt, hi)):
        d = float(d)  # noqa: PLW2901
        if not _can_stop(d / dt, d, caps, budget):
            continue
        p = leg[0] + (d / length) * (leg[1] - leg[0]) if d < length else leg[1].copy()
        v = np.array([*(p - leg[0]) / dt, 0.0])
        rates = budget.rates(v, phi)
        if budget.ok(rates, r_prev):
            cum = arclength(state.plan)
            rest = _rest_of(state.plan, cum, d) if d < length else state.plan[1:]
            if len(rest) < 2:
                rest = np.zeros((0, 2))
            return _moved(
                state,
                budget,
                rest=rest,
                pose=(float(p[0]), float(p[1]), phi),
                velocity=v,
                rates=rates,
                d=d,
            )
    return _over(state, budget)


def _rotate(state: LiveState, budget: _Budget) -> LiveState:
    """Turn in place toward ``turn_left`` (theta_1 = theta_2), braking to stop on it."""
    dt, left = budget.dt, state.turn_left
    sign = 1.0 if left > 0 else -1.0
    w = abs(state.velocity[2])
    hi = min(budget.w_max, w + budget.dw) * dt
    x, y, phi = state.pose
    r_prev = np.asarray(state.rates)
    caps = [(abs(left), 0.0)]
    top = min(hi, abs(left))
    for a in _candidates(top, min(max(w - budget.dw, 0.0) * dt, top)):
        a = float(a)  # noqa: PLW2901
        if not _can_stop_rot(a / dt, a, caps, budget):
            continue
        v = np.array([0.0, 0.0, sign * a / dt])
        rates = budget.rates(v, phi)
        if budget.ok(rates, r_prev):
            remaining = left - sign * a
            if abs(remaining) <= _TURN_EPS:
                remaining = 0.0
            return _moved(
                state,
                budget,
                rest=state.plan,
                pose=(x, y, phi + sign * a),
                velocity=v,
                rates=rates,
                turn_left=remaining,
            )
    return _over(state, budget)


def _brake_along(
    state: LiveState, old: FloatArray, space: ConfigurationSpace, budget: _Budget
) -> LiveState | None:
    """Slow down as fast as the wheels allow, along the old piece or the old turn.

    None when that is not possible (the old piece is blocked now, or no braking command
    keeps the wheels within their limits): the caller's emergency stop stands.
    """
    dt, r_prev = budget.dt, np.asarray(state.rates)
    x, y, phi = state.pose
    speed = float(np.hypot(*state.velocity[:2]))
    if speed > 0.0:
        if len(old) < 2:
            return None
        cum = arclength(old)
        # Only the way to where it can stop needs to be free (with one more step).
        stop = speed * dt + _brake_distance(speed, 0.0, budget.dv, dt) + speed * dt
        if not _plan_free(space, _cut(old, cum, min(stop, float(cum[-1])))):
            return None
        for d in np.linspace(0.0, min(speed * dt, float(cum[-1])), _GRID + 1):
            p = _point_at(old, cum, float(d))
            v = np.array([*(p - old[0]) / dt, 0.0])
            rates = budget.rates(v, phi)
            if budget.ok(rates, r_prev):
                return _moved(
                    state,
                    budget,
                    rest=np.zeros((0, 2)),
                    pose=(float(p[0]), float(p[1]), phi),
                    velocity=v,
                    rates=rates,
                    d=float(d),
                )
        return None
    w = state.velocity[2]
    for a in np.linspace(0.0, abs(w) * dt, _GRID + 1):
        v = np.array([0.0, 0.0, math.copysign(float(a) / dt, w)])
        rates = budget.rates(v, phi)
        if budget.ok(rates, r_prev):
            return _moved(
                state,
                budget,
                rest=np.zeros((0, 2)),
                pose=(x, y, phi + float(v[2]) * dt),
                velocity=v,
                rates=rates,
            )
    return None


def _can_stop_rot(
    w: float, a: float, caps: list[tuple[float, float]], budget: _Budget
) -> bool:
    for at, cap in caps:
        if _brake_distance(w, cap, _PLAN * budget.dw, budget.dt) > at - a + 1e-12:
            return False
    return True


# --------------------------------------------------------------------------- the run


@dataclasses.dataclass(frozen=True)
class LiveStep:
    """One control period of a live run, as recorded (what the app replays)."""

    t: float
    """Time at the end of the period [s]."""
    pose: tuple[float, float, float]
    """(x, y, phi) [m, m, rad]."""
    velocity: tuple[float, float, float]
    """Commanded world velocity over the period."""
    rates: tuple[float, ...]
    """Commanded wheel rates over the period [rad/s]."""
    mode: str
    """DSB mode: ``"seek"`` or ``"follow"`` (of the piece driven)."""
    status: str
    """One of :data:`LIVE_STATUSES`."""
    aim: Point | None
    """r_next while seeking, else None."""
    offsets: tuple[Point, ...]
    """Translation of each moving obstacle (scene order of the motions) [m]."""
    message: str = ""
    """The status in words."""
    over_limit: bool = False
    """The command exceeded a wheel limit (an emergency stop)."""
    obstacles: tuple[Polygon, ...] = ()
    """The obstacles as the robot sensed them in this period (moving ones where they
    were, the user's edits as they were) [m]."""
    goal: Point | None = None
    """The goal in this period [m] (the user may drag it)."""


@dataclasses.dataclass(frozen=True, eq=False)
class LiveTrace:
    """A whole live run: every step, the events and the decisions (section 9.6)."""

    start: tuple[float, float, float]
    """Pose at t = 0."""
    steps: tuple[LiveStep, ...]
    """One record per control period."""
    events: tuple[LiveEvent, ...]
    """Everything that happened, in order."""
    decisions: tuple[Decision, ...]
    """The planner's decisions (Fig. 9.15), in order."""
    status: str
    """The last step's status."""
    dt: float
    """Control period [s]."""
    robot_kind: str
    """``"holonomic"`` or ``"differential"``."""
    motions: tuple[int, ...] = ()
    """The obstacles that move (indices), in the order of :attr:`LiveStep.offsets`."""

    @property
    def times(self) -> FloatArray:
        """(T + 1,) times of :attr:`poses` [s]."""
        return np.array([0.0] + [s.t for s in self.steps])

    @property
    def poses(self) -> FloatArray:
        """(T + 1, 3) poses, the start first."""
        return np.array([self.start] + [s.pose for s in self.steps], dtype=np.float64)

    @property
    def path(self) -> FloatArray:
        """(T + 1, 2) positions [m]."""
        return self.poses[:, :2]

    @property
    def rates(self) -> FloatArray:
        """(T, k) commanded wheel rates, one row per period [rad/s]."""
        return np.array([s.rates for s in self.steps], dtype=np.float64)

    @property
    def duration(self) -> float:
        """Time of the last step [s]."""
        return self.steps[-1].t if self.steps else 0.0

    def step_at(self, t: float) -> LiveStep | None:
        """Return the record of the period in force at time ``t`` (None before the first)."""
        k = math.floor(float(t) / self.dt + 1e-9) - 1
        if k < 0 or not self.steps:
            return None
        return self.steps[min(k, len(self.steps) - 1)]

    def to_dict(self) -> dict[str, Any]:
        """Return a JSON-ready mapping of the run (:meth:`to_json`)."""
        return {
            "format": "live-trace-1",
            "dt": self.dt,
            "robot_kind": self.robot_kind,
            "status": self.status,
            "start": list(self.start),
            "motions": list(self.motions),
            "steps": _steps_json(self.steps),
            "events": [dataclasses.asdict(e) for e in self.events],
            "decisions": [
                {
                    "s": d.s,
                    "position": list(d.position),
                    "mode": d.mode,
                    "box": d.box,
                    "chosen": d.chosen,
                    "d_goal": d.d_goal,
                }
                for d in self.decisions
            ],
        }

    def to_json(self) -> str:
        """Return the run as JSON text (what the app's Save offers)."""
        return json.dumps(self.to_dict(), indent=1) + "\n"


def _steps_json(steps: tuple[LiveStep, ...]) -> list[dict[str, Any]]:
    """Each step as a mapping; its obstacles only where they differ from the step before."""
    out, before = [], None
    for s in steps:
        row = {
            f.name: getattr(s, f.name)
            for f in dataclasses.fields(s)
            if f.name != "obstacles"
        }
        if s.obstacles != before:
            row["obstacles"] = [
                [[float(x), float(y)] for x, y in o.exterior.coords[:-1]]
                for o in s.obstacles
            ]
            before = s.obstacles
        out.append(row)
    return out


def run_live(
    scene: Scene,
    options: LiveOptions | None = None,
    *,
    duration: float = MAX_DURATION_S,
    memo: Memo | None = None,
    phi: float | None = None,
) -> LiveTrace:
    """Drive the live robot in ``scene`` (obstacles moving as its motions say) until it ends.

    The loop ends when the goal is reached, when a static scene leaves it waiting (the
    goal is unreachable), or after ``duration`` seconds.

    Examples
    --------
    >>> from shapely import Polygon
    >>> from planners.scene import Scene
    >>> square = Polygon([(0, 0), (2, 0), (2, 2), (0, 2)])
    >>> trace = run_live(Scene(obstacles=(square,), start=(-1, 1), goal=(3, 1)))
    >>> trace.status, [e.label for e in trace.events]
    ('reached', ['H1', 'D1', 'goal'])
    """
    options = options if options is not None else LiveOptions()
    memo = memo if memo is not None else Memo()
    state = live_start(scene, phi)
    steps: list[LiveStep] = []
    events: list[LiveEvent] = []
    decisions: list[Decision] = []
    n = math.ceil(duration / options.dt)
    for _ in range(n):
        t0 = state.t
        now = scene_at(scene, t0)
        state = live_step(state, now, options, memo)
        steps.append(record_step(state, scene, now, t0))
        events.extend(state.events)
        decisions.extend(state.decisions)
        if state.status == REACHED or (state.status == "waiting" and not scene.motions):
            break
    status = state.status if state.status != "waiting" or scene.motions else UNREACHABLE
    return LiveTrace(
        start=live_start(scene, phi).pose,
        steps=tuple(steps),
        events=tuple(events),
        decisions=tuple(decisions),
        status=status,
        dt=options.dt,
        robot_kind=scene.robot.kind,
        motions=tuple(m.obstacle for m in scene.motions),
    )


def record_step(state: LiveState, scene: Scene, sensed: Scene, t0: float) -> LiveStep:
    """Return the record of the step that led to ``state`` (what :class:`LiveTrace` keeps).

    ``scene`` is the scene with its motions, ``sensed`` the scene the step was given
    (:func:`planners.scene.scene_at` at ``t0``, the step's start time).
    """
    return LiveStep(
        t=state.t,
        pose=state.pose,
        velocity=state.velocity,
        rates=state.rates,
        mode=state.plan_mode if state.bug.mode in (SEEK, FOLLOW) else state.bug.mode,
        status=state.status,
        aim=state.aim,
        offsets=tuple(motion_offset(m, t0) for m in scene.motions),
        message=state.message,
        over_limit=state.over_limit,
        obstacles=sensed.obstacles,
        goal=(float(sensed.goal[0]), float(sensed.goal[1])),
    )
