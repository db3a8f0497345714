"""Where the camera of a picture goes: the box a scene's picture shows, and a camera on it.

Pure geometry (numpy, no browser): :func:`picture_bounds` is the floor box a picture of a
scene must show, :func:`frame_camera` a :class:`CameraPose` that shows a box whole, with a
margin, in a picture of a given size, seen from straight above (``"top"``, a plan) or in
perspective. The slides' layout (:mod:`app.media.slides`) and Explain's pictures place
their cameras with it; :func:`app.media.browser.apply_camera` puts a pose in a browser.
"""

from __future__ import annotations

__all__ = [
    "TOP_FOV",
    "VIEWS",
    "CameraPose",
    "frame_camera",
    "picture_bounds",
]

import dataclasses
import math
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

if TYPE_CHECKING:
    from planners.scene import Scene

VIEWS = ("top", "perspective")
"""Camera framings :func:`frame_camera` knows."""

TOP_FOV = math.radians(20.0)
"""Vertical field of view of the ``"top"`` view [rad]. A narrow field of view keeps the top
view close to a plan drawing: layers lifted a few millimetres above the floor (paths over
expanded obstacles) stay aligned with them."""
_PERSPECTIVE_FOV = math.radians(40.0)
_PERSPECTIVE_AZIMUTH = math.radians(-105.0)  # looking from slightly left of "south"
_PERSPECTIVE_ELEVATION = math.radians(50.0)
_MARGIN = 0.06  # of the larger side of the scene, on every side


@dataclasses.dataclass(frozen=True)
class CameraPose:
    """A viser client camera, in world coordinates (z up, metres)."""

    position: tuple[float, float, float]
    """Camera centre [m]."""
    look_at: tuple[float, float, float]
    """Point the camera looks at [m]."""
    up: tuple[float, float, float]
    """Up direction of the camera's orbit (the image's up for the top view)."""
    fov: float
    """Vertical field of view [rad]."""
    near: float
    """Near clipping distance [m]."""
    far: float
    """Far clipping distance [m]."""


def picture_bounds(scene: Scene) -> tuple[float, float, float, float]:
    """Return the box ``(xmin, ymin, xmax, ymax)`` a picture of ``scene`` must show [m].

    It holds the boundary, every obstacle grown by the robot's radius (so the expanded
    regions fit), the start and the goal (also grown by the radius: the robot is drawn
    there).

    Parameters
    ----------
    scene
        The scene.

    Returns
    -------
    tuple of float
        ``(xmin, ymin, xmax, ymax)`` [m].

    Examples
    --------
    >>> from planners import load_scene
    >>> scene = load_scene({"format": 1, "obstacles": [[[0, 0], [2, 0], [2, 2]]],
    ...                     "start": [-1, 1], "goal": [3, 1], "robot": {"radius": 0.5}})
    >>> picture_bounds(scene)
    (-1.5, -0.5, 3.5, 2.5)
    """
    radius = float(scene.robot.radius)
    boxes: list[tuple[float, float, float, float]] = []
    if scene.boundary is not None:
        boxes.append(tuple(scene.boundary.bounds))  # type: ignore[arg-type]
    for obstacle in scene.obstacles:
        x0, y0, x1, y1 = obstacle.bounds
        boxes.append((x0 - radius, y0 - radius, x1 + radius, y1 + radius))
    for x, y in (scene.start, scene.goal):
        boxes.append((x - radius, y - radius, x + radius, y + radius))
    b = np.asarray(boxes, dtype=np.float64)
    return (
        float(b[:, 0].min()),
        float(b[:, 1].min()),
        float(b[:, 2].max()),
        float(b[:, 3].max()),
    )


def frame_camera(
    bounds: tuple[float, float, float, float],
    width: int,
    height: int,
    view: str = "top",
) -> CameraPose:
    """Place a camera that shows ``bounds`` whole, with a margin, in a W x H picture.

    Parameters
    ----------
    bounds
        ``(xmin, ymin, xmax, ymax)`` of what must be visible [m], see :func:`picture_bounds`.
    width, height
        Picture size [px]; only their ratio matters.
    view
        ``"top"``: straight down, +x to the right and +y up in the picture, a narrow
        field of view (20 degrees) so it reads like a plan. ``"perspective"``: from above
        the lower-left, 50 degrees above the floor; the box on the floor is fitted to
        the picture, with the margin (the tops of obstacles and walls are not measured).

    Returns
    -------
    CameraPose

    Examples
    --------
    >>> pose = frame_camera((0.0, 0.0, 10.0, 8.0), 1280, 800)
    >>> pose.look_at, pose.up
    ((5.0, 4.0, 0.0), (0.0, 1.0, 0.0))
    >>> round(pose.position[2], 3)  # (4 m + 0.6 m margin) / tan(10 deg): the height fills it
    26.088
    """
    if view not in VIEWS:
        raise ValueError(f"unknown view {view!r} (known: {', '.join(VIEWS)})")
    xmin, ymin, xmax, ymax = bounds
    cx, cy = (xmin + xmax) / 2, (ymin + ymax) / 2
    margin = _MARGIN * max(xmax - xmin, ymax - ymin, 1e-3)
    half_x = (xmax - xmin) / 2 + margin
    half_y = (ymax - ymin) / 2 + margin
    aspect = width / height
    if view == "top":
        fov = TOP_FOV
        # Half the visible floor is distance * tan(fov / 2) tall and `aspect` times wider.
        distance = max(half_y, half_x / aspect) / math.tan(fov / 2)
        return CameraPose(
            position=(cx, cy, distance),
            look_at=(cx, cy, 0.0),
            up=(0.0, 1.0, 0.0),
            fov=fov,
            near=distance / 10,
            far=distance * 10,
        )
    return _perspective_camera((cx, cy), (half_x, half_y), aspect)


def _perspective_camera(
    center: tuple[float, float], half: tuple[float, float], aspect: float
) -> CameraPose:
    """Place the ``"perspective"`` camera of :func:`frame_camera` on a floor box of half-sizes ``half``."""
    (cx, cy), (half_x, half_y) = center, half
    fov = _PERSPECTIVE_FOV
    ce = math.cos(_PERSPECTIVE_ELEVATION)
    back = np.array(
        [
            ce * math.cos(_PERSPECTIVE_AZIMUTH),
            ce * math.sin(_PERSPECTIVE_AZIMUTH),
            math.sin(_PERSPECTIVE_ELEVATION),
        ]
    )
    corners = np.array(
        [
            [x, y, 0.0]
            for x in (cx - half_x, cx + half_x)
            for y in (cy - half_y, cy + half_y)
        ]
    )
    target = np.array([cx, cy, 0.0])
    distance = 1.0
    # Fit the floor box: find the distance at which its corners just fill the picture,
    # then slide camera and target sideways so the box is centred; twice is plenty.
    for _ in range(3):
        lo, hi = 1e-3, 1e6
        for _ in range(80):
            distance = math.sqrt(lo * hi)
            extent, _ = _projected_extent(
                corners, target + distance * back, target, fov, aspect
            )
            lo, hi = (distance, hi) if extent > 1.0 else (lo, distance)
        distance = hi
        _, shift = _projected_extent(
            corners, target + distance * back, target, fov, aspect
        )
        target = target + shift
    position = target + distance * back
    return CameraPose(
        position=(float(position[0]), float(position[1]), float(position[2])),
        look_at=(float(target[0]), float(target[1]), float(target[2])),
        up=(0.0, 0.0, 1.0),
        fov=fov,
        near=distance / 20,
        far=distance * 10,
    )


def _projected_extent(
    points: npt.NDArray[np.float64],
    position: npt.NDArray[np.float64],
    target: npt.NDArray[np.float64],
    fov: float,
    aspect: float,
) -> tuple[float, npt.NDArray[np.float64]]:
    """Half-size of ``points`` in the picture (1 fills it) and the shift that centres them."""
    forward = (target - position) / np.linalg.norm(target - position)
    right = np.cross(forward, (0.0, 0.0, 1.0))
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    rel = points - position
    depth = rel @ forward
    tan_y = math.tan(fov / 2)
    nx = (rel @ right) / (depth * tan_y * aspect)
    ny = (rel @ up) / (depth * tan_y)
    mid_x, mid_y = (nx.max() + nx.min()) / 2, (ny.max() + ny.min()) / 2
    extent = max((nx.max() - nx.min()) / 2, (ny.max() - ny.min()) / 2)
    # Moving camera and target together by (right * a + up * b) moves the picture's
    # centre by a / (depth tan) in x; use the target's depth as the typical depth.
    d0 = float(np.linalg.norm(target - position))
    shift = right * mid_x * d0 * tan_y * aspect + up * mid_y * d0 * tan_y
    return float(extent), shift
