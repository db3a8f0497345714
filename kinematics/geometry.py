r"""Robot meshes for the app: body, heading marker, wheels with visible rollers or spokes.

Everything is in the **robot frame**: ``x_m`` to the right (sway), ``y_m`` forward, z up,
metres, the floor at z = 0. The robot frame sits in the world at ``(x, y, 0)`` rotated
about z by ``phi - pi/2`` (:func:`robot_transform`, :func:`yaw_wxyz`), because the heading
``phi`` is the world angle of ``y_m``.

Each wheel is separate so the app can spin it: its ``mesh`` and ``marking`` are given in a
**wheel-local frame**, parallel to the robot frame with its origin at the wheel's hub. To
draw wheel ``w`` turned by angle ``a`` (the integral of its rate, see
:attr:`kinematics.trajectory.Trajectory.wheel_angles`), place that frame at ``w.hub`` in the
robot frame, rotated by ``+a`` about ``w.axle`` (right-hand rule): :func:`wheel_transform`,
or ``position=w.hub, wxyz=axis_angle_wxyz(w.axle, a)`` for a scene-graph child node.

Rate sign, consistent with eq. 9.1: a positive rate rolls the robot, at that wheel, in the
rolling direction :math:`\mathbf d_i = (-\sin\beta_i, \cos\beta_i, 0)`. For a wheel rolling
without slipping with angular velocity :math:`\dot\theta\,\mathbf a` the hub moves at
:math:`\dot\theta\, r\, (\mathbf a \times \hat{\mathbf z})`, so the axle axis is
:math:`\mathbf a_i = \hat{\mathbf z} \times \mathbf d_i = (-\cos\beta_i, -\sin\beta_i, 0)`,
pointing from the wheel towards the robot's centre. Turning a wheel by a positive angle
about it moves its lowest point backwards (along :math:`-\mathbf d_i`) relative to the hub.

Parts have distinct colours (vertex colours on each mesh, and the same colour as an RGB
tuple for renderers that take one colour per mesh): body, heading marker, caster, each
wheel and each wheel's marking (rollers or spokes).
"""

from __future__ import annotations

__all__ = [
    "BODY_COLOR",
    "CASTER_COLOR",
    "HEADING_COLOR",
    "MARKING_COLOR",
    "WHEEL_COLOR",
    "Part",
    "RobotGeometry",
    "WheelGeometry",
    "axis_angle_wxyz",
    "differential_robot",
    "holonomic_robot",
    "robot_geometry",
    "robot_transform",
    "rotation_matrix",
    "wheel_transform",
    "yaw_wxyz",
]

import dataclasses
import math
from collections.abc import Sequence
from typing import cast

import numpy as np
import numpy.typing as npt
import trimesh
from trimesh.visual import ColorVisuals

from kinematics import differential, holonomic
from kinematics._arrays import FloatArray, check_positive
from kinematics.robot import RobotParams

RGB = tuple[int, int, int]

BODY_COLOR: RGB = (70, 130, 180)
"""Body: steel blue."""
HEADING_COLOR: RGB = (220, 50, 47)
"""Heading marker (points along ``y_m``): red."""
WHEEL_COLOR: RGB = (45, 45, 50)
"""Wheel hub or tyre: near black."""
MARKING_COLOR: RGB = (255, 165, 0)
"""Rollers and spokes, so rotation is visible: orange."""
CASTER_COLOR: RGB = (150, 150, 150)
"""Caster ball: grey."""

_SECTIONS = 24  # facets around a wheel; rollers and spokes use fewer


def _colored(mesh: trimesh.Trimesh, color: RGB) -> trimesh.Trimesh:
    rgba = np.array([*color, 255], dtype=np.uint8)
    mesh.visual = ColorVisuals(
        mesh, vertex_colors=np.tile(rgba, (len(mesh.vertices), 1))
    )
    return mesh


def _concatenate(meshes: Sequence[trimesh.Trimesh]) -> trimesh.Trimesh:
    """Concatenate meshes (colours kept), typed as the Trimesh it always is here."""
    return cast("trimesh.Trimesh", trimesh.util.concatenate(list(meshes)))


def rotation_matrix(axis: npt.ArrayLike, angle: float) -> FloatArray:
    """Return the 3x3 rotation by ``angle`` about ``axis`` (right-hand rule, Rodrigues).

    Parameters
    ----------
    axis
        Rotation axis, shape (3,); need not be unit length.
    angle
        Angle [rad].

    Returns
    -------
    numpy.ndarray
        Shape (3, 3).

    Examples
    --------
    >>> (rotation_matrix([0, 0, 1], np.pi / 2) @ [1.0, 0.0, 0.0]).round(12)
    array([0., 1., 0.])
    """
    a = np.asarray(axis, dtype=np.float64)
    a = a / np.linalg.norm(a)
    k = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
    return np.eye(3) + math.sin(angle) * k + (1.0 - math.cos(angle)) * (k @ k)


def axis_angle_wxyz(axis: npt.ArrayLike, angle: float) -> FloatArray:
    """Return the unit quaternion ``(w, x, y, z)`` of a rotation by ``angle`` about ``axis``.

    Parameters
    ----------
    axis
        Rotation axis, shape (3,).
    angle
        Angle [rad].

    Returns
    -------
    numpy.ndarray
        Shape (4,), scalar first (the convention of viser's ``wxyz``).

    Examples
    --------
    >>> axis_angle_wxyz([0, 0, 1], np.pi).round(12)
    array([0., 0., 0., 1.])
    """
    a = np.asarray(axis, dtype=np.float64)
    a = a / np.linalg.norm(a)
    return np.array([math.cos(angle / 2.0), *(math.sin(angle / 2.0) * a)])


def yaw_wxyz(phi: float) -> FloatArray:
    """Return the orientation of the robot frame in the world for heading ``phi``.

    A rotation about z by ``phi - pi/2``: it takes ``y_m`` to ``(cos phi, sin phi, 0)``.

    Parameters
    ----------
    phi
        Heading [rad].

    Returns
    -------
    numpy.ndarray
        Quaternion ``(w, x, y, z)``, shape (4,).

    Examples
    --------
    >>> yaw_wxyz(np.pi / 2)  # robot frame == world frame
    array([1., 0., 0., 0.])
    """
    return axis_angle_wxyz([0.0, 0.0, 1.0], phi - math.pi / 2.0)


def robot_transform(pose: npt.ArrayLike) -> FloatArray:
    """Return the 4x4 transform from the robot frame to the world for ``(x, y, phi)``.

    Parameters
    ----------
    pose
        ``(x, y, phi)`` [m, m, rad].

    Returns
    -------
    numpy.ndarray
        Shape (4, 4).

    Examples
    --------
    >>> T = robot_transform([1.0, 2.0, 0.0])  # facing +x: forward y_m -> world +x
    >>> (T @ [0.0, 1.0, 0.0, 1.0]).round(12)
    array([2., 2., 0., 1.])
    """
    x, y, phi = (float(v) for v in np.asarray(pose, dtype=np.float64))
    t = np.eye(4)
    t[:3, :3] = rotation_matrix([0.0, 0.0, 1.0], phi - math.pi / 2.0)
    t[:3, 3] = [x, y, 0.0]
    return t


def _frame_z_to(axis: FloatArray, origin: npt.ArrayLike) -> FloatArray:
    """Return a 4x4 transform taking the local z axis to ``axis`` and the origin to ``origin``."""
    z = axis / np.linalg.norm(axis)
    helper = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(helper, z)
    x /= np.linalg.norm(x)
    t = np.eye(4)
    t[:3, :3] = np.column_stack([x, np.cross(z, x), z])
    t[:3, 3] = np.asarray(origin, dtype=np.float64)
    return t


def _cylinder(
    radius: float, length: float, axis: FloatArray, center: npt.ArrayLike, sections: int
) -> trimesh.Trimesh:
    return trimesh.creation.cylinder(
        radius=radius,
        height=length,
        sections=sections,
        transform=_frame_z_to(axis, center),
    )


def _box(
    extents: Sequence[float], axes: FloatArray, center: npt.ArrayLike
) -> trimesh.Trimesh:
    """Return a box with ``extents`` along the columns of ``axes``, centred at ``center``."""
    t = np.eye(4)
    t[:3, :3] = axes
    t[:3, 3] = np.asarray(center, dtype=np.float64)
    return trimesh.creation.box(extents=extents, transform=t)


def _prism(outline: FloatArray, z0: float, z1: float) -> trimesh.Trimesh:
    """Return a closed prism over a convex counter-clockwise polygon ``outline`` (n, 2)."""
    n = len(outline)
    bottom = np.column_stack([outline, np.full(n, z0)])
    top = np.column_stack([outline, np.full(n, z1)])
    faces = []
    for i in range(1, n - 1):  # fans: bottom faces down, top faces up
        faces.append([0, i + 1, i])
        faces.append([n, n + i, n + i + 1])
    for i in range(n):
        j = (i + 1) % n
        faces.append([i, j, n + j])
        faces.append([i, n + j, n + i])
    return trimesh.Trimesh(
        vertices=np.vstack([bottom, top]), faces=np.array(faces), process=False
    )


@dataclasses.dataclass(frozen=True, eq=False)
class WheelGeometry:
    """One driven wheel: meshes in its wheel-local frame plus where it sits and turns."""

    index: int
    """Wheel number minus one (wheel 1 of the chapter is index 0)."""
    beta: float
    """Wheel angle beta_i in the robot frame [rad]."""
    hub: FloatArray
    """Hub centre in the robot frame, ``(L cos beta, L sin beta, r)`` [m], shape (3,)."""
    axle: FloatArray
    """Unit spin axis in the robot frame, ``(-cos beta, -sin beta, 0)``: a positive rate
    turns the wheel by a positive angle about it (right-hand rule)."""
    rolling_direction: FloatArray
    """Unit direction the robot moves at this wheel for a positive rate, eq. 9.1:
    ``(-sin beta, cos beta, 0)`` = ``cross(axle, z)``."""
    radius: float
    """Wheel radius r [m]."""
    width: float
    """Wheel width along the axle [m]."""
    mesh: trimesh.Trimesh
    """Hub/tyre, wheel-local frame (robot axes, origin at the hub)."""
    marking: trimesh.Trimesh
    """Rollers or spokes that make rotation visible, same frame."""
    color: RGB = WHEEL_COLOR
    """Colour of :attr:`mesh`."""
    marking_color: RGB = MARKING_COLOR
    """Colour of :attr:`marking`."""


def wheel_transform(wheel: WheelGeometry, angle: float) -> FloatArray:
    """Return the 4x4 transform from the wheel-local frame to the robot frame.

    Parameters
    ----------
    wheel
        The wheel.
    angle
        Wheel angle [rad], the integral of its rate.

    Returns
    -------
    numpy.ndarray
        Shape (4, 4): rotate by ``angle`` about ``wheel.axle``, then move to ``wheel.hub``.

    Examples
    --------
    >>> w = differential_robot().wheels[0]  # right wheel, rolls the robot forward (+y_m)
    >>> bottom = [0.0, 0.0, -w.radius, 1.0]  # lowest point, wheel-local
    >>> moved = wheel_transform(w, 0.1) @ bottom - wheel_transform(w, 0.0) @ bottom
    >>> bool(moved[1] < 0)  # the contact point moves backwards: the robot rolls forwards
    True
    """
    t = np.eye(4)
    t[:3, :3] = rotation_matrix(wheel.axle, angle)
    t[:3, 3] = wheel.hub
    return t


@dataclasses.dataclass(frozen=True, eq=False)
class Part:
    """One rigid, single-coloured piece of the robot placed in the robot frame."""

    name: str
    """``"body"``, ``"heading"``, ``"caster"``, ``"wheel<i>"`` or ``"wheel<i>_marking"``."""
    mesh: trimesh.Trimesh
    """Mesh in the robot frame [m]."""
    color: RGB
    """RGB colour, 0-255."""


@dataclasses.dataclass(frozen=True, eq=False)
class RobotGeometry:
    """All meshes of one robot, in the robot frame (wheels in their wheel-local frames)."""

    kind: str
    """``"holonomic"`` or ``"differential"``."""
    radius: float
    """Radius of the drawn body [m]."""
    body: trimesh.Trimesh
    """Round body (a disc), robot frame."""
    heading: trimesh.Trimesh
    """Arrow-shaped marker on top of the body pointing along ``y_m``, robot frame."""
    wheels: tuple[WheelGeometry, ...]
    """The driven wheels, in the order of the wheel rates."""
    caster: trimesh.Trimesh | None = None
    """The differential robot's free caster, robot frame; None for the holonomic robot."""
    body_color: RGB = BODY_COLOR
    """Colour of :attr:`body`."""
    heading_color: RGB = HEADING_COLOR
    """Colour of :attr:`heading`."""
    caster_color: RGB = CASTER_COLOR
    """Colour of :attr:`caster`."""

    def parts(self, wheel_angles: npt.ArrayLike | None = None) -> list[Part]:
        """Return every part placed in the robot frame, wheels turned by ``wheel_angles``.

        Parameters
        ----------
        wheel_angles
            One angle per wheel [rad]; None means all zero.

        Returns
        -------
        list of Part
            Body, heading marker, caster (if any), then each wheel and its marking.
        """
        angles = (
            np.zeros(len(self.wheels))
            if wheel_angles is None
            else np.asarray(wheel_angles, float)
        )
        if angles.shape != (len(self.wheels),):
            raise ValueError(
                f"need {len(self.wheels)} wheel angles, got shape {angles.shape}"
            )
        out = [
            Part("body", self.body, self.body_color),
            Part("heading", self.heading, self.heading_color),
        ]
        if self.caster is not None:
            out.append(Part("caster", self.caster, self.caster_color))
        for w, a in zip(self.wheels, angles, strict=True):
            t = wheel_transform(w, float(a))
            out.append(
                Part(f"wheel{w.index}", w.mesh.copy().apply_transform(t), w.color)
            )
            out.append(
                Part(
                    f"wheel{w.index}_marking",
                    w.marking.copy().apply_transform(t),
                    w.marking_color,
                )
            )
        return out

    def to_mesh(self, wheel_angles: npt.ArrayLike | None = None) -> trimesh.Trimesh:
        """Return one coloured mesh of the whole robot in the robot frame (for snapshots).

        Parameters
        ----------
        wheel_angles
            One angle per wheel [rad]; None means all zero.

        Returns
        -------
        trimesh.Trimesh
            All parts concatenated, with their vertex colours.
        """
        meshes = [_colored(p.mesh.copy(), p.color) for p in self.parts(wheel_angles)]
        return _concatenate(meshes)


def _body(radius: float, r: float) -> tuple[trimesh.Trimesh, trimesh.Trimesh]:
    # The body floats from 0.5 r to 1.5 r: the wheels (up to 2 r) poke out above it, so
    # their rollers or spokes stay visible from above even when L < radius.
    z0, z1 = 0.5 * r, 1.5 * r
    body = _cylinder(
        radius, z1 - z0, np.array([0.0, 0.0, 1.0]), [0.0, 0.0, 0.5 * (z0 + z1)], 48
    )
    arrow = radius * np.array([[0.0, 0.85], [-0.3, 0.25], [0.0, 0.4], [0.3, 0.25]])
    # The arrow outline is not convex at its notch: build it from two convex halves.
    left = _prism(arrow[[0, 1, 2]], z1, z1 + 0.2 * r)
    right = _prism(arrow[[0, 2, 3]], z1, z1 + 0.2 * r)
    return _colored(body, BODY_COLOR), _colored(
        _concatenate([left, right]), HEADING_COLOR
    )


def _wheel_frame(beta: float) -> tuple[FloatArray, FloatArray]:
    axle = np.array([-math.cos(beta), -math.sin(beta), 0.0])
    rolling = np.array([-math.sin(beta), math.cos(beta), 0.0])
    return axle, rolling


def _omni_wheel(
    beta: float, r: float, width: float, n_rollers: int
) -> tuple[trimesh.Trimesh, trimesh.Trimesh]:
    """Hub plus two staggered rows of free rollers (Fig. 9.5), in the wheel-local frame."""
    axle, d = _wheel_frame(beta)
    z = np.array([0.0, 0.0, 1.0])
    hub = _cylinder(0.55 * r, 0.9 * width, axle, [0.0, 0.0, 0.0], _SECTIONS)
    roller_r = 0.22 * r
    length = 1.6 * (r - roller_r) * math.sin(math.pi / n_rollers)
    # Roller centres sit so that the rollers' outer end rims just reach radius r: the
    # wheel touches the floor, never dips through it.
    ring = math.sqrt(r * r - (0.5 * length) ** 2) - roller_r
    # One roller along z, instanced by plain array maths: creating 2 n cylinders one by
    # one dominated the build time.
    roller = trimesh.creation.cylinder(radius=roller_r, height=length, sections=10)
    rv, rf = np.asarray(roller.vertices), np.asarray(roller.faces)
    vertices, faces = [], []
    for row, offset in enumerate((-0.25 * width, 0.25 * width)):
        for j in range(n_rollers):
            g = 2.0 * math.pi * (j + 0.5 * row) / n_rollers
            radial = math.cos(g) * d + math.sin(g) * z
            tangent = -math.sin(g) * d + math.cos(g) * z
            frame = _frame_z_to(tangent, ring * radial + offset * axle)
            faces.append(rf + len(vertices) * len(rv))
            vertices.append(rv @ frame[:3, :3].T + frame[:3, 3])
    rollers = trimesh.Trimesh(np.vstack(vertices), np.vstack(faces), process=False)
    pieces = [rollers]
    # A stripe on the outer face (the side away from the robot, -axle) pointing up at
    # angle 0, so rotation reads clearly even when the rollers alias.
    stripe = _box(
        [0.08 * r, 0.5 * r, 0.04 * r],
        np.column_stack([d, z, axle]),
        [0.0, 0.0, 0.0] + 0.25 * r * z - (0.45 * width + 0.02 * r) * axle,
    )
    pieces.append(stripe)
    return _colored(hub, WHEEL_COLOR), _colored(_concatenate(pieces), MARKING_COLOR)


def _plain_wheel(
    beta: float, r: float, width: float
) -> tuple[trimesh.Trimesh, trimesh.Trimesh]:
    """Tyre plus three spokes on each face, in the wheel-local frame."""
    axle, d = _wheel_frame(beta)
    z = np.array([0.0, 0.0, 1.0])
    tyre = _cylinder(r, width, axle, [0.0, 0.0, 0.0], _SECTIONS)
    spokes = []
    for side in (-1.0, 1.0):
        for j in range(3):
            g = math.pi / 2 + 2.0 * math.pi * j / 3.0
            radial = math.cos(g) * d + math.sin(g) * z
            across = np.cross(axle, radial)
            spokes.append(
                _box(
                    [0.12 * r, 0.8 * r, 0.04 * r],
                    np.column_stack([across, radial, axle]),
                    0.4 * r * radial + side * (0.5 * width + 0.02 * r) * axle,
                )
            )
    return _colored(tyre, WHEEL_COLOR), _colored(_concatenate(spokes), MARKING_COLOR)


def _wheels(
    betas: Sequence[float], r: float, L: float, width: float, n_rollers: int | None
) -> tuple[WheelGeometry, ...]:
    wheels = []
    for i, beta in enumerate(betas):
        axle, rolling = _wheel_frame(beta)
        mesh, marking = (
            _plain_wheel(beta, r, width)
            if n_rollers is None
            else _omni_wheel(beta, r, width, n_rollers)
        )
        hub = np.array([L * math.cos(beta), L * math.sin(beta), r])
        for a in (hub, axle, rolling):
            a.setflags(write=False)
        wheels.append(
            WheelGeometry(
                index=i,
                beta=float(beta),
                hub=hub,
                axle=axle,
                rolling_direction=rolling,
                radius=r,
                width=width,
                mesh=mesh,
                marking=marking,
            )
        )
    return tuple(wheels)


def _body_radius(radius: float, r: float, L: float) -> float:
    if not math.isfinite(radius) or radius < 0.0:
        raise ValueError(f"radius must be a finite number >= 0, got {radius!r}")
    # A point robot (radius 0) still needs something to look at: a body around the wheels.
    return radius if radius > 0.0 else L + r


def holonomic_robot(
    radius: float = 0.3,
    wheel_radius: float = 0.05,
    wheel_distance: float = 0.25,
    betas: Sequence[float] | None = None,
    *,
    wheel_width: float | None = None,
    n_rollers: int = 8,
) -> RobotGeometry:
    """Build the three-omni-wheel robot of Fig. 9.3/9.4.

    Parameters
    ----------
    radius
        Body radius [m]; 0 (a point robot) draws a body of radius ``L + r``.
    wheel_radius
        Wheel radius r [m].
    wheel_distance
        Centre-to-wheel distance L [m].
    betas
        Wheel angles [rad]; None means 30, 150, 270 degrees.
    wheel_width
        Width of a wheel along its axle [m]; None means ``0.6 r``.
    n_rollers
        Rollers per row (two staggered rows per wheel).

    Returns
    -------
    RobotGeometry
        Body, heading marker and one :class:`WheelGeometry` per angle.

    Examples
    --------
    >>> g = holonomic_robot()
    >>> [round(float(np.degrees(w.beta))) for w in g.wheels]
    [30, 150, 270]
    >>> g.wheels[2].hub.round(6).tolist()  # the back wheel, at (L cos 270, L sin 270, r)
    [-0.0, -0.25, 0.05]
    """
    r = check_positive("wheel_radius", wheel_radius)
    L = check_positive("wheel_distance", wheel_distance)
    width = (
        0.6 * r if wheel_width is None else check_positive("wheel_width", wheel_width)
    )
    if n_rollers < 3:
        raise ValueError(f"n_rollers must be >= 3, got {n_rollers}")
    b = holonomic.DEFAULT_BETAS if betas is None else tuple(float(x) for x in betas)
    R = _body_radius(radius, r, L)
    body, heading = _body(R, r)
    return RobotGeometry(
        "holonomic", R, body, heading, _wheels(b, r, L, width, n_rollers)
    )


def differential_robot(
    radius: float = 0.3,
    wheel_radius: float = 0.05,
    wheel_distance: float = 0.25,
    *,
    wheel_width: float | None = None,
) -> RobotGeometry:
    """Build the differential-drive robot of Fig. 9.7: body, two wheels, a caster at the back.

    Parameters
    ----------
    radius
        Body radius [m]; 0 (a point robot) draws a body of radius ``L + r``.
    wheel_radius
        Wheel radius r [m].
    wheel_distance
        Centre-to-wheel distance L [m]; wheel 1 at ``(L, 0)``, wheel 2 at ``(-L, 0)``.
    wheel_width
        Width of a wheel along its axle [m]; None means ``0.5 r``.

    Returns
    -------
    RobotGeometry
        Body, heading marker, caster and the two wheels (right, then left).

    Examples
    --------
    >>> g = differential_robot(wheel_distance=0.2)
    >>> [w.hub.round(6).tolist() for w in g.wheels]
    [[0.2, 0.0, 0.05], [-0.2, 0.0, 0.05]]
    >>> g.wheels[0].axle.round(6).tolist()  # points from the right wheel to the centre
    [-1.0, -0.0, 0.0]
    """
    r = check_positive("wheel_radius", wheel_radius)
    L = check_positive("wheel_distance", wheel_distance)
    width = (
        0.5 * r if wheel_width is None else check_positive("wheel_width", wheel_width)
    )
    R = _body_radius(radius, r, L)
    body, heading = _body(R, r)
    # The caster ball touches the floor behind the axle; its top overlaps the body's
    # underside (0.5 r) so it looks attached.
    c = 0.3 * r
    caster = trimesh.creation.icosphere(subdivisions=2, radius=c)
    caster.apply_translation([0.0, -0.65 * R, c])
    return RobotGeometry(
        "differential",
        R,
        body,
        heading,
        _wheels(differential.BETAS, r, L, width, None),
        caster=_colored(caster, CASTER_COLOR),
    )


def robot_geometry(
    robot: RobotParams, *, wheel_width: float | None = None, n_rollers: int = 8
) -> RobotGeometry:
    """Build the meshes for ``robot`` (dispatch on its kind).

    Parameters
    ----------
    robot
        Kind, radius, wheel radius, wheel distance and wheel angles.
    wheel_width
        Width of a wheel along its axle [m]; None: the kind's default.
    n_rollers
        Rollers per row of an omni-wheel (holonomic robot only).

    Returns
    -------
    RobotGeometry
        The robot's meshes.

    Examples
    --------
    >>> len(robot_geometry(RobotParams("differential")).wheels)
    2
    """
    if robot.kind == "differential":
        return differential_robot(
            robot.radius,
            robot.wheel_radius,
            robot.wheel_distance,
            wheel_width=wheel_width,
        )
    return holonomic_robot(
        robot.radius,
        robot.wheel_radius,
        robot.wheel_distance,
        robot.wheel_angles,
        wheel_width=wheel_width,
        n_rollers=n_rollers,
    )
