"""The 3-D scene: every node is created once, then :meth:`PlannerView.render` assigns properties.

Following viser's ``ViserUrdf.update_cfg`` and its performance notes, one layer is one
node: all edges of the visibility graph are one ``add_line_segments`` of shape (N, 2, 3),
all obstacle prisms are one mesh, and so on, so that a redraw during a drag is a handful
of property assignments inside one ``atomic()`` batch. Pools (vertex handles, labels)
only grow; unused members are hidden.

The functions at the top are pure (numpy and shapely only) and are tested as arrays.
"""

from __future__ import annotations

__all__ = [
    "EVENT_CROSS",
    "MAX_NUMBERED_OBSTACLES",
    "MAX_VERTEX_HANDLES",
    "STALE_RGB",
    "GizmoView",
    "Gizmos",
    "GraphEdges",
    "Labels",
    "PlannerView",
    "Segments",
    "SensingPicture",
    "circle_segments",
    "disk_mesh",
    "event_labels",
    "floor_bounds",
    "lift",
    "lift_segments",
    "live_keepouts",
    "marker_size",
    "path_to_segments",
    "polygon_to_mesh",
    "polygons_of",
    "prism_mesh",
    "rings_to_segments",
    "vertex_colors",
    "wall_mesh",
    "yaw_quaternion",
]

import contextlib
import functools
import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from typing import Any, Generic, Literal, NamedTuple, Protocol, TypeVar

import numpy as np
import numpy.typing as npt
import shapely
import viser
from shapely import MultiPolygon, Polygon
from shapely.geometry.base import BaseGeometry

import planners
from app.session.controller import Frame, Handle, RobotPose
from app.session.robot import RobotModel
from app.ui.backdrop import backdrop_of
from app.ui.floor_text import (
    FloorLabel,
    Keepouts,
    floor_font,
    place_events,
    scene_keepouts,
)
from app.ui.scoped import ScopedTarget
from app.ui.style import COLORS, HEIGHTS, WIDTHS, PlannerLook, planner_look
from app.ui.thinning import edges_to_draw
from planners.bug.trace import FOLLOW

FloatArray = npt.NDArray[np.float64]
IndexArray = npt.NDArray[np.uint32]
Mesh = tuple[FloatArray, IndexArray]
T = TypeVar("T")

MAX_VERTEX_HANDLES = 600
"""A scene with more obstacle vertices than this shows no vertex gizmos in the edit tool."""
EVENT_CROSS = 0.12
"""Half-size [m] of the cross drawn at a trace planner's event (H, D, L, M)."""
MAX_NUMBERED_OBSTACLES = 100
"""A scene with more obstacles than this shows no obstacle numbers: hundreds of labels
(a maze, a CAD floor plan) would bury the scene. Pictures number the obstacles as big as
their number (:mod:`app.media.slides`)."""

# The grey of an older scene's plans, kept while a big scene is computed (app.session.big).
STALE_RGB = (176, 176, 176)

# Drawings of polygons kept for the next frames (by value), and the most vertices a kept
# one may have: at most 256 x 200 vertices a cache, about 11 MB for the prisms and 3 MB
# for each of the others; a bigger polygon (a CAD floor plan's) is drawn afresh.
_KEPT_DRAWINGS = 256
_KEPT_VERTICES = 200

CHUNK_NODES = 16
"""Most nodes a chunked layer (:class:`_Chunked`) spreads its polygons over."""
MIN_CHUNK = 4
"""Fewest polygons a node of a chunked layer holds."""

# One degenerate segment / triangle: viser nodes keep a valid shape while hidden.
_NO_SEGMENTS = np.zeros((1, 2, 3))
_NO_MESH: Mesh = (np.zeros((3, 3)), np.array([[0, 1, 2]], dtype=np.uint32))


# --------------------------------------------------------------------------- pure helpers


def lift(points: npt.ArrayLike, z: float = 0.0) -> FloatArray:
    """Lift (N, 2) floor points to (N, 3) at height ``z`` [m].

    Examples
    --------
    >>> lift([[1, 2], [3, 4]], 0.5)
    array([[1. , 2. , 0.5],
           [3. , 4. , 0.5]])
    """
    xy = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    return np.column_stack([xy, np.full(len(xy), float(z))])


def lift_segments(ends: npt.ArrayLike, z: float = 0.0) -> FloatArray:
    """Segments in the floor plane, shape (N, 2, 2), at height ``z``: shape (N, 2, 3).

    Examples
    --------
    >>> lift_segments([[(0.0, 0.0), (1.0, 0.0)]], 0.1).tolist()
    [[[0.0, 0.0, 0.1], [1.0, 0.0, 0.1]]]
    """
    xy = np.asarray(ends, dtype=np.float64).reshape(-1, 2, 2)
    out = np.empty((len(xy), 2, 3))
    out[:, :, :2] = xy
    out[:, :, 2] = z
    return out


def path_to_segments(path: npt.ArrayLike | None, z: float = 0.0) -> FloatArray:
    """Turn an (N, 2) path into its N - 1 segments, shape (N - 1, 2, 3).

    Examples
    --------
    >>> path_to_segments([[0, 0], [1, 0], [1, 1]]).tolist()
    [[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]], [[1.0, 0.0, 0.0], [1.0, 1.0, 0.0]]]
    """
    if path is None:
        return np.zeros((0, 2, 3))
    p = lift(path, z)
    if len(p) < 2:
        return np.zeros((0, 2, 3))
    return np.stack([p[:-1], p[1:]], axis=1)


def polygons_of(
    geometry: BaseGeometry | Iterable[BaseGeometry] | None,
) -> list[Polygon]:
    """Flatten polygons, multipolygons and collections into a list of non-empty polygons."""
    if geometry is None:
        return []
    if isinstance(geometry, BaseGeometry):
        if isinstance(geometry, Polygon):
            return [] if geometry.is_empty else [geometry]
        return [p for g in getattr(geometry, "geoms", []) for p in polygons_of(g)]
    return [p for g in geometry for p in polygons_of(g)]


def rings_to_segments(
    polygons: Iterable[Polygon], z: float = 0.0, holes: bool = True
) -> FloatArray:
    """Outline every ring (exterior and, with ``holes``, interiors) as segments (N, 2, 3).

    Works on invalid (self-intersecting) polygons too: the ring is drawn as given, so a
    student sees where it crosses itself.

    Examples
    --------
    >>> rings_to_segments([Polygon([(0, 0), (1, 0), (0, 1)])]).shape
    (3, 2, 3)

    Each polygon's outline is kept (polygons compare by value): while one obstacle is
    dragged only its outline is made again.
    """
    parts = [_outline(polygon, float(z), holes) for polygon in polygons]
    return np.concatenate(parts) if parts else np.zeros((0, 2, 3))


def _small(polygon: Polygon) -> bool:
    """Whether a polygon is small enough to keep its drawing (bounds the caches' memory)."""
    return bool(shapely.get_num_coordinates(polygon) <= _KEPT_VERTICES)


class _Kept(Generic[T]):
    """A polygon's drawing by ``make``, kept by value (LRU) for a polygon of few vertices.

    Polygons compare and hash by value, so an obstacle that did not move between two
    frames finds its drawing again; a big polygon's is made afresh each time. Hashing a
    polygon serialises it, so the very objects drawn lately are looked up by identity
    first: an edit replaces one obstacle and keeps the others' objects.
    """

    def __init__(self, make: Callable[..., T]) -> None:
        self.make = make
        self._kept = functools.lru_cache(maxsize=_KEPT_DRAWINGS)(make)
        # (id, args) -> (the object itself, drawing): the object is held, so its id is
        # not reused while the entry lives; cleared when full, then refilled as drawn.
        self._recent: dict[tuple[Any, ...], tuple[Polygon, T]] = {}

    def __call__(self, polygon: Polygon, *args: Any) -> T:
        """Return ``make(polygon, *args)``, kept when ``polygon`` is small."""
        key = (id(polygon), *args)
        seen = self._recent.get(key)
        if seen is not None and seen[0] is polygon:
            return seen[1]
        if not _small(polygon):
            return self.make(polygon, *args)
        drawing = self._kept(polygon, *args)
        if len(self._recent) >= _KEPT_DRAWINGS:
            self._recent.clear()
        self._recent[key] = (polygon, drawing)
        return drawing


def _make_outline(polygon: Polygon, z: float, holes: bool) -> FloatArray:
    """One polygon's rings as segments (N, 2, 3) at height ``z`` (read-only)."""
    parts = [np.zeros((0, 2, 3))]
    for ring in [polygon.exterior, *(polygon.interiors if holes else [])]:
        coords = np.asarray(ring.coords, dtype=np.float64)
        if len(coords) >= 2:
            parts.append(path_to_segments(coords[:, :2], z))
    segments = np.concatenate(parts)
    segments.setflags(write=False)
    return segments


_outline = _Kept(_make_outline)


def _triangles(polygon: Polygon) -> FloatArray:
    """Triangles (T, 3, 2) covering a valid polygon (holes respected)."""
    if hasattr(shapely, "constrained_delaunay_triangles"):
        tris = shapely.constrained_delaunay_triangles(polygon)
        parts = shapely.get_parts(tris)
    else:  # shapely < 2.1: Delaunay of the vertices, keeping triangles inside
        parts = [
            t
            for t in shapely.get_parts(shapely.delaunay_triangles(polygon))
            if polygon.covers(t.centroid)
        ]
    if len(parts) == 0:
        return np.zeros((0, 3, 2))
    coords = shapely.get_coordinates(np.asarray(parts, dtype=object)).reshape(
        len(parts), 4, 2
    )[:, :3]
    # Counter-clockwise seen from above, so the faces' normals point up (+z).
    a, b, c = coords[:, 0], coords[:, 1], coords[:, 2]
    cw = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (
        c[:, 0] - a[:, 0]
    ) < 0
    coords[cw] = coords[cw][:, ::-1]
    return coords


def _valid_parts(polygon: Polygon) -> list[Polygon]:
    # An edit may leave a polygon self-intersecting; fill what make_valid makes of it.
    if polygon.is_valid:
        return [polygon]
    return polygons_of(shapely.make_valid(polygon))


def polygon_to_mesh(
    polygons: Iterable[Polygon] | Polygon | MultiPolygon, z: float = 0.0
) -> Mesh:
    """Triangulate flat polygons at height ``z``: vertices (V, 3) and faces (F, 3).

    Examples
    --------
    >>> v, f = polygon_to_mesh(Polygon([(0, 0), (2, 0), (2, 1), (0, 1)]), 0.1)
    >>> v.shape, f.shape, float(v[:, 2].max())
    ((6, 3), (2, 3), 0.1)

    Each polygon's triangles are kept (polygons compare by value): while one obstacle
    is dragged only its part of the configuration space is triangulated again.
    """
    tris = [_fill(g) for g in polygons_of(polygons)]
    if not tris or sum(len(t) for t in tris) == 0:
        return np.zeros((0, 3)), np.zeros((0, 3), dtype=np.uint32)
    all_tris = np.concatenate(tris)
    vertices = lift(all_tris.reshape(-1, 2), z)
    faces = np.arange(len(vertices), dtype=np.uint32).reshape(-1, 3)
    return vertices, faces


def _make_fill(polygon: Polygon) -> FloatArray:
    """Triangles (T, 3, 2) covering one polygon, made valid first (read-only)."""
    tris = [np.zeros((0, 3, 2)), *(_triangles(p) for p in _valid_parts(polygon))]
    triangles = np.concatenate(tris)
    triangles.setflags(write=False)
    return triangles


_fill = _Kept(_make_fill)


def prism_mesh(polygons: Iterable[Polygon] | Polygon, height: float) -> Mesh:
    """Extrude floor polygons into solid prisms of ``height`` [m] (top and sides, no bottom).

    Each polygon's prism is kept (polygons compare by value): while one vertex is dragged
    only that obstacle is triangulated again.

    Examples
    --------
    >>> v, f = prism_mesh([Polygon([(0, 0), (1, 0), (1, 1), (0, 1)])], 0.5)
    >>> len(f)  # 2 top triangles + 4 sides x 2
    10
    """
    parts = [_prism_vertices(g, float(height)) for g in polygons_of(polygons)]
    if not parts:
        return np.zeros((0, 3)), np.zeros((0, 3), dtype=np.uint32)
    vertices = np.concatenate(parts)
    faces = np.arange(len(vertices), dtype=np.uint32).reshape(-1, 3)
    return vertices, faces


def _make_prism_vertices(polygon: Polygon, height: float) -> FloatArray:
    """Triangle corners (3T, 3) of one polygon's prism: its top, then its sides."""
    top, _ = polygon_to_mesh(polygon, height)
    side_v = [top]
    for part in _valid_parts(polygon):
        oriented = shapely.geometry.polygon.orient(part, sign=1.0)
        for ring in [oriented.exterior, *oriented.interiors]:
            c = np.asarray(ring.coords, dtype=np.float64)[:, :2]
            a, b = c[:-1], c[1:]
            # Each side is a quad a0 b0 b1 a1 (outward normal for a CCW exterior).
            quad = np.stack(
                [
                    lift(a, 0.0),
                    lift(b, 0.0),
                    lift(b, height),
                    lift(a, 0.0),
                    lift(b, height),
                    lift(a, height),
                ],
                axis=1,
            )
            side_v.append(quad.reshape(-1, 3))
    vertices = np.concatenate(side_v)
    vertices.setflags(write=False)
    return vertices


_prism_vertices = _Kept(_make_prism_vertices)


def wall_mesh(
    boundary: Polygon | None, thickness: float = 0.12, height: float = 0.3
) -> Mesh:
    """Walls standing just outside ``boundary``: a prism of the ring ``thickness`` [m] wide.

    Examples
    --------
    >>> v, f = wall_mesh(Polygon([(0, 0), (4, 0), (4, 3), (0, 3)]))
    >>> bool(v[:, 0].min() < 0 and v[:, 0].max() > 4)
    True
    """
    if boundary is None or boundary.is_empty:
        return np.zeros((0, 3)), np.zeros((0, 3), dtype=np.uint32)
    # Square corners at right angles; a sharper corner (a traced map's) is bevelled
    # instead of growing a spike up to five wall thicknesses long.
    outer = boundary.buffer(thickness, join_style="mitre", mitre_limit=1.5)
    return prism_mesh(polygons_of(outer.difference(boundary)), height)


def circle_segments(
    center: npt.ArrayLike, radius: float, z: float = 0.0, n: int = 96
) -> FloatArray:
    """Draw a circle of ``radius`` [m] around ``center`` as ``n`` segments (n, 2, 3).

    Examples
    --------
    >>> s = circle_segments((1, 1), 2.0, n=8)
    >>> s.shape, bool(np.allclose(np.hypot(s[..., 0] - 1, s[..., 1] - 1), 2.0))
    ((8, 2, 3), True)
    """
    angles = np.linspace(0.0, 2.0 * np.pi, n + 1)
    c = np.asarray(center, dtype=np.float64)
    ring = c + radius * np.column_stack([np.cos(angles), np.sin(angles)])
    return path_to_segments(ring, z)


def disk_mesh(radius: float, z: float = 0.0, n: int = 48) -> Mesh:
    """Make a flat disk of ``radius`` [m] around the origin at height ``z``: (V, 3), (F, 3)."""
    angles = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    rim = np.column_stack(
        [radius * np.cos(angles), radius * np.sin(angles), np.full(n, z)]
    )
    vertices = np.vstack([[0.0, 0.0, z], rim])
    k = np.arange(n)
    faces = np.column_stack([np.zeros(n), 1 + k, 1 + (k + 1) % n]).astype(np.uint32)
    return vertices, faces


def vertex_colors(rgb: npt.ArrayLike) -> npt.NDArray[np.uint8]:
    """Encode sRGB colours (0-255) for viser's per-vertex colour arrays.

    three.js treats per-vertex colours as linear and brightens them on output (a single
    layer colour is converted properly), so (170, 68, 153) came out as (214, 161, 205) in
    the browser. Sending the linear value makes a per-segment colour look like the same
    colour given for a whole layer.

    Examples
    --------
    >>> vertex_colors([[0, 170, 255]]).tolist()
    [[0, 103, 255]]
    """
    c = np.asarray(rgb, dtype=np.float64) / 255.0
    linear = np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)
    return np.clip(np.round(linear * 255.0), 0, 255).astype(np.uint8)


def yaw_quaternion(angle: float) -> tuple[float, float, float, float]:
    """Quaternion (w, x, y, z) of a rotation by ``angle`` [rad] about +z.

    Examples
    --------
    >>> [round(v, 6) for v in yaw_quaternion(math.pi)]
    [0.0, 0.0, 0.0, 1.0]
    """
    return (math.cos(angle / 2.0), 0.0, 0.0, math.sin(angle / 2.0))


def _axis_quaternion(
    axis: npt.ArrayLike, angle: float
) -> tuple[float, float, float, float]:
    a = np.asarray(axis, dtype=np.float64)
    a = a / np.linalg.norm(a)
    s = math.sin(angle / 2.0)
    return (math.cos(angle / 2.0), float(a[0] * s), float(a[1] * s), float(a[2] * s))


# --------------------------------------------------------------------------- the view


class Segments:
    """One line-segment layer whose number of segments changes from frame to frame."""

    def __init__(
        self,
        scene: viser.SceneApi,
        name: str,
        color: tuple[int, int, int],
        thickness: float,
        units: Literal["world", "screen"] = "world",
        *,
        per_segment: bool = False,
    ) -> None:
        # A layer is created either with one colour, shape (3,), or with one colour per
        # segment end, and keeps that mode for ever: three.js must recompile a material
        # whose vertex colours are switched on, and viser 1.1.1 does not, so a layer that
        # switched could be drawn white.
        self.per_segment = per_segment
        self.color = np.asarray(color, dtype=np.uint8)
        self.handle = scene.add_line_segments(
            name,
            _NO_SEGMENTS,
            self._spread(len(_NO_SEGMENTS)) if per_segment else color,
            thickness=thickness,
            thickness_units=units,
            visible=False,
        )

    def _spread(self, n: int) -> npt.NDArray[np.uint8]:
        return vertex_colors(np.broadcast_to(self.color, (n, 2, 3)))

    def set(
        self,
        segments: FloatArray,
        visible: bool = True,
        colors: npt.NDArray[np.uint8] | None = None,
    ) -> None:
        """Draw ``segments`` ((N, 2, 3) [m]), in one colour or one per segment."""
        if len(segments) == 0:
            self.handle.visible = False
            return
        if self.per_segment:
            self.handle.colors = (
                self._spread(len(segments)) if colors is None else vertex_colors(colors)
            )
        self.handle.points = segments.astype(np.float32)
        self.handle.visible = visible


class _Mesh:
    """One mesh layer whose triangles change from frame to frame."""

    def __init__(
        self,
        scene: viser.SceneApi,
        name: str,
        color: tuple[int, int, int],
        **kwargs: Any,
    ) -> None:
        self.handle = scene.add_mesh_simple(
            name, _NO_MESH[0], _NO_MESH[1], color=color, visible=False, **kwargs
        )

    def set(self, mesh: Mesh, visible: bool = True) -> None:
        vertices, faces = mesh
        if len(faces) == 0:
            self.handle.visible = False
            return
        self.handle.vertices = vertices.astype(np.float32)
        self.handle.faces = faces.astype(np.uint32)
        self.handle.visible = visible


def chunk_size(count: int) -> int:
    """Polygons per node of a chunked layer of ``count``: 4, or more for at most 16 nodes.

    Examples
    --------
    >>> chunk_size(0), chunk_size(32), chunk_size(64), chunk_size(65), chunk_size(500)
    (4, 4, 4, 5, 32)
    """
    return max(MIN_CHUNK, -(-count // CHUNK_NODES))


class _NodeLayer(Protocol):
    """One node's layer of a chunked layer: a handle, and a drawing to show on it."""

    handle: Any

    def set(self, drawing: Any, visible: bool = True, /) -> None: ...


_LayerT = TypeVar("_LayerT", bound=_NodeLayer)


class _Chunked(Generic[_LayerT]):
    """Polygons drawn on a few nodes of a few polygons each (``prefix/0``, ``prefix/1``..).

    Node ``k`` draws polygons ``k * size`` to ``(k + 1) * size - 1`` (:func:`chunk_size`)
    and is sent again only when they differ from the ones it drew (by identity, then by
    value): while one obstacle is dragged, one node of 4 obstacles goes to the browsers
    instead of the whole layer. At most :data:`CHUNK_NODES` nodes, so a floor plan of
    thousands of polygons is still a few draw calls. Nodes are made as needed and hidden
    when unused.

    Parameters
    ----------
    make
        Makes one node's layer, given its name.
    prefix
        The nodes' parent name.
    draw
        The drawing of a few polygons for the layer's ``set`` (a mesh or segments).
    """

    def __init__(
        self,
        make: Callable[[str], _LayerT],
        prefix: str,
        draw: Callable[[Sequence[Polygon]], Any],
    ) -> None:
        self._make = make
        self._prefix = prefix
        self._draw = draw
        self.layers: list[_LayerT] = []
        self._drawn: list[tuple[tuple[Polygon, ...], bool] | None] = []

    def set(self, polygons: Sequence[Polygon], visible: bool = True) -> None:
        """Draw ``polygons``; send only the nodes whose polygons or visibility changed."""
        size = chunk_size(len(polygons))
        chunks = [tuple(polygons[k : k + size]) for k in range(0, len(polygons), size)]
        while len(self.layers) < len(chunks):
            self.layers.append(self._make(f"{self._prefix}/{len(self.layers)}"))
            self._drawn.append(None)
        for k, layer in enumerate(self.layers):
            key = (chunks[k], visible) if k < len(chunks) else None
            if _same(self._drawn[k], key):
                continue
            if key is None or not visible:
                layer.handle.visible = False
            else:
                layer.set(self._draw(chunks[k]))
            self._drawn[k] = key  # once drawn: a drawing that failed is tried again

    def shown(self) -> list[Any]:
        """Return the handles of the nodes shown now, in order (what browsers draw)."""
        return [layer.handle for layer in self.layers if layer.handle.visible]


def _chunked_outlines(
    scene: viser.SceneApi, prefix: str, color: tuple[int, int, int], z: float
) -> _Chunked[Segments]:
    """Polygons' outlines at height ``z`` [m], drawn in chunks (:class:`_Chunked`)."""
    return _Chunked(
        functools.partial(Segments, scene, color=color, thickness=WIDTHS["outline"]),
        prefix,
        functools.partial(rings_to_segments, z=z),
    )


def _same(old: object, new: object) -> bool:
    """Whether ``new`` is what was drawn (``old``): the same object, or equal by value.

    Polygons, and tuples of them, compare by value; a value that cannot say (an array)
    counts as changed.
    """
    try:
        return old is new or bool(old == new)
    except (TypeError, ValueError):
        return False


class Labels:
    """A pool of labels; only grows, hides what it does not need.

    Sized on the screen (``scale``: 12 px a unit, viser's "screen" mode), or, once
    :meth:`size_in_metres` is called, in the scene's metres (viser's "scene" mode: the
    projector text of :mod:`app.ui.floor_text`).
    """

    def __init__(
        self,
        scene: viser.SceneApi,
        prefix: str,
        scale: float = 1.0,
        anchor: str = "bottom-left",
    ) -> None:
        self.scene = scene
        self.prefix = prefix
        self.scale = scale
        self.anchor = anchor
        self.height: float | None = None
        """Font size [m] in "scene" mode; None: sized on the screen."""
        self.handles: list[viser.LabelHandle] = []
        self.shown: dict[int, tuple[str | None, tuple[float, ...] | None, bool]] = {}
        self.hidden = False  # a picture draws its own labels (PlannerView.present)

    def size_in_metres(self, height: float) -> None:
        """Size every label of the pool ``height`` metres (viser's "scene" mode)."""
        height = float(height)
        if height == self.height:
            return
        self.height = height
        for handle in self.handles:
            handle.font_size_mode = "scene"
            handle.font_scene_height = height

    def set(
        self, items: Sequence[tuple[str, npt.ArrayLike]], visible: bool = True
    ) -> None:
        """Show ``items`` (text, position) and hide the labels beyond them."""
        while len(self.handles) < len(items):
            self.handles.append(
                self.scene.add_label(
                    f"{self.prefix}/{len(self.handles)}",
                    "",
                    font_size_mode="screen" if self.height is None else "scene",
                    font_screen_scale=self.scale,
                    font_scene_height=self.height or 0.075,
                    anchor=self.anchor,  # type: ignore[arg-type]
                    visible=False,
                )
            )
        for k, handle in enumerate(self.handles):
            if k < len(items) and visible and not self.hidden:
                text, position = items[k]
                xyz = _floats(position)
                state: tuple[str | None, tuple[float, ...] | None, bool] = (
                    text,
                    xyz,
                    True,
                )
            else:
                text, xyz, state = "", (), (None, None, False)
            if self.shown.get(k) == state:
                continue  # only this pool writes its labels: nothing to send
            self.shown[k] = state
            if state[2]:
                handle.text = text
                handle.position = xyz  # type: ignore[assignment]
            handle.visible = state[2]


def _floats(position: npt.ArrayLike) -> tuple[float, ...]:
    """Return a position as a tuple of Python floats (a tuple of numbers directly)."""
    values: Iterable[Any] = (
        position
        if isinstance(position, tuple)
        else np.asarray(position, dtype=np.float64)
    )
    return tuple(map(float, values))


def _place(node: Any, position: tuple[float, float, float]) -> None:
    """Move a scene node (a gizmo) only when it moves: most stay put during an edit."""
    if tuple(float(v) for v in node.position) != tuple(float(v) for v in position):
        node.position = position


HandleCallback = Callable[[Handle, tuple[float, float], str], None]


class GraphEdges:
    """A graph's edges on two nodes: those at the start or the goal, and the rest.

    Dragging the start or the goal changes only the edges at them: the other node, most
    of the graph, is sent again only when its edges change (by value), so a drag sends
    a browser a few edges per frame instead of the whole graph. Both nodes have the same
    colour and width: the picture is one layer of edges.
    """

    def __init__(
        self,
        scene: viser.SceneApi,
        name: str,
        color: tuple[int, int, int],
        thickness: float,
    ) -> None:
        self.rest = Segments(scene, name, color, thickness, "screen")
        """The edges between obstacles' vertices."""
        self.ends = Segments(scene, name + "_ends", color, thickness, "screen")
        """The edges with an end at the start or the goal."""
        self._rest: tuple[FloatArray, bool] | None = None  # what ``rest`` shows

    @property
    def visible(self) -> bool:
        """Whether the browsers draw any edge of the graph."""
        return any(layer.handle.visible for layer in self.layers)

    @property
    def layers(self) -> tuple[Segments, Segments]:
        """Both nodes' layers (the rest first)."""
        return self.rest, self.ends

    def set(
        self, segments: FloatArray, at_ends: npt.NDArray[np.bool_], visible: bool
    ) -> None:
        """Draw ``segments`` ((N, 2, 3) [m]); ``at_ends`` marks the start's and goal's."""
        rest = segments[~at_ends] if len(segments) else segments
        shown = self._rest
        if (
            shown is None
            or shown[1] != visible
            or shown[0].shape != rest.shape
            or not np.array_equal(shown[0], rest)
        ):
            self.rest.set(rest, visible)
            self._rest = (rest, visible)
        self.ends.set(segments[at_ends] if len(segments) else segments, visible)

    def points(self) -> npt.NDArray[np.float32]:
        """Return the edges the browsers draw, shape (N, 2, 3): the rest, then the ends'."""
        parts = [
            np.asarray(layer.handle.points, dtype=np.float32)
            for layer in self.layers
            if layer.handle.visible
        ]
        return np.concatenate(parts) if parts else np.zeros((0, 2, 3), np.float32)


class _GraphLayer:
    """A graph planner's edges and shortest path (VG, SVG: section 9.4, 9.5)."""

    def __init__(self, scene: viser.SceneApi, name: str, look: PlannerLook) -> None:
        self.name = name
        self.look = look
        # Graph edges are thin lines of constant pixel width: readable at any zoom, and
        # cheaper to draw than world-width ribbons (which matters in software WebGL).
        self.edges = GraphEdges(
            scene, f"/{name}/edges", look.edges or look.path, look.edges_px
        )
        self.path = Segments(scene, f"/{name}/path", look.path, look.path_width)
        self.stale = False  # drawn grey (an older scene's result)

    def render(self, frame: Frame, changed: Callable[[str, Any], bool]) -> None:
        """Draw the frame's result of this planner (nothing is sent if it is unchanged)."""
        result = frame.plans.get(self.name)
        show_edges = frame.layers.get(f"{self.name}_edges", True) and getattr(
            result, "status", ""
        ) in ("ok", "unreachable")
        show_path = frame.layers.get(f"{self.name}_path", True)
        all_edges = frame.layers.get(f"{self.name}_edges_all", False)
        # The same result object drawn the same way: nothing to send (the frame that
        # brings the DSB result leaves VG and SVG as they are).
        key = (result, show_edges, show_path, all_edges, frame.stale)
        if not changed(self.name, key):
            return
        if frame.stale != self.stale:
            # An older scene's plans, kept while a big scene is computed, are grey.
            self.stale = frame.stale
            for layer, color in (
                *((edges, self.look.edges) for edges in self.edges.layers),
                (self.path, self.look.path),
            ):
                rgb = STALE_RGB if frame.stale else (color or self.look.path)
                layer.handle.colors = np.asarray(rgb, dtype=np.uint8)
        # A big graph is thinned unless its "edges: all" layer is on (app.ui.thinning).
        if show_edges and result is not None:
            drawing = edges_to_draw(result, all_edges)
            self.edges.set(
                lift_segments(drawing.segments, self.look.edges_height),
                drawing.at_ends,
                show_edges,
            )
        else:
            self.edges.set(_NO_SEGMENTS, np.zeros(len(_NO_SEGMENTS), bool), show_edges)
        self.path.set(
            path_to_segments(result.path, self.look.path_height)
            if show_path and result is not None
            else _NO_SEGMENTS,
            show_path,
        )


class _TraceLayer:
    """A sensing planner's walk, coloured by mode, with its events (DSB: Fig. 9.19)."""

    def __init__(self, scene: viser.SceneApi, name: str, look: PlannerLook) -> None:
        self.name = name
        self.look = look
        self.path = Segments(
            scene, f"/{name}/path", look.path, look.path_width, per_segment=True
        )
        self.marks = Segments(
            scene, f"/{name}/marks", COLORS["marker_edge"], WIDTHS["outline"]
        )
        # Sized in metres and placed with every trace's events at once
        # (PlannerView._render_event_labels): no label hides another's.
        self.labels = Labels(scene, f"/{name}/labels", 1.0, "center-center")
        self.leaders = Segments(
            scene, f"/{name}/leaders", COLORS["marker_edge"], WIDTHS["outline"]
        )

    def shown(self, frame: Frame) -> Any:
        """Return the frame's result of this planner when its layer is on, else None."""
        result = frame.plans.get(self.name)
        return result if frame.layers.get(f"{self.name}_path", True) else None

    def show_labels(self, placed: Sequence[FloorLabel], font: float) -> None:
        """Draw this planner's event labels where they were placed, with their leaders."""
        z = self.look.path_height + 0.05
        self.labels.size_in_metres(font)
        self.labels.set([(p.request.text, (*p.centre, z)) for p in placed])
        leaders = [p.leader for p in placed if p.leader is not None]
        self.leaders.set(
            lift_segments(np.asarray(leaders, dtype=np.float64), z - 0.01)
            if leaders
            else _NO_SEGMENTS,
            bool(leaders) and not self.labels.hidden,
        )

    def render(self, frame: Frame, changed: Callable[[str, Any], bool]) -> None:
        """Draw the frame's result of this planner (nothing is sent if it is unchanged).

        The path and the crosses depend only on the result: a goal dragged while the
        DSB result lags re-sends no path. The labels are drawn by :meth:`show_labels`.
        """
        result = frame.plans.get(self.name)
        show = frame.layers.get(f"{self.name}_path", True) and result is not None
        events = event_labels(result) if show else []
        z = self.look.path_height
        stale = frame.stale
        if not changed(self.name, (result, show, stale)):
            return
        segments = (
            path_to_segments(result.path, z)
            if show and result is not None
            else _NO_SEGMENTS
        )
        colors = self._colors(result, len(segments))
        if stale and colors is not None:  # an older scene's walk, kept while computing
            colors[:] = STALE_RGB
        self.path.set(segments, show, colors)
        crosses = [_cross(at, EVENT_CROSS, z + 0.004) for _, at in events]
        self.marks.set(
            np.concatenate(crosses) if crosses else _NO_SEGMENTS, show and bool(crosses)
        )

    def _colors(self, result: Any, n: int) -> npt.NDArray[np.uint8] | None:
        """One colour per path segment: goal seeking, or following a border."""
        modes = getattr(result, "modes", ())
        if n == 0 or len(modes) != n:
            return None  # an invalid result has no path, hence no segments
        follow = self.look.follow or self.look.path
        rgb = np.array(
            [follow if m == FOLLOW else self.look.path for m in modes],
            dtype=np.uint8,
        )
        return np.repeat(rgb[:, None, :], 2, axis=1)


class PlannerView:
    """The planner's 3-D scene on a viser server (or on one client).

    Parameters
    ----------
    target
        A :class:`viser.ViserServer` (every browser sees the same scene), a
        :class:`viser.ClientHandle`, or either under a root node
        (:class:`app.ui.scoped.ScopedTarget`, a classroom's views).
    on_drag
        Called as ``on_drag(handle, (x, y), phase)`` when a user drags a gizmo; the app
        passes :meth:`app.session.controller.SceneEdits.drag_handle`.
    registry
        The planners to draw a layer for (each as its kind says).
    """

    def __init__(
        self,
        target: viser.ViserServer | viser.ClientHandle | ScopedTarget,
        on_drag: HandleCallback | None = None,
        registry: Mapping[str, planners.PlannerSpec] = planners.REGISTRY,
    ) -> None:
        self.target = target
        self.scene = target.scene
        self._last: dict[str, Any] = {}
        self.rendered_version = -1
        self.robot_model_fn: Callable[[Any], tuple[Any, RobotModel]] | None = None
        self._add_scene_nodes()
        # One layer per registered planner, drawn as its kind says (planners.registry).
        self.graphs = {
            name: _GraphLayer(self.scene, name, planner_look(name, registry))
            for name, spec in registry.items()
            if spec.kind == "graph"
        }
        self.traces = {
            name: _TraceLayer(self.scene, name, planner_look(name, registry))
            for name, spec in registry.items()
            if spec.kind == "trace"
        }
        self.gizmos = Gizmos(self.scene, on_drag)
        """The gizmos a user drags (start and goal, vertices and obstacles)."""
        self._add_markers()
        self._add_robot_nodes()

    def _add_scene_nodes(self) -> None:
        """Create the floor, walls, obstacles, expansions, selection and draft nodes."""
        s = self.scene
        self.grid = s.add_grid(
            "/floor",
            width=10.0,
            height=8.0,
            cell_size=0.5,
            section_size=1.0,
            cell_color=(215, 215, 215),
            section_color=(170, 170, 170),
            position=(5.0, 4.0, 0.0),
            shadow_opacity=0.0,
        )
        self.walls = _Mesh(
            s, "/walls", COLORS["wall"], flat_shading=True, side="double"
        )
        self._floor_map_node: Any = None
        """The occupancy map's picture on the floor (:mod:`app.ui.backdrop`), or None."""
        # Obstacles and the configuration space in chunks of a few polygons each: a
        # drag sends the changed obstacle's chunk, not the whole layer (_Chunked).
        self.obstacles = _Chunked(
            functools.partial(
                _Mesh, s, color=COLORS["obstacle"], flat_shading=True, side="double"
            ),
            "/obstacles/body",
            functools.partial(prism_mesh, height=HEIGHTS["obstacle"]),
        )
        self.obstacle_edges = _chunked_outlines(
            s, "/obstacles/edges", COLORS["obstacle_edge"], HEIGHTS["obstacle"] + 0.002
        )
        self.obstacle_labels = Labels(s, "/obstacles/labels", 0.9, "center-center")
        self.expanded_fill = _Chunked(
            functools.partial(
                _Mesh,
                s,
                color=COLORS["expanded"],
                opacity=0.4,
                side="double",
                cast_shadow=False,
                receive_shadow=False,
            ),
            "/expanded/fill",
            functools.partial(polygon_to_mesh, z=HEIGHTS["expanded_fill"]),
        )
        self.expanded_edges = _chunked_outlines(
            s, "/expanded/edges", COLORS["expanded_edge"], HEIGHTS["expanded_edge"]
        )
        self.other_edges = Segments(
            s, "/expanded/other", COLORS["other_expansion"], WIDTHS["outline"] * 0.8
        )
        self.selection = Segments(
            s, "/selection", COLORS["selection"], WIDTHS["selection"]
        )
        self.draft = Segments(s, "/draft", COLORS["draft"], WIDTHS["outline"] * 1.5)

    def _add_markers(self) -> None:
        """Hang a marker, rim and label from the start and goal gizmos.

        As the gizmo's children they follow the mouse in the browser even before the
        server has replanned.
        """
        s = self.scene
        self.markers: dict[str, viser.MeshHandle] = {}
        self.marker_rims: dict[str, viser.LineSegmentsHandle] = {}
        self.marker_labels: dict[str, viser.LabelHandle] = {}
        for name in ("start", "goal"):
            v, f = disk_mesh(1.0, HEIGHTS["marker"])
            self.markers[name] = s.add_mesh_simple(
                f"/handles/{name}/marker",
                v,
                f,
                color=COLORS[name],
                side="double",
                cast_shadow=False,
            )
            self.marker_rims[name] = s.add_line_segments(
                f"/handles/{name}/rim",
                circle_segments((0, 0), 1.0, HEIGHTS["marker"] + 0.002, n=48),
                COLORS["marker_edge"],
                thickness=0.03,
            )
            self.marker_labels[name] = s.add_label(
                f"/handles/{name}/label",
                name,
                position=(0.0, 0.0, 0.05),
                font_screen_scale=1.3,
                anchor="bottom-center",
            )

    def _add_robot_nodes(self) -> None:
        """Create the robot's frame (body and wheels are its children) and sensor layers."""
        s = self.scene
        self.robot = s.add_frame("/robot", show_axes=False, visible=False)
        self.robot_parts: list[Any] = []
        self.body_parts: list[viser.MeshHandle] = []
        self.wheel_spins: list[tuple[viser.FrameHandle, FloatArray]] = []
        self._robot_key: Any = None
        self.sensing_circle = Segments(
            s, "/sensing/range", COLORS["sensing"], WIDTHS["sensing"]
        )
        self.sensing_graph = Segments(
            s, "/sensing/tangents", COLORS["tangents"], WIDTHS["sensing"]
        )
        self.sensing_seen = Segments(
            s, "/sensing/seen", COLORS["sensed"], WIDTHS["sensing"] * 3
        )
        # The planner's choice r_next: r -> O_i -> g, black and bold.
        self.sensing_chosen = Segments(
            s, "/sensing/chosen", COLORS["chosen"], WIDTHS["sensing"] * 2.4
        )

    # ------------------------------------------------------------------ helpers

    def _atomic(self) -> contextlib.AbstractContextManager[None]:
        atomic = getattr(self.target, "atomic", None)
        return atomic() if atomic is not None else contextlib.nullcontext()

    def _changed(self, key: str, value: Any) -> bool:
        """Tell whether ``value`` differs from the last one drawn for ``key`` (and remember it)."""
        old = self._last.get(key, _MISSING)
        if old is not _MISSING and _same(old, value):
            return False
        self._last[key] = value
        return True

    # ------------------------------------------------------------------ render

    def render(self, frame: Frame) -> None:
        """Draw ``frame``: property assignments only, in one atomic batch."""
        with self._atomic():
            self._render(frame)
        self.rendered_version = frame.version

    def _render(self, frame: Frame) -> None:
        scene = frame.scene
        layers = frame.layers
        radius = scene.robot.radius
        self.set_layer_flags(layers.get("robot", True), layers.get("sensing", True))
        if self.robot_model_fn is not None and self._changed(
            "robot_model", scene.robot
        ):
            self.set_robot_model(*self.robot_model_fn(scene.robot))
        self._render_floor_and_obstacles(frame)
        self._render_floor_map(frame)
        self._render_expansion(frame)
        for graph in self.graphs.values():
            graph.render(frame, self._changed)
        for trace in self.traces.values():
            trace.render(frame, self._changed)
        self._render_event_labels(frame)
        self._render_markers(frame, radius)
        self.gizmos.render(frame)
        self._render_selection(frame)

    def _render_floor_and_obstacles(self, frame: Frame) -> None:
        scene = frame.scene
        if self._changed("bounds", floor_bounds(scene)):
            x0, y0, x1, y1 = self._last["bounds"]
            self.grid.width, self.grid.height = x1 - x0, y1 - y0
            self.grid.position = ((x0 + x1) / 2, (y0 + y1) / 2, -0.001)
        if self._changed("boundary", scene.boundary):
            self.walls.set(wall_mesh(scene.boundary, height=HEIGHTS["wall"]))
        show = frame.layers.get("obstacles", True)
        if not self._changed("obstacles", (scene.obstacles, show)):
            return
        self.obstacles.set(scene.obstacles, show)
        self.obstacle_edges.set(scene.obstacles, show)
        numbered = len(scene.obstacles) <= MAX_NUMBERED_OBSTACLES
        self.obstacle_labels.set(
            [
                (str(i + 1), _label_point(o, HEIGHTS["obstacle"] + 0.05))
                for i, o in enumerate(scene.obstacles)
            ]
            if numbered
            else [],
            show,
        )

    def _render_event_labels(self, frame: Frame) -> None:
        """Place the events of every trace planner at once, clear of the fixed marks."""
        scene = frame.scene
        results = tuple((name, t.shown(frame)) for name, t in self.traces.items())
        key = (results, scene.start, scene.goal, scene.robot.radius, scene.obstacles)
        if not self._changed("event_labels", key):
            return
        bounds = floor_bounds(scene)
        font = floor_font(bounds)
        placed = place_events(
            [(name, event_labels(result)) for name, result in results],
            font=font,
            area=bounds,
            cross=EVENT_CROSS,
            keepouts=live_keepouts(scene, font),
        )
        for name, trace in self.traces.items():
            trace.show_labels(placed[name], font)

    def _render_floor_map(self, frame: Frame) -> None:
        """Lay the occupancy map the scene was imported from on the floor (or take it away)."""
        floor_map = frame.floor_map if frame.layers.get("map", True) else None
        if not self._changed("floor_map", floor_map):
            return
        if self._floor_map_node is not None:
            self._floor_map_node.remove()
            self._floor_map_node = None
        if floor_map is None:
            return
        backdrop = backdrop_of(floor_map)
        (cx, cy), (width, height) = backdrop.centre, backdrop.size
        self._floor_map_node = self.scene.add_image(
            "/floor_map",
            backdrop.rgb,
            render_width=width,
            render_height=height,
            format="png",
            cast_shadow=False,
            receive_shadow=False,
            position=(cx, cy, HEIGHTS["floor_map"]),
            wxyz=yaw_quaternion(backdrop.yaw),
        )

    def _render_expansion(self, frame: Frame) -> None:
        cspace = frame.plans.get("cspace")
        show = frame.layers.get("expanded", True)
        # The key holds the object itself (compared by identity), never its id(): an id
        # can be reused once the old configuration space is freed.
        if self._changed("expanded", (cspace, show)):
            if cspace is not None and show:
                self.expanded_fill.set(polygons_of(cspace.merged))
                outlines = list(cspace.expanded)
                if cspace.boundary is not None:
                    outlines += polygons_of(cspace.boundary)
                self.expanded_edges.set(outlines)
            else:
                self.expanded_fill.set((), False)
                self.expanded_edges.set((), False)
        layers = frame.layers
        other = frame.other_expanded if layers.get("other_expansion", False) else None
        if self._changed("other", other):
            self.other_edges.set(
                rings_to_segments(other or [], HEIGHTS["expanded_edge"] + 0.001),
                other is not None,
            )

    def _render_markers(self, frame: Frame, radius: float) -> None:
        size = marker_size(radius)
        if self._changed("marker_size", size):
            for name in ("start", "goal"):
                self.markers[name].scale = (size, size, 1.0)
                self.marker_rims[name].scale = (size, size, 1.0)
                # Above the marker on screen, so the label never hides the footprint.
                self.marker_labels[name].position = (0.0, size + 0.05, 0.05)

    def _render_selection(self, frame: Frame) -> None:
        scene = frame.scene
        sel = frame.selection
        segments: list[FloatArray] = []
        z = HEIGHTS["obstacle"] + 0.02
        if sel is not None and sel.obstacle < len(scene.obstacles):
            polygon = scene.obstacles[sel.obstacle]
            ring = np.asarray(polygon.exterior.coords, dtype=np.float64)
            if sel.vertex is not None:
                segments.append(circle_segments(ring[sel.vertex], 0.18, z, n=24))
            elif sel.edge is not None:
                segments.append(path_to_segments(ring[sel.edge : sel.edge + 2], z))
            else:
                segments.append(rings_to_segments([polygon], z))
        self.selection.set(
            np.concatenate(segments) if segments else _NO_SEGMENTS, bool(segments)
        )
        draft = np.asarray(frame.draft, dtype=np.float64).reshape(-1, 2)
        parts = [path_to_segments(draft, 0.05)] + [_cross(p, 0.1, 0.05) for p in draft]
        self.draft.set(
            np.concatenate(parts) if len(draft) else _NO_SEGMENTS, len(draft) > 0
        )

    # ------------------------------------------------------------------ robot

    def render_robot(self, pose: RobotPose | None) -> None:
        """Move the robot to ``pose`` and spin its wheels; None hides it."""
        with self._atomic():
            self._render_robot(pose)

    def _render_robot(self, pose: RobotPose | None) -> None:
        flags = (self._last.get("robot_layer", True), self._last.get("sensing_layer"))
        if not self._changed("robot_pose", (pose, flags, self._robot_key)):
            return  # a redraw of the scene that left the robot where it was
        visible = pose is not None and self._last.get("robot_layer", True)
        if pose is None or not visible:
            self.robot.visible = False
            self._hide_sensing()
            return
        self.robot.position = (pose.xy[0], pose.xy[1], 0.0)
        # Robot frame: x_m right, y_m forward; phi is the world angle of y_m.
        self.robot.wxyz = yaw_quaternion(pose.phi - math.pi / 2)
        for (spin, axis), angle in zip(
            self.wheel_spins, pose.wheel_angles, strict=False
        ):
            spin.wxyz = _axis_quaternion(axis, angle)
        self.robot.visible = True
        sensing = pose.sensing
        if sensing is None or not self._last.get("sensing_layer", True):
            self._hide_sensing()
            return
        picture = sensing_geometry(sensing)
        z = HEIGHTS["sensing"]
        self.sensing_circle.set(
            circle_segments(picture.center, picture.radius, z)
            if math.isfinite(picture.radius)
            else _NO_SEGMENTS
        )
        self.sensing_seen.set(_segments_2d(picture.seen, z + 0.002))
        self.sensing_graph.set(_segments_2d(picture.tangents, z + 0.004))
        self.sensing_chosen.set(
            _segments_2d(picture.chosen, z + 0.006), len(picture.chosen) > 0
        )

    def _hide_sensing(self) -> None:
        for layer in (
            self.sensing_circle,
            self.sensing_graph,
            self.sensing_seen,
            self.sensing_chosen,
        ):
            layer.set(_NO_SEGMENTS, False)

    def set_robot_model(self, key: Any, model: RobotModel) -> None:
        """Show the robot's meshes (see :func:`app.session.robot.robot_model`).

        The meshes are sent again only when ``key`` changes; a new radius only rescales
        the body.
        """
        if key != self._robot_key:
            self._robot_key = key
            with self._atomic():
                for part in self.robot_parts:
                    part.remove()
                self.robot_parts = []
                self.body_parts = []
                self.wheel_spins = []
                for k, ((vertices, faces), color) in enumerate(model.body):
                    node = self.scene.add_mesh_simple(
                        f"/robot/body{k}",
                        vertices,
                        faces,
                        color=color,
                        flat_shading=True,
                        cast_shadow=False,
                    )
                    self.robot_parts.append(node)
                    self.body_parts.append(node)
                for w, (hub, axle, pieces) in enumerate(model.wheels):
                    # The wheel-local frame is parallel to the robot frame, origin at the hub.
                    mount = self.scene.add_frame(
                        f"/robot/wheel{w}",
                        show_axes=False,
                        position=(float(hub[0]), float(hub[1]), float(hub[2])),
                    )
                    spin = self.scene.add_frame(
                        f"/robot/wheel{w}/spin", show_axes=False
                    )
                    self.robot_parts.append(mount)
                    for k, ((vertices, faces), color) in enumerate(pieces):
                        self.scene.add_mesh_simple(
                            f"/robot/wheel{w}/spin/part{k}",
                            vertices,
                            faces,
                            color=color,
                            flat_shading=True,
                            cast_shadow=False,
                        )
                    self.wheel_spins.append((spin, np.asarray(axle, dtype=np.float64)))
        for node in self.body_parts:
            node.scale = (model.body_scale, model.body_scale, 1.0)

    def present(self, *, line_scale: float = 1.0, labels: bool = True) -> None:
        """Draw for a picture instead of for editing (:mod:`app.media.slides`, :mod:`app.media.export_html`).

        The start and goal gizmos lose their arrows and squares (the markers stay), lines
        drawn in screen pixels are ``line_scale`` times as wide, and with ``labels``
        False the 3-D labels are hidden (the picture draws its own, placed for its size).
        """
        with self._atomic():
            for gizmo in self.gizmos.handles.values():
                gizmo.disable_axes = True
                gizmo.disable_sliders = True
                gizmo.disable_rotations = True
            for graph in self.graphs.values():
                for layer in graph.edges.layers:
                    layer.handle.thickness = graph.look.edges_px * line_scale
            pools = [self.obstacle_labels, *(t.labels for t in self.traces.values())]
            for pool in pools:
                pool.hidden = not labels
                pool.shown.clear()  # the next render sends every label's state again
                for handle in pool.handles:
                    handle.visible = labels and handle.visible
            for trace in self.traces.values():
                trace.leaders.handle.visible = labels and trace.leaders.handle.visible
            for label in self.marker_labels.values():
                label.visible = labels
        self._last.pop("obstacles", None)
        self._last.pop("event_labels", None)

    def set_layer_flags(self, robot: bool, sensing: bool) -> None:
        """Remember the robot and sensing layer toggles for :meth:`render_robot`."""
        self._last["robot_layer"] = robot
        self._last["sensing_layer"] = sensing


# --------------------------------------------------------------------------- gizmos


class Gizmos:
    """The gizmos a user drags in one scope: start and goal, and in the edit tool more.

    In the edit tool every vertex and every obstacle has one too. A :class:`PlannerView`
    hangs its start and goal markers from them (``/handles/start`` and
    ``/handles/goal``); a classroom's presenter has them alone (:class:`GizmoView`), over
    the class's one drawing.

    Parameters
    ----------
    scene
        The scene the gizmos are added to (a viser ``SceneApi`` or a prefixed one).
    on_drag
        Called as ``on_drag(handle, (x, y), phase)`` when a user drags a gizmo.
    """

    def __init__(self, scene: Any, on_drag: HandleCallback | None = None) -> None:
        self.scene = scene
        self._on_drag = on_drag
        self.held: frozenset[Handle] = frozenset()
        """Handles a user holds now with these gizmos (another scope's are placed)."""
        self.place_dragged = False
        """Place gizmos even while they are dragged (gizmos nobody holds: a classroom's
        shared view, whose frames stand in for them)."""
        self.handles: dict[str, viser.TransformControlsHandle] = {
            name: self._add_end(name) for name in ("start", "goal")
        }
        """The start and goal gizmos."""
        self.vertex_handles: list[viser.TransformControlsHandle] = []
        self.vertex_slots: list[tuple[int, int]] = []
        """(obstacle, vertex) of each vertex gizmo shown, in order."""
        self.obstacle_handles: list[viser.TransformControlsHandle] = []
        self._drawn: Any = _MISSING

    def _add_end(self, name: str) -> viser.TransformControlsHandle:
        return self._add(f"/handles/{name}", 0.9, lambda: (name,))

    def _add(
        self,
        node: str,
        scale: float,
        which: Callable[[], Handle | None],
        **options: Any,
    ) -> viser.TransformControlsHandle:
        """Add a gizmo that moves in the floor's plane and reports ``which()`` handle."""
        gizmo = self.scene.add_transform_controls(
            node,
            scale=scale,
            active_axes=(True, True, False),
            disable_rotations=True,
            depth_test=False,
            **options,
        )
        gizmo.on_update(self._callback(which))
        return gizmo

    def _callback(self, which: Callable[[], Handle | None]) -> Callable[[Any], Any]:
        """Return a gizmo's update callback, reporting the handle ``which()`` names."""

        async def callback(event: Any) -> None:
            # async: viser runs these on its event loop in order, so "start", "update"
            # and "end" of one drag reach the controller in order (def callbacks may not).
            handle = which()
            if self._on_drag is None or handle is None:
                return
            x, y = float(event.target.position[0]), float(event.target.position[1])
            if event.phase == "end":
                self.held = self.held - {handle}
            else:
                self.held = self.held | {handle}
            self._on_drag(handle, (x, y), event.phase)

        return callback

    def _vertex(self, slot: int) -> Handle | None:
        """Return the handle vertex gizmo ``slot`` moves now (None: it is not shown)."""
        if slot >= len(self.vertex_slots):
            return None
        i, j = self.vertex_slots[slot]
        return ("vertex", i, j)

    def render(self, frame: Frame) -> None:
        """Place the gizmos on ``frame``'s scene, shown as its tool asks."""
        scene = frame.scene
        # Gizmos are left alone while a user drags them here, unless nobody holds
        # them (place_dragged), so watchers see the drag. A drag held in another scope
        # (a second presenter's browser) is placed here.
        dragging = frozenset() if self.place_dragged else frame.dragging & self.held
        key = (scene.start, scene.goal, scene.obstacles, frame.tool, dragging)
        if self._drawn is not _MISSING and _same(self._drawn, key):
            return
        self._drawn = key
        for name, xy in (("start", scene.start), ("goal", scene.goal)):
            if (name,) not in dragging:
                self.handles[name].position = (xy[0], xy[1], 0.0)
        editing = frame.tool == "edit"
        self._place_vertices(scene, editing, dragging)
        self._place_obstacles(scene, editing, dragging)

    def _place_vertices(
        self, scene: Any, editing: bool, dragging: frozenset[Handle]
    ) -> None:
        slots = [
            (i, j)
            for i, o in enumerate(scene.obstacles)
            for j in range(len(o.exterior.coords) - 1)
        ]
        top = HEIGHTS["obstacle"] + 0.01
        # Gizmos are made when the edit tool first needs them; a scene of thousands of
        # vertices (a CAD floor plan) gets none: its obstacles are moved whole.
        wanted = len(slots) if editing and len(slots) <= MAX_VERTEX_HANDLES else 0
        while len(self.vertex_handles) < wanted:
            k = len(self.vertex_handles)
            self.vertex_handles.append(
                self._add(
                    f"/handles/vertex/{k}",
                    0.45,
                    functools.partial(self._vertex, k),
                    disable_axes=True,
                    visible=False,
                )
            )
        self.vertex_slots = slots
        for k, gizmo in enumerate(self.vertex_handles):
            shown = k < wanted
            if shown:
                i, j = slots[k]
                if ("vertex", i, j) not in dragging:
                    x, y = scene.obstacles[i].exterior.coords[j]
                    _place(gizmo, (x, y, top))
            if gizmo.visible != shown:
                gizmo.visible = shown

    def _place_obstacles(
        self, scene: Any, editing: bool, dragging: frozenset[Handle]
    ) -> None:
        top = HEIGHTS["obstacle"] + 0.01
        n = len(scene.obstacles)
        while len(self.obstacle_handles) < (n if editing else 0):
            k = len(self.obstacle_handles)
            self.obstacle_handles.append(
                self._add(
                    f"/handles/obstacle/{k}",
                    0.8,
                    functools.partial(_obstacle, k),
                    visible=False,
                )
            )
        for k, gizmo in enumerate(self.obstacle_handles):
            shown = k < n and editing
            if shown and ("obstacle", k) not in dragging:
                _place(gizmo, _label_point(scene.obstacles[k], top + 0.01))
            if gizmo.visible != shown:
                gizmo.visible = shown


def _obstacle(slot: int) -> Handle:
    return ("obstacle", slot)


class GizmoView:
    """A view of the gizmos alone, in one browser's scope (a classroom's presenter).

    The browser sees the class's one drawing (``/shared``, broadcast) and drags these
    gizmos over it: the session is drawn once for everyone, the presenter included;
    the markers it moves are the shared drawing's, one frame behind the mouse.

    Parameters
    ----------
    target
        The browser's scope under a root (:class:`app.ui.scoped.ScopedTarget`).
    on_drag
        Called as ``on_drag(handle, (x, y), phase)`` when its user drags a gizmo.
    """

    def __init__(self, target: ScopedTarget, on_drag: HandleCallback) -> None:
        self.target = target
        """The scope drawn in (remove it to remove the gizmos)."""
        self.gizmos = Gizmos(target.scene, on_drag)
        """The gizmos."""

    def render(self, frame: Frame) -> None:
        """Place the gizmos on ``frame``, in one atomic batch."""
        with self.target.atomic():
            self.gizmos.render(frame)

    def render_robot(self, pose: RobotPose | None) -> None:
        """Nothing: the robot is the shared drawing's."""


# --------------------------------------------------------------------------- DSB adapters


def marker_size(radius: float) -> float:
    """Radius [m] of the start and goal markers: the robot's footprint, or a dot."""
    return max(radius, 0.12)


def event_labels(result: Any) -> list[tuple[str, tuple[float, float]]]:
    """(label, (x, y)) of each event of a trace: H1, D1, M3, L3 (Fig. 9.19)."""
    return [
        (event.label, (float(event.at[0]), float(event.at[1])))
        for event in getattr(result, "events", ())
    ]


class SensingPicture(NamedTuple):
    """What the view draws of a DSB robot's sensor at one instant (Fig. 9.16)."""

    center: tuple[float, float]
    """The robot r [m]."""
    radius: float
    """Sensor range R [m] (``inf``: unlimited, no circle)."""
    seen: FloatArray
    """Visible border within R, segments (N, 2, 2) [m]."""
    tangents: FloatArray
    """The local tangent graph: r -> O_i for every O_i, segments (M, 2, 2) [m]."""
    chosen: FloatArray
    """The planner's r_next: r -> O_i and O_i -> g, segments (K, 2, 2) [m]; none while
    the robot follows a border; just r -> g when it heads for the goal itself."""


def sensing_geometry(sensing: Mapping[str, Any]) -> SensingPicture:
    """Turn what the app's sampler attached to the pose into segments to draw.

    ``sensing`` is :func:`app.session.robot.sensing_at`'s mapping: ``center``, ``radius``,
    ``seen``, ``tangents``, and ``chosen`` (the planner's r_next, or None) with ``goal``.
    """
    center = sensing["center"]
    r = (float(center[0]), float(center[1]))
    chosen = sensing.get("chosen")
    goal = sensing.get("goal")
    lines: list[list[tuple[float, float]]] = []
    if chosen is not None:
        aim = (float(chosen[0]), float(chosen[1]))
        lines.append([r, aim])
        if goal is not None and math.dist(aim, goal) > 0:
            lines.append([aim, (float(goal[0]), float(goal[1]))])
    return SensingPicture(
        center=r,
        radius=float(sensing.get("radius", math.inf)),
        seen=_as_segments(sensing.get("seen")),
        tangents=_as_segments(sensing.get("tangents")),
        chosen=np.asarray(lines, dtype=np.float64).reshape(-1, 2, 2),
    )


def _as_segments(value: Any) -> FloatArray:
    if value is None:
        return np.zeros((0, 2, 2))
    return np.asarray(value, dtype=np.float64).reshape(-1, 2, 2)


# --------------------------------------------------------------------------- small helpers


class _Missing:
    pass


_MISSING = _Missing()


def _segments_2d(segments: FloatArray, z: float) -> FloatArray:
    if len(segments) == 0:
        return np.zeros((0, 2, 3))
    out = np.empty((len(segments), 2, 3))
    out[:, :, :2] = segments
    out[:, :, 2] = z
    return out


def _cross(at: Sequence[float] | FloatArray, size: float, z: float) -> FloatArray:
    x, y = float(at[0]), float(at[1])
    return np.array(
        [
            [[x - size, y - size, z], [x + size, y + size, z]],
            [[x - size, y + size, z], [x + size, y - size, z]],
        ]
    )


def live_keepouts(scene: Any, font: float) -> Keepouts:
    """Return what the live view's placed labels keep clear of in ``scene``.

    The start and goal disks with their names, and the obstacles' numbers when they are
    drawn (:data:`MAX_NUMBERED_OBSTACLES`), at ``font`` [m]
    (:func:`app.ui.floor_text.scene_keepouts`).
    """
    numbers = (
        [(str(i + 1), _label_point(o, 0.0)[:2]) for i, o in enumerate(scene.obstacles)]
        if len(scene.obstacles) <= MAX_NUMBERED_OBSTACLES
        else []
    )
    ends = [("start", scene.start), ("goal", scene.goal)]
    return scene_keepouts(ends, marker_size(scene.robot.radius), numbers, font)


def _label_point(polygon: Polygon, z: float) -> tuple[float, float, float]:
    """Where a polygon's label and gizmo sit: a point inside it, at height ``z``."""
    x, y = _inner_point(polygon)
    return (x, y, z)


def _make_inner_point(polygon: Polygon) -> tuple[float, float]:
    # A self-intersecting ring's centroid can lie far outside it (its signed areas
    # cancel): label what make_valid makes of it, or the mean of its vertices.
    shape = polygon if polygon.is_valid else shapely.make_valid(polygon)
    try:
        p = shape.representative_point()
        if not p.is_empty:
            return (float(p.x), float(p.y))
    except Exception:  # a degenerate ring
        pass
    x, y = np.asarray(polygon.exterior.coords)[:-1].mean(axis=0)
    return (float(x), float(y))


# Kept by value like the drawings: 32 obstacles' labels and gizmos each frame.
_inner_point = _Kept(_make_inner_point)


def floor_bounds(scene: Any) -> tuple[float, float, float, float]:
    """Floor area to draw the grid on: the boundary, or everything in the scene plus a margin.

    Whole metres, so the grid's lines fall on them; a picture's box is
    :func:`app.media.camera.picture_bounds`.
    """
    if scene.boundary is not None:
        return _whole_metres(*scene.boundary.bounds)
    pts = [np.asarray(o.exterior.coords) for o in scene.obstacles] + [
        np.array([scene.start, scene.goal])
    ]
    allp = np.vstack(pts)
    x0, y0 = allp.min(axis=0) - 2.0
    x1, y1 = allp.max(axis=0) + 2.0
    return _whole_metres(x0, y0, x1, y1)


def _whole_metres(
    x0: float, y0: float, x1: float, y1: float
) -> tuple[float, float, float, float]:
    """Round a box outward to whole metres, as floats.

    Floats, not ints: ``math.floor(1e20)`` is an int too big for msgpack, and viser's
    sender to every browser would die on the message carrying it.

    Examples
    --------
    >>> _whole_metres(0.5, -0.5, 1e20, 2.0)
    (0.0, -1.0, 1e+20, 2.0)
    """
    return (
        float(np.floor(x0)),
        float(np.floor(y0)),
        float(np.ceil(x1)),
        float(np.ceil(y1)),
    )
