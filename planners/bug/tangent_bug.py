"""Distance-sensor-based path planning (section 9.6): TangentBug.

The robot is a point in the configuration space of :mod:`planners.space.expansion`. It knows
where it is and where the goal g is, but not the map: every decision uses only what its
360-degree range sensor of range R sees (:mod:`planners.bug.sensor`): the visible border
within R and the discontinuity points O_i. Two modes alternate (the chapter's Fig. 9.15;
Kamon, Rivlin and Rimon 1998; Choset et al. 2005, section 2.3).

Goal seeking (motion to goal)
    If nothing blocks the segment toward g within min(R, d(r, g)), move straight toward
    g. Otherwise move toward the O_i that minimises the heuristic distance
    d(r, O_i) + d(O_i, g) among the candidates: the O_i closer to the goal than the robot
    (Kamon et al.), and the O_i the robot is already heading for as long as heading for
    it still brings the robot closer to the goal. The choice is re-made as the view
    changes. A local minimum M (Fig. 9.17) is where no candidate is left ("all of the
    vertex points available to the robot would force the robot to move away from the
    goal"), or where the O_i the robot heads for, still the best of all, stops bringing
    it closer (Choset et al.: "the direction that minimizes the heuristic begins to
    increase d(x, q_goal)"). While seeking, d(r, g) never increases.
Boundary following
    From M the robot follows the border that blocks the goal direction, continuing the
    direction of its last motion: if it is not on that border yet, it heads for the end
    of the visible piece of it on that side, then walks along the border itself (it may
    touch it: obstacles are already expanded). When the leave rule holds it goes back to
    goal seeking.

Leave rules (``leave_rule``):

``"tangent_bug"`` (default; Kamon et al., Choset et al.)
    d_followed is the least distance to the goal of any point of the followed border the
    robot has sensed since M (and d(M, g)); d_reach the least distance to the goal of the
    followed border in view now (0 if the goal itself is in view within R). The robot
    leaves as soon as d_reach < d_followed, that is, as soon as it *sees* part of the
    obstacle closer to the goal than anything seen before, and heads for that point until
    it is closer to the goal than d_followed. With R = 0 this is the chapter's rule.
``"chapter"`` (Fig. 9.15 and 9.18)
    The robot leaves when it *is* closer to the goal than M: d(r, g) < d(M, g). It ignores
    what it sees, so it walks on along the far side of an obstacle until it is level with
    M, where TangentBug would already have cut across toward the point it saw. Where the
    border leads downhill from M (into a pocket toward the goal) the inequality holds at
    once, so it only counts once the robot has been farther from the goal than M.

Termination: ``"reached"`` when the robot is at the goal (it ends exactly on it);
``"unreachable"`` when boundary following goes all the way round the followed border
without meeting the leave rule and that border separates robot and goal (the robot has
walked the whole border, so it knows that it is closed around the goal or around itself).
Should a full round end otherwise (the leave rule never met although the border does not
enclose the goal), the robot walks on to the border's point closest to the goal and
leaves there (Bug1's rule), so a reachable goal is never given up. A hard cap on the
number of steps, derived from the size of the scene and never met on the lecture
scenarios, stops a run that would not end and says so (status ``"unreachable"``, reason
"gave up ... not a proof").

Stepping is event-driven: the robot moves straight until the next point where its
decision can change (the obstacle ahead coming into range, arriving at O_i, the closest
approach to the goal) or at most a fraction of R; where the decision changes within a
move, the sensor locates the switch point: first on either side of where geometry puts
the most common switches (the chosen range point turning into a corner, the border
beyond the chosen corner coming into view), which are then found with two readings,
else by a bisection. Where two choices are equally
good the continuous algorithm would chatter between them; the robot then moves like a
sliding mode, along the combination of both headings that keeps them equal. A run is
:func:`run`, a loop over the pure :func:`step`; it returns a :class:`BugTrace` that the
app can scrub, and that answers what the robot saw anywhere along the run
(:meth:`BugTrace.sensing_at`), where it was heading (:meth:`BugTrace.aim_at`) and on
what grounds: every decision is a :class:`Decision` record (the box of Fig. 9.15, the
O_i with d(r, O_i) and d(O_i, g), r_next, d_reach and d_followed), in
:attr:`BugTrace.decisions` and :meth:`BugTrace.decision_at`.

The code follows the flowchart: goal seeking (:mod:`planners.bug._seek`) and boundary
following (:mod:`planners.bug._follow`) never import each other and hand over by the
mode of the state they return; the leave rule is one object (:mod:`planners.bug._leave`);
the records and the context a run derives from (configuration space, parameters) are in
:mod:`planners.bug._context`. This module is the entry point: the step, the run and the
trace.

References
----------
I. Kamon, E. Rivlin and E. Rimon, "TangentBug: A range-sensor-based navigation algorithm",
International Journal of Robotics Research 17(9), 934-953, 1998.
H. Choset, K. Lynch, S. Hutchinson, G. Kantor, W. Burgard, L. Kavraki and S. Thrun,
Principles of Robot Motion, MIT Press, 2005, section 2.3 (Tangent Bug).
"""

from __future__ import annotations

__all__ = [
    "LEAVE_RULES",
    "BugEvent",
    "BugParams",
    "BugState",
    "BugTrace",
    "Candidate",
    "Decision",
    "Follow",
    "Move",
    "initial_state",
    "plan_tangent_bug",
    "run",
    "step",
]

import bisect
import dataclasses
import functools
import math
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from planners.bug._context import (
    FOLLOW,
    LEAVE_RULES,
    REACHED,
    SEEK,
    UNREACHABLE,
    BugEvent,
    BugParams,
    BugState,
    Candidate,
    Context,
    Decision,
    FloatArray,
    Follow,
    Move,
    Point,
    make_context,
)
from planners.bug._follow import boundary_following_step
from planners.bug._leave import leave_rule
from planners.bug._seek import goal_seeking_step
from planners.bug.sensor import Sensing, sense
from planners.bug.trace import WalkedPath, arclength, simplify_walk
from planners.space.expansion import ConfigurationSpace
from planners.space.geometry import as_point as _pt

# --------------------------------------------------------------------------- the run


@dataclasses.dataclass(frozen=True, eq=False)
class BugTrace(WalkedPath):
    """A whole DSB run: the path, its modes and events, and what the robot saw along it."""

    status: str
    """``"reached"`` or ``"unreachable"`` (``"invalid"`` from :func:`planners.plan_all`)."""
    path: FloatArray
    """The robot's path, shape (N, 2) [m]; for ``"unreachable"`` the walk until it gave up."""
    length: float | None
    """Path length when the goal is reached [m], else None."""
    reason: str | None
    """Why the goal was not reached, in words; None when it was."""
    events: tuple[BugEvent, ...]
    """Hit, leave and local-minimum points in order."""
    modes: tuple[str, ...]
    """Mode of each path segment (N - 1 entries): ``"seek"`` or ``"follow"``."""
    aims: tuple[Point | None, ...]
    """For each path segment, the point the robot was heading for while seeking (the
    chosen O_i, or the goal), None while following a border."""
    travelled: float
    """Length of ``path`` [m]."""
    start: Point
    """Start [m]."""
    goal: Point
    """Goal [m]."""
    sensor_range: float
    """R [m]."""
    leave_rule: str
    """The leave rule used."""
    steps: int
    """Number of :func:`step` calls."""
    terminated: str
    """``"goal"``, ``"loop"`` (went round an enclosing border), ``"step_cap"`` or ``"invalid"``."""
    decisions: tuple[Decision, ...] = ()
    """Every sensing and decision step in order (the boxes of Fig. 9.15 with their
    grounds): what the app draws as the robot's choice, and what an explanation shows."""
    cspace: ConfigurationSpace | None = None
    """The configuration space the robot moved in (for :meth:`sensing_at`)."""
    planner: str = "dsb"
    """The planner's short name."""
    ms: float = 0.0
    """Compute time [ms], set by :func:`planners.plan_all` (shared expansion included)."""

    @functools.cached_property
    def _decision_s(self) -> list[float]:
        return [d.s for d in self.decisions]

    def decision_at(self, s: float) -> Decision | None:
        """Return the decision in force after travelling ``s`` metres (clamped to the run).

        The last one taken at or before ``s``: while seeking its ``chosen`` point is
        :meth:`aim_at`; while following it has none (the chapter's robot chooses no O_i
        then). None for an ``"invalid"`` trace, which has no decisions.

        Examples
        --------
        >>> from shapely import Polygon
        >>> from planners.space.expansion import configuration_space
        >>> space = configuration_space((Polygon([(0, 0), (2, 0), (2, 2), (0, 2)]),), 0.0)
        >>> trace = run(space, (-1.0, 1.0), BugParams(goal=(3.0, 1.0), sensor_range=math.inf))
        >>> d = trace.decision_at(0.5)
        >>> d.box, d.chosen, [(c.point, c.valid) for c in d.candidates]
        ('choose_O_i', (0.0, 2.0), [((0.0, 0.0), True), ((0.0, 2.0), True)])
        >>> d.chosen == trace.aim_at(0.5)
        True
        >>> trace.decision_at(trace.travelled).box
        'reached'
        """
        if not self.decisions:
            return None  # "invalid": the robot never looked
        i = bisect.bisect_right(self._decision_s, float(s)) - 1
        return self.decisions[max(i, 0)]

    def sensing_at(self, s: float) -> Sensing:
        """Return what the robot's sensor saw after travelling ``s`` metres.

        The sensor is pure, so this recomputes it at :meth:`position_at`; the result is
        what the robot used wherever it took a decision.
        """
        if self.cspace is None:
            raise ValueError("this trace carries no configuration space")
        return sense(self.cspace, self.position_at(s), self.sensor_range)


# --------------------------------------------------------------------------- the step


def _context(cspace: ConfigurationSpace, params: BugParams) -> Context:
    """Build the context of a run: ``params`` on ``cspace`` (about 55 us).

    Built per run, not kept on the configuration space: it depends on the goal, and a
    goal dragged over a fixed configuration space would leave one behind per position.
    What it reads of the border (:func:`planners.space.border.ring_geometry`) is kept there.
    """
    return make_context(cspace, params, leave_rule(params.leave_rule))


def _step(ctx: Context, state: BugState) -> BugState:
    """One step of the mode the robot is in (the two boxes of Fig. 9.15)."""
    if state.mode == SEEK:
        return goal_seeking_step(ctx, state)
    return boundary_following_step(ctx, state)


def initial_state(start: npt.ArrayLike) -> BugState:
    """Put the robot at ``start``, seeking the goal.

    Examples
    --------
    >>> initial_state((0, 0)).mode
    'seek'
    """
    x, y = np.asarray(start, dtype=np.float64).reshape(2)
    return BugState(position=(float(x), float(y)), mode=SEEK)


def step(state: BugState, cspace: ConfigurationSpace, params: BugParams) -> BugState:
    """Advance the robot by one event-driven step (pure: same inputs, same output).

    Parameters
    ----------
    state
        The current state; a final state (``"reached"``, ``"unreachable"``) is returned as is.
    cspace
        The configuration space the robot moves in (it only ever *senses* it).
    params
        Goal, sensor range and leave rule.

    Returns
    -------
    BugState
        The next state; ``moves`` and ``events`` say what this step did.

    Examples
    --------
    >>> from shapely import Polygon
    >>> from planners.space.expansion import configuration_space
    >>> space = configuration_space((Polygon([(0, 0), (1, 0), (1, 1), (0, 1)]),), 0.0)
    >>> params = BugParams(goal=(3.0, 0.5), sensor_range=10.0)
    >>> state = step(initial_state((-1.0, 0.5)), space, params)
    >>> state.mode, [e.label for e in state.events], state.moves[0].aim  # for a corner
    ('seek', ['H1'], (0.0, 1.0))

    References
    ----------
    I. Kamon, E. Rivlin and E. Rimon, "TangentBug: A range-sensor-based navigation
    algorithm", International Journal of Robotics Research 17(9), 1998.
    """
    if state.mode not in (SEEK, FOLLOW):
        return state
    return _step(_context(cspace, params), state)


def run(
    cspace: ConfigurationSpace, start: npt.ArrayLike, params: BugParams
) -> BugTrace:
    """Run TangentBug from ``start`` until the goal is reached or proven unreachable.

    Parameters
    ----------
    cspace
        Configuration space; ``start`` and ``params.goal`` must be free (the caller checks).
    start
        Start, shape (2,) [m].
    params
        Goal, sensor range R and leave rule.

    Returns
    -------
    BugTrace
        Path, mode of each piece, events, and :meth:`BugTrace.sensing_at`.

    Examples
    --------
    >>> from shapely import Polygon
    >>> from planners.space.expansion import configuration_space
    >>> space = configuration_space((Polygon([(0, 0), (2, 0), (2, 2), (0, 2)]),), 0.0)
    >>> trace = run(space, (-1.0, 1.0), BugParams(goal=(3.0, 1.0), sensor_range=math.inf))
    >>> trace.status, round(trace.length, 6)  # over a corner, along a side, down: optimal
    ('reached', 4.828427)
    >>> trace.path.tolist()
    [[-1.0, 1.0], [0.0, 2.0], [2.0, 2.0], [3.0, 1.0]]
    >>> [e.label for e in trace.events]
    ['H1', 'D1']

    References
    ----------
    I. Kamon, E. Rivlin and E. Rimon, "TangentBug: A range-sensor-based navigation
    algorithm", International Journal of Robotics Research 17(9), 1998.
    """
    ctx = _context(cspace, params)
    state = initial_state(start)
    log = _Log([np.asarray(state.position, dtype=np.float64)], [], [], [], [])
    while state.mode in (SEEK, FOLLOW) and state.steps < ctx.max_steps:
        state = _step(ctx, state)
        log.add(state)
    path, modes, aims = simplify_walk(
        np.asarray(log.points, dtype=np.float64).reshape(-1, 2), log.modes, log.aims
    )
    travelled = (
        float(np.hypot(*np.diff(path, axis=0).T).sum()) if len(path) > 1 else 0.0
    )
    status, length, reason, terminated = _outcome(state, travelled)
    return BugTrace(
        status=status,
        path=path,
        length=length,
        reason=reason,
        events=tuple(log.events),
        modes=tuple(modes),
        aims=tuple(aims),
        travelled=travelled,
        start=_pt(np.asarray(start, dtype=np.float64)),
        goal=_pt(ctx.goal),
        sensor_range=ctx.radius,
        leave_rule=ctx.rule,
        steps=state.steps,
        terminated=terminated,
        decisions=_snapped(log.decisions, arclength(path)),
        cspace=cspace,
    )


class _Log(NamedTuple):
    """What :func:`run` gathers step by step (lists it appends to, owned by one run)."""

    points: list[FloatArray]  # the path's vertices, without repeats
    modes: list[str]  # the mode of each segment
    aims: list[Point | None]  # ... and its aim
    events: list[BugEvent]
    decisions: list[Decision]

    def add(self, state: BugState) -> None:
        """Append what the step that led to ``state`` did."""
        points = self.points
        for move in state.moves:
            for p in move.path[1:]:
                if math.hypot(*(p - points[-1])) > 0.0:
                    points.append(np.asarray(p, dtype=np.float64))
                    self.modes.append(move.mode)
                    self.aims.append(move.aim)
        self.events.extend(state.events)
        self.decisions.extend(state.decisions)


def _outcome(
    state: BugState, travelled: float
) -> tuple[str, float | None, str | None, str]:
    """Return the run's status, length, reason and termination from its last state."""
    if state.mode == REACHED:
        return REACHED, travelled, None, "goal"
    if state.mode == UNREACHABLE:
        return UNREACHABLE, None, state.reason, state.terminated or "loop"
    reason = (
        f"gave up after {state.steps} steps (the step cap for this scene) without reaching "
        "the goal; this is not a proof that the goal is unreachable"
    )
    return UNREACHABLE, None, reason, "step_cap"


def _snapped(decisions: list[Decision], cum: FloatArray) -> tuple[Decision, ...]:
    """Put the decisions taken at a path vertex exactly at its arclength ``cum``.

    A decision's ``s`` sums the moves before it, the trace's arclength the simplified
    path's segments: they differ in the last bits, and at a vertex
    :meth:`BugTrace.decision_at` and :meth:`BugTrace.aim_at` must agree.
    """
    if len(cum) < 2:  # the robot did not move
        return tuple(decisions)
    # A few dozen decisions: plain Python beats numpy's per-call cost here.
    at = cum.tolist()
    tol = 1e-9 * max(1.0, at[-1])
    out = []
    for d in decisions:
        j = min(max(bisect.bisect_left(at, d.s), 1), len(at) - 1)
        lower, upper = at[j - 1], at[j]
        nearest = lower if abs(lower - d.s) <= abs(upper - d.s) else upper
        if nearest != d.s and abs(nearest - d.s) <= tol:
            d = dataclasses.replace(d, s=nearest)  # noqa: PLW2901 - the snapped copy
        out.append(d)
    return tuple(out)


def plan_tangent_bug(
    cspace: ConfigurationSpace,
    start: npt.ArrayLike,
    goal: npt.ArrayLike,
    sensor_range: float = math.inf,
    leave_rule: str = "tangent_bug",
) -> BugTrace:
    """Plan with the distance-sensor-based method (TangentBug) of section 9.6.

    Parameters
    ----------
    cspace
        Configuration space (expanded obstacles, shrunk walls).
    start, goal
        Points of shape (2,) [m].
    sensor_range
        R [m]; ``math.inf`` for unlimited.
    leave_rule
        ``"tangent_bug"`` or ``"chapter"`` (see the module docstring).

    Returns
    -------
    BugTrace
        ``status`` ``"reached"``, ``"unreachable"`` or ``"invalid"`` (start or goal blocked).

    Examples
    --------
    >>> from shapely import Polygon
    >>> from planners.space.expansion import configuration_space
    >>> space = configuration_space((Polygon([(0, 0), (2, 0), (2, 2), (0, 2)]),), 0.0)
    >>> plan_tangent_bug(space, (1, 1), (3, 1)).status
    'invalid'
    """
    s = np.asarray(start, dtype=np.float64).reshape(2)
    g = np.asarray(goal, dtype=np.float64).reshape(2)
    blocked = cspace.contains_blocked(np.array([s, g]))
    if blocked.any():
        which = "start" if blocked[0] else "goal"
        return BugTrace(
            status="invalid",
            path=np.zeros((0, 2)),
            length=None,
            reason=f"the {which} is not in free space",
            events=(),
            modes=(),
            aims=(),
            travelled=0.0,
            start=_pt(s),
            goal=_pt(g),
            sensor_range=float(sensor_range),
            leave_rule=leave_rule,
            steps=0,
            terminated="invalid",
            cspace=cspace,
        )
    return run(
        cspace,
        s,
        BugParams(goal=_pt(g), sensor_range=float(sensor_range), leave_rule=leave_rule),
    )
