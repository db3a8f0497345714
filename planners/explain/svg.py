"""The simplified visibility graph's procedure, step by step (section 9.5).

The chapter builds the SVG in steps:

1. add the line segments to the obstacle vertices that are also *common tangents*;
2. for each obstacle,

   (a) if both start and goal lie outside its convex hull, join start and goal to the
       visible convex hull vertices, and add each hull edge that connects a visible vertex
       to a common tangent vertex;
   (b) if start or goal lies inside its convex hull, join start and goal to the visible
       vertices of the obstacle itself, and add each obstacle edge that connects a
       visible vertex to a common tangent vertex;

3. end of procedure.

The planner (:func:`planners.visibility.simplified_visibility_graph`) keeps the segments
that are tangent at both ends, which realises these steps and a little more.
:func:`explain_svg` takes the planner's own segments, with the builder's reason for each
end (:func:`planners.visibility.svg_node_reasons`), and tags every one with the step that puts
it there. Where the planner keeps a segment the chapter's words do not mention, the tag
says so and why (:data:`ADDITIONS`).
"""

from __future__ import annotations

__all__ = ["ADDITIONS", "RULES", "ObstacleHull", "SvgTag", "explain_svg"]

import dataclasses
from collections.abc import Callable
from types import MappingProxyType
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt
import shapely
from shapely import LineString, Point, Polygon

from planners.api import plan_all
from planners.explain._steps import (
    Explanation,
    Lazy,
    Step,
    as_segments,
    keep_going,
    marks,
    point_mark,
    ring_segments,
)
from planners.visibility import GraphArrays, svg_node_reasons

if TYPE_CHECKING:
    from planners.registry import PlanOptions
    from planners.scene import Scene
    from planners.space.expansion import ConfigurationSpace

FloatArray = npt.NDArray[np.float64]

RULES = ("1", "2a", "2b", "pocket", "mouth", "pinch", "wall", "direct")
"""Tags of SVG segments: the chapter's steps 1, 2(a), 2(b), then :data:`ADDITIONS`."""

ADDITIONS = MappingProxyType(
    {
        "pocket": "a convex vertex inside the obstacle's convex hull (in a pocket): a "
        "shortest path can wrap around it, so the segments tangent there are kept, although "
        "the chapter's steps only name hull vertices",
        "mouth": "the hull edge across the pocket is tangent at both ends, so a path passing "
        "the pocket may run along it; it is kept although step 2(b) names obstacle edges only",
        "pinch": "two obstacles touch at this vertex (after expansion): a path may squeeze "
        "past it around either of them, so every segment it sees is kept",
        "wall": "the walls, shrunk by the robot's radius, block the robot like an obstacle: a "
        "path may have to turn around one of their corners",
        "direct": "the start sees the goal: the straight segment between them is the "
        "shortest path of all",
    }
)
"""What the planner adds to the chapter's words, and why, in a student's words."""


@dataclasses.dataclass(frozen=True)
class ObstacleHull:
    """One obstacle of the configuration space with its convex hull (Fig. 9.11)."""

    index: int
    """Position in the explanation's list of obstacles (:attr:`Explanation.data`),
    which follows the scene's numbering; :attr:`SvgTag.obstacle` refers to it."""
    merged_index: int
    """Position of its shape in :attr:`ConfigurationSpace.merged`."""
    name: str
    """``"obstacle 2"``, or ``"obstacles 2 and 3"`` when they merged after expansion."""
    hull: tuple[tuple[float, float], ...]
    """The convex hull's vertices, counter-clockwise [m]."""
    holds: tuple[str, ...]
    """Which of ``"start"``, ``"goal"`` lie strictly inside the hull (decides 2a vs 2b)."""

    @property
    def rule(self) -> str:
        """``"2b"`` when start or goal lies inside the hull, else ``"2a"``."""
        return "2b" if self.holds else "2a"


@dataclasses.dataclass(frozen=True)
class SvgTag:
    """One SVG segment and the step of the procedure that puts it there."""

    a: tuple[float, float]
    """One end [m] (the start or goal first when one is)."""
    b: tuple[float, float]
    """Other end [m]."""
    rule: str
    """One of :data:`RULES`."""
    obstacle: int | None
    """Index of the obstacle (:class:`ObstacleHull`) the rule is applied to; for step 1
    the first of the two; None for the walls and start-to-goal."""
    why: str
    """One line saying why the segment is there, in the chapter's numbering."""
    end: str | None = None
    """``"start"`` or ``"goal"`` when the segment joins one of them to a vertex."""


@dataclasses.dataclass(frozen=True, eq=False)
class _Setting:
    """What the tagging reads: the configuration space, the graph, its hulls."""

    cspace: ConfigurationSpace
    arrays: GraphArrays
    reasons: tuple[str, ...]
    owner: tuple[int, ...]  # per graph node: obstacle index, -1 start/goal, -2 walls
    hulls: tuple[ObstacleHull, ...]
    hull_polygons: tuple[Any, ...]  # Polygon, or a line for a degenerate obstacle
    outlines: _Outlines
    nodes: dict[tuple[float, float], int]  # the graph's first node at each point


class _Outlines:
    """Each obstacle's and each hull's outline, and the band ``tol`` around it.

    Made once per explanation, when first asked for, and prepared: a segment is tested
    against them once per SVG edge, and an outline of 10,000 vertices buffered again
    for every edge took minutes. The same geometry as made for each edge, so the same
    answers.
    """

    def __init__(
        self, comps: list[Polygon], hull_polygons: tuple[Any, ...], tol: float
    ) -> None:
        self._shapes = {"obstacle": comps, "hull": hull_polygons}
        self.tol = tol
        self._outlines: dict[tuple[str, int], Any] = {}
        self._bands: dict[tuple[str, int], Any] = {}

    def outline(self, kind: str, k: int) -> Any:
        """Return the boundary of obstacle (``kind="obstacle"``) or hull ``k``, prepared."""
        key = (kind, k)
        if key not in self._outlines:
            outline = self._shapes[kind][k].boundary
            shapely.prepare(outline)
            self._outlines[key] = outline
        return self._outlines[key]

    def band(self, kind: str, k: int) -> Any:
        """Return that outline buffered by ``tol``, prepared for ``covers``."""
        key = (kind, k)
        if key not in self._bands:
            band = self.outline(kind, k).buffer(self.tol)
            shapely.prepare(band)
            self._bands[key] = band
        return self._bands[key]

    def near(self, kind: str, k: int, points: list[tuple[float, float]]) -> bool:
        """Tell if every point lies within ``tol`` of the outline.

        On the prepared outline (an index of its edges): the distance to the nearest
        edge, as an unprepared one finds it by looking at all of them.
        """
        outline = self.outline(kind, k)
        return bool(np.all(shapely.dwithin(outline, shapely.points(points), self.tol)))

    def covers(
        self, kind: str, k: int, a: tuple[float, float], b: tuple[float, float]
    ) -> bool:
        """Tell if the band around the outline covers the segment a-b."""
        return bool(self.band(kind, k).covers(LineString([a, b])))


def explain_svg(
    scene: Scene,
    options: PlanOptions | None = None,
    *,
    plans: dict[str, Any] | None = None,
    abandoned: Callable[[], bool] | None = None,
) -> Explanation:
    """Explain the SVG of ``scene``: every segment tagged with its step (section 9.5).

    Parameters
    ----------
    scene
        The scene.
    options
        Planner settings (arc step of the disk model); None for the defaults.
    plans
        Results of :func:`planners.plan_all` for this scene and options that include
        ``"svg"``, when the caller has them; None computes them.
    abandoned
        Asked between pieces of the work (1,024 nodes or edges each): True gives the
        explanation up (:class:`~planners.explain.Abandoned` is raised).

    Returns
    -------
    Explanation
        Steps: the hulls, step 1 per pair of obstacles, step 2(a) or 2(b) per obstacle
        (start and goal first, then the obstacle's edges), the additions, and the
        shortest path (step 3). ``tags`` holds one :class:`SvgTag` per SVG segment;
        ``data`` the :class:`ObstacleHull` records.

    Examples
    --------
    >>> import planners
    >>> scene = planners.load_scene("static_scenarios/05_pocket_start.json")
    >>> svg = planners.explain_svg(scene)
    >>> [h.holds for h in svg.data]  # the start lies in the U's hull: step 2(b) there
    [(), ('start',)]
    >>> sorted({t.rule for t in svg.tags if "start" in t.why})
    ['2a', '2b']
    >>> print(svg.steps[-1].text)  # doctest: +ELLIPSIS
    Step 3: end of procedure. The shortest path through the SVG is ... m long.
    """
    plans = plans if plans is not None else plan_all(scene, ("svg",), options)
    result = plans["svg"]
    title = "Simplified visibility graph (section 9.5)"
    cspace = plans.get("cspace")
    if result.status == "invalid" or cspace is None:
        return Explanation("svg", title, (Step("svg:invalid", _invalid(result)),))
    setting = _setting(scene, cspace, plans, abandoned)
    tags = _tags(setting, abandoned)
    groups = _groups(setting, tags)
    # Every group's segments in the steps' order: what the steps before step k added.
    added = _tag_segments([t for _, _, group, _ in groups for t in group])
    ends = np.cumsum([0, *(len(group) for _, _, group, _ in groups)])

    def step(k: int) -> Step:
        if k == 0:
            return _hull_step(setting)
        if k <= len(groups):
            return _rule_step(setting, groups[k - 1], added[: ends[k - 1]])
        return _end_step(setting, tags, result)

    steps = Lazy(len(groups) + 2, step)
    return Explanation("svg", title, steps, tags, setting.hulls)


def _invalid(result: Any) -> str:
    return f"Nothing to build: {getattr(result, 'reason', None) or 'the scene is not plannable'}."


# --------------------------------------------------------------------------- the setting


def _setting(
    scene: Scene,
    cspace: ConfigurationSpace,
    plans: dict[str, Any],
    abandoned: Callable[[], bool] | None = None,
) -> _Setting:
    # The planner's own graph, and why each of its nodes may carry segments (the
    # border's flags its builder read): the SVG is not built a second time.
    arrays = plans["svg"].arrays
    points, reasons = svg_node_reasons(cspace, scene.start, scene.goal)
    if not np.array_equal(points, arrays.points):
        raise RuntimeError("the SVG's nodes are not this scene's")
    # In the scene's order of obstacles (a merged one where its first obstacle is).
    geoms = list(cspace.merged.geoms)
    members = _members(cspace, geoms, abandoned)
    order = sorted(range(len(geoms)), key=lambda m: members[m][:1] or [0])
    comps = [geoms[m] for m in order]
    hull_polygons = tuple(shapely.convex_hull(c) for c in comps)
    hulls = tuple(
        ObstacleHull(
            k,
            order[k],
            _component_name(members[order[k]]),
            _ccw(hull_polygons[k]),
            _holds(hull_polygons[k], scene, cspace.eps),
        )
        for k in range(len(comps))
    )
    owner = _owners(cspace, arrays, comps, abandoned)
    outlines = _Outlines(comps, hull_polygons, 10 * cspace.eps)
    nodes: dict[tuple[float, float], int] = {}
    for n, p in enumerate(map(tuple, arrays.points.tolist())):
        nodes.setdefault(p, n)
    return _Setting(
        cspace, arrays, reasons, owner, hulls, hull_polygons, outlines, nodes
    )


def _members(
    cspace: ConfigurationSpace,
    comps: list[Polygon],
    abandoned: Callable[[], bool] | None = None,
) -> list[list[int]]:
    """Return, per component, the scene's obstacles (1-based) that expanded into it.

    An expanded obstacle is in a component when their intersection has an area. Only
    the expanded obstacles an index names as intersecting the component are tried (the
    others have no intersection at all): a scene of 500 obstacles tried every pair,
    about a third of a second. ``abandoned`` is asked before each component.
    """
    expanded = list(cspace.expanded)
    index = shapely.STRtree(expanded)
    out = []
    for comp in comps:
        keep_going(abandoned)
        touching = sorted(index.query(comp, predicate="intersects").tolist())
        out.append([k + 1 for k in touching if expanded[k].intersection(comp).area > 0])
    return out


def _component_name(members: list[int]) -> str:
    names = [str(k) for k in members]
    if len(names) == 1:
        return f"obstacle {names[0]}"
    return "merged obstacle " + "+".join(names)


def _ccw(hull: Any) -> tuple[tuple[float, float], ...]:
    if not isinstance(hull, Polygon):  # a degenerate obstacle: no area
        return tuple(map(tuple, np.asarray(hull.coords).tolist()))
    ring = shapely.orient_polygons(hull).exterior.coords[:-1]
    return tuple((float(x), float(y)) for x, y in ring)


def _holds(hull: Any, scene: Scene, eps: float) -> tuple[str, ...]:
    """Which of start and goal lie strictly inside ``hull`` (farther than eps from its edge)."""
    inside = []
    for label, p in (("start", scene.start), ("goal", scene.goal)):
        point = Point(p)
        if hull.contains(point) and hull.exterior.distance(point) > eps:
            inside.append(label)
    return tuple(inside)


def _owners(
    cspace: ConfigurationSpace,
    arrays: GraphArrays,
    comps: list[Polygon],
    abandoned: Callable[[], bool] | None = None,
) -> tuple[int, ...]:
    """Per graph node: the obstacle whose border it lies on, -1 start/goal, -2 walls.

    A node lies on the border of the first obstacle (in ``comps``' order) that is
    closest to it within 10 eps. Each border is measured only to the nodes an index of
    the points names within twice that (the others are farther anyway): a scene of 500
    obstacles and 7,500 nodes measured every pair, about a second. ``abandoned`` is
    asked before every :data:`_CHUNK` nodes measured.
    """
    pts = np.asarray(shapely.points(arrays.points), dtype=object)
    index = shapely.STRtree(pts)
    reach = 10 * cspace.eps
    owner = np.full(len(arrays.points), -2, dtype=np.intp)
    best = np.full(len(arrays.points), np.inf)
    for k, comp in enumerate(comps):
        border = comp.boundary
        found = index.query(border, predicate="dwithin", distance=2.0 * reach)
        for lo in range(0, len(found), _CHUNK):
            keep_going(abandoned)
            near = found[lo : lo + _CHUNK]
            d = np.asarray(shapely.distance(border, pts[near]), dtype=np.float64)
            closer = (d <= reach) & (d < best[near])
            owner[near[closer]], best[near[closer]] = k, d[closer]
    owner[arrays.start] = owner[arrays.goal] = -1
    return tuple(owner.tolist())


# --------------------------------------------------------------------------- tagging

_CHUNK = 1024
"""Nodes measured, or edges tagged, between two questions to ``abandoned`` (on the
10,000-vertex circle about a tenth of a second's work)."""


def _tags(
    setting: _Setting, abandoned: Callable[[], bool] | None
) -> tuple[SvgTag, ...]:
    """Tag every edge of the SVG, asking ``abandoned`` every :data:`_CHUNK` edges."""
    tags: list[SvgTag] = []
    for e in range(setting.arrays.edges):
        if e % _CHUNK == 0:
            keep_going(abandoned)
        tags.append(_tag(setting, e))
    return tuple(tags)


def _tag(setting: _Setting, e: int) -> SvgTag:
    """Tag edge ``e`` of the SVG with the step that puts it there."""
    arrays = setting.arrays
    u, v = int(arrays.i[e]), int(arrays.j[e])
    if setting.owner[v] == -1 and setting.owner[u] != -1:
        u, v = v, u  # start or goal first
    a, b = _xy(arrays, u), _xy(arrays, v)
    ou, ov = setting.owner[u], setting.owner[v]
    if ou == -1 and ov == -1:
        return SvgTag(a, b, "direct", None, _addition("direct", "start and goal"))
    if -2 in (ou, ov):
        return SvgTag(a, b, "wall", None, _addition("wall", "the walls"))
    if "pinch" in (setting.reasons[u], setting.reasons[v]):
        k = ov if setting.reasons[v] == "pinch" else ou
        return SvgTag(a, b, "pinch", k, _addition("pinch", setting.hulls[k].name))
    if ou == -1:
        return _end_tag(setting, a, b, ov, arrays.kind(u))
    if ou != ov:
        return _tangent_tag(setting, a, b, ou, ov)
    return _same_obstacle_tag(setting, a, b, ou)


def _xy(arrays: GraphArrays, n: int) -> tuple[float, float]:
    x, y = arrays.points[n].tolist()
    return (float(x), float(y))


def _addition(rule: str, name: str) -> str:
    return f"Added ({name}): {ADDITIONS[rule]}."


def _on_hull(setting: _Setting, k: int, *points: tuple[float, float]) -> bool:
    """Whether every point lies on obstacle k's hull boundary (within the tolerance)."""
    return setting.outlines.near("hull", k, list(points))


def _along(
    outlines: _Outlines,
    kind: str,
    k: int,
    a: tuple[float, float],
    b: tuple[float, float],
) -> bool:
    """Whether the segment a-b runs along an outline (its middle and ends on it)."""
    mid = (0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1]))
    return outlines.near(kind, k, [a, mid, b]) and outlines.covers(kind, k, a, b)


def _end_tag(
    setting: _Setting, a: tuple[float, float], b: tuple[float, float], k: int, end: str
) -> SvgTag:
    hull = setting.hulls[k]
    if hull.holds:
        where = " and ".join(hull.holds)
        verb = "lies" if len(hull.holds) == 1 else "lie"
        why = (
            f"Step 2(b): the {where} {verb} inside {hull.name}'s convex hull, so the "
            f"{end} connects to the visible vertices of {hull.name} itself, not of its hull."
        )
        return SvgTag(a, b, "2b", k, why, end)
    if _on_hull(setting, k, b):
        why = (
            f"Step 2(a): start and goal lie outside {hull.name}'s convex hull, so the "
            f"{end} connects to its visible convex hull vertices."
        )
        return SvgTag(a, b, "2a", k, why, end)
    return SvgTag(a, b, "pocket", k, _addition("pocket", hull.name), end)


def _tangent_tag(
    setting: _Setting, a: tuple[float, float], b: tuple[float, float], k: int, m: int
) -> SvgTag:
    first, second = sorted((k, m))
    why = (
        f"Step 1: a common tangent of {setting.hulls[first].name} and "
        f"{setting.hulls[second].name}: the line through it touches both at its ends "
        "without entering either there."
    )
    return SvgTag(a, b, "1", first, why)


def _same_obstacle_tag(
    setting: _Setting, a: tuple[float, float], b: tuple[float, float], k: int
) -> SvgTag:
    hull = setting.hulls[k]
    obstacle_edge = _along(setting.outlines, "obstacle", k, a, b)
    hull_edge = _along(setting.outlines, "hull", k, a, b)
    if hull.holds and obstacle_edge:
        why = (
            f"Step 2(b): an edge of {hull.name} itself (start or goal lies inside its "
            "hull) joining two of its tangent vertices."
        )
        return SvgTag(a, b, "2b", k, why)
    if not hull.holds and hull_edge:
        why = (
            f"Step 2(a): a convex hull edge of {hull.name} from a visible vertex to a "
            "common tangent vertex."
        )
        return SvgTag(a, b, "2a", k, why)
    if hull.holds and hull_edge:
        return SvgTag(a, b, "mouth", k, _addition("mouth", hull.name))
    return SvgTag(a, b, "pocket", k, _addition("pocket", hull.name))


# --------------------------------------------------------------------------- the steps


def _tag_segments(tags: list[SvgTag] | tuple[SvgTag, ...]) -> FloatArray:
    return as_segments([(t.a, t.b) for t in tags])


def _hull_polylines(setting: _Setting, which: list[int] | None = None) -> FloatArray:
    idx = range(len(setting.hulls)) if which is None else which
    parts = [
        ring_segments(setting.hulls[k].hull)
        for k in idx
        if len(setting.hulls[k].hull) > 2
    ]
    return np.concatenate(parts) if parts else np.zeros((0, 2, 2))


def _hull_step(setting: _Setting) -> Step:
    inside = [h for h in setting.hulls if h.holds]
    if inside:
        said = "; ".join(
            f"the {' and '.join(h.holds)} inside {h.name}'s" for h in inside
        )
        text = (
            "Before step 1: the convex hull of each expanded obstacle (Fig. 9.11) decides "
            f"between steps 2(a) and 2(b): {said}."
        )
    else:
        text = (
            "Before step 1: the convex hull of each expanded obstacle (Fig. 9.11); start "
            "and goal lie outside every hull, so step 2(a) applies to all."
        )
    labels = tuple(
        (h.name + (" (2b)" if h.holds else " (2a)"), _label_at(h))
        for h in setting.hulls
    )
    focus = point_mark(
        "focus",
        [
            setting.arrays.points[setting.arrays.start],
            setting.arrays.points[setting.arrays.goal],
        ],
        labels=(
            ("start", _xy(setting.arrays, setting.arrays.start)),
            ("goal", _xy(setting.arrays, setting.arrays.goal)),
        ),
    )
    hull_mark = point_mark("hull", np.zeros((0, 2)), labels, _hull_polylines(setting))
    return Step("svg:hulls", text, marks(hull=hull_mark, focus=focus))


def _label_at(hull: ObstacleHull) -> tuple[float, float]:
    pts = np.asarray(hull.hull, dtype=np.float64).reshape(-1, 2)
    top = pts[np.argmax(pts[:, 1])]
    return (float(top[0]), float(top[1]))


_Group = tuple[str, str, list[SvgTag], list[int]]
"""One step of the procedure: (kind, text, its tags, the hulls it shows)."""


def _rule_step(setting: _Setting, group: _Group, done: FloatArray) -> Step:
    """Make the step that adds ``group``'s segments after those ``done`` before it."""
    kind, text, tags, hull_ids = group
    return Step(
        kind,
        text,
        marks(
            done=done,
            hull=_hull_polylines(setting, hull_ids),
            current=_tag_segments(tags),
            focus=point_mark("focus", _focus(setting, tags)),
        ),
        (("segments", str(len(tags))),),
    )


def _groups(setting: _Setting, tags: tuple[SvgTag, ...]) -> list[_Group]:
    """Return the steps in the procedure's order: (kind, text, tags, hulls to show).

    Tags are sorted into their groups in one pass (each group keeps the tags' order).
    """
    out: list[_Group] = []
    by_pair: dict[tuple[int, int], list[SvgTag]] = {}
    by_rule: dict[tuple[str, int | None], list[SvgTag]] = {}
    for t in tags:
        if t.rule == "1":
            by_pair.setdefault(_pair(setting, t), []).append(t)
        else:
            by_rule.setdefault((t.rule, t.obstacle), []).append(t)
    for pair in sorted(by_pair):
        group = by_pair[pair]
        names = [setting.hulls[k].name for k in pair]
        text = (
            f"Step 1: the common tangents of {names[0]} and {names[1]} "
            f"({len(group)} segment{'s' * (len(group) != 1)}): the line through each "
            "touches both obstacles at its ends without entering either there."
        )
        out.append(("svg:1", text, group, list(pair)))
    for hull in setting.hulls:
        out.extend(_obstacle_groups(hull, by_rule.get((hull.rule, hull.index), [])))
    for rule in ("pocket", "mouth", "pinch", "wall", "direct"):
        ks = sorted({k for r, k in by_rule if r == rule}, key=_none_first)
        for k in ks:
            group = by_rule[rule, k]
            out.append((f"svg:{rule}", group[0].why, group, [] if k is None else [k]))
    return out


def _none_first(k: int | None) -> int:
    return -1 if k is None else k


def _focus(setting: _Setting, group: list[SvgTag]) -> list[tuple[float, float]]:
    """Return the points a step is about.

    The start or goal it joins, the pocket or pinch vertices it adds; none for step 1
    and edges (the segments themselves tell).
    """
    points: list[tuple[float, float]] = []
    for t in group:
        if t.end is not None and t.rule in ("2a", "2b"):
            points.append(t.a)
        elif t.rule == "pocket" and t.obstacle is not None:
            points.extend(p for p in (t.a, t.b) if _in_pocket(setting, t.obstacle, p))
        elif t.rule == "pinch":
            points.extend(
                p
                for p in (t.a, t.b)
                if setting.reasons[_node_of(setting, p)] == "pinch"
            )
    return list(dict.fromkeys(points))


def _in_pocket(setting: _Setting, k: int, p: tuple[float, float]) -> bool:
    n = _node_of(setting, p)
    return setting.owner[n] == k and not _on_hull(setting, k, p)


def _node_of(setting: _Setting, p: tuple[float, float]) -> int:
    """Return the graph's node nearest ``p`` (the first at exactly ``p``, when one is)."""
    found = setting.nodes.get((float(p[0]), float(p[1])))
    if found is not None:
        return found
    return int(np.argmin(np.hypot(*(setting.arrays.points - np.asarray(p)).T)))


def _pair(setting: _Setting, tag: SvgTag) -> tuple[int, int]:
    ka = _owner_of(setting, tag.a)
    kb = _owner_of(setting, tag.b)
    first, second = sorted((ka, kb))
    return (first, second)


def _owner_of(setting: _Setting, p: tuple[float, float]) -> int:
    return setting.owner[_node_of(setting, p)]


def _obstacle_groups(hull: ObstacleHull, mine: list[SvgTag]) -> list[_Group]:
    """Return step 2's groups for one obstacle from its tags of its rule (2a or 2b)."""
    rule = hull.rule
    ends = [t for t in mine if t.end is not None]
    edges = [t for t in mine if t.end is None]
    out = []
    if ends:
        joined = sorted({t.end for t in ends if t.end is not None}, reverse=True)
        who = " and ".join(joined)
        verb = "connect" if len(joined) > 1 else "connects"
        if rule == "2a":
            text = (
                f"Step 2(a): start and goal lie outside {hull.name}'s convex hull, so "
                f"the {who} {verb} to its visible convex hull vertices."
            )
        else:
            inside = " and ".join(hull.holds)
            lies = "lie" if len(hull.holds) > 1 else "lies"
            text = (
                f"Step 2(b): the {inside} {lies} inside {hull.name}'s convex hull, so "
                f"the {who} {verb} to the visible vertices of {hull.name} itself, not "
                "of its hull."
            )
        out.append((f"svg:{rule}", text, ends, [hull.index]))
    if edges:
        if rule == "2a":
            text = (
                f"Step 2(a): the convex hull edges of {hull.name} that connect a visible "
                "vertex to a common tangent vertex."
            )
        else:
            text = (
                f"Step 2(b): the edges of {hull.name} itself that connect a visible "
                "vertex to a common tangent vertex."
            )
        out.append((f"svg:{rule}", text, edges, [hull.index]))
    return out


def _end_step(setting: _Setting, tags: tuple[SvgTag, ...], result: Any) -> Step:
    if result.status == "ok" and result.length is not None:
        text = (
            "Step 3: end of procedure. The shortest path through the SVG is "
            f"{result.length:.2f} m long."
        )
    else:
        text = f"Step 3: end of procedure. No path: {result.reason}."
    return Step(
        "svg:end",
        text,
        marks(done=_tag_segments(tags), path=_path_segments(result.path)),
        (("segments", str(len(tags))),),
    )


def _path_segments(path: Any) -> FloatArray:
    p = np.asarray(path, dtype=np.float64).reshape(-1, 2)
    if len(p) < 2:
        return np.zeros((0, 2, 2))
    return np.stack([p[:-1], p[1:]], axis=1)
