"""Robot meshes: parts, wheel placement, axle signs consistent with eq. 9.1."""

from __future__ import annotations

import math

import networkx as nx
import numpy as np
import pytest
import trimesh
from numpy.testing import assert_allclose

from kinematics import geometry, holonomic, plan_trajectory
from kinematics.geometry import (
    axis_angle_wxyz,
    differential_robot,
    holonomic_robot,
    robot_geometry,
    robot_transform,
    rotation_matrix,
    wheel_transform,
    yaw_wxyz,
)
from tests.conftest import run_code
from tests.kinematics.kin_helpers import DIFFERENTIAL, HOLONOMIC

Z = np.array([0.0, 0.0, 1.0])


@pytest.fixture(params=["holonomic", "differential"])
def geom(request) -> geometry.RobotGeometry:
    return robot_geometry(HOLONOMIC if request.param == "holonomic" else DIFFERENTIAL)


def pieces(mesh: trimesh.Trimesh) -> int:
    """Connected components (trimesh's own body_count needs scipy)."""
    graph = nx.Graph()
    graph.add_nodes_from(range(len(mesh.vertices)))
    graph.add_edges_from(mesh.edges_unique.tolist())
    return nx.number_connected_components(graph)


def quat_to_matrix(q: np.ndarray) -> np.ndarray:
    w, x, y, z = q
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def test_every_part_is_a_closed_non_empty_coloured_mesh(geom):
    parts = geom.parts()
    names = [p.name for p in parts]
    assert names[:2] == ["body", "heading"]
    assert sum(
        n.startswith("wheel") and not n.endswith("marking") for n in names
    ) == len(geom.wheels)
    assert ("caster" in names) == (geom.kind == "differential")
    for p in parts:
        assert len(p.mesh.faces) > 0
        assert p.mesh.is_watertight, p.name
        assert p.mesh.volume > 0, p.name  # outward normals
    # Distinct colours for body, heading marker, wheels and markings.
    assert (
        len(
            {
                geom.body_color,
                geom.heading_color,
                geom.wheels[0].color,
                geom.wheels[0].marking_color,
            }
        )
        == 4
    )
    for mesh, color in [
        (geom.body, geom.body_color),
        (geom.wheels[0].marking, geom.wheels[0].marking_color),
    ]:
        assert np.all(mesh.visual.vertex_colors[:, :3] == color)


@pytest.mark.parametrize("kind", ["holonomic", "differential"])
def test_wheels_sit_at_l_beta_and_touch_the_floor(kind):
    r, L = 0.04, 0.22
    g = (
        holonomic_robot(0.3, r, L)
        if kind == "holonomic"
        else differential_robot(0.3, r, L)
    )
    betas = holonomic.DEFAULT_BETAS if kind == "holonomic" else (0.0, math.pi)
    assert [w.beta for w in g.wheels] == pytest.approx(list(betas))
    for w, b in zip(g.wheels, betas, strict=True):
        assert_allclose(w.hub, [L * math.cos(b), L * math.sin(b), r], atol=1e-12)
        # Wheel-local meshes are centred on the hub and reach (almost exactly) radius r.
        placed = np.vstack([w.mesh.vertices, w.marking.vertices]) + w.hub
        assert placed[:, 2].min() == pytest.approx(0.0, abs=0.03 * r)
        assert placed[:, 2].min() >= -1e-12  # never below the floor
        assert np.max(np.abs(w.mesh.bounds.mean(axis=0))) < 0.05 * r


def test_axle_and_rolling_direction_follow_eq_9_1(geom):
    for w in geom.wheels:
        b = w.beta
        assert_allclose(
            w.rolling_direction, [-math.sin(b), math.cos(b), 0.0], atol=1e-12
        )
        assert_allclose(w.axle, [-math.cos(b), -math.sin(b), 0.0], atol=1e-12)
        assert np.dot(w.axle, w.rolling_direction) == pytest.approx(0.0, abs=1e-12)
        assert np.linalg.norm(w.axle) == pytest.approx(1.0)
        assert_allclose(np.cross(w.axle, Z), w.rolling_direction, atol=1e-12)


def test_positive_angle_rolls_the_robot_along_the_rolling_direction(geom):
    # Turning by +eps about the axle moves the contact point by -eps r d relative to the
    # hub: without slip the hub (the robot) moves by +eps r d.
    eps = 1e-4
    for w in geom.wheels:
        bottom = np.array([0.0, 0.0, -w.radius, 1.0])
        moved = (wheel_transform(w, eps) @ bottom - wheel_transform(w, 0.0) @ bottom)[
            :3
        ]
        assert_allclose(moved, -eps * w.radius * w.rolling_direction, atol=1e-9)


def test_rates_of_a_motion_spin_wheels_the_right_way():
    # Pure rotation: all rates are positive and every rolling direction is the
    # counter-clockwise tangent at its wheel, which is where each wheel then moves.
    g = holonomic_robot()
    rates = holonomic.inverse_robot_frame(0.0, 0.0, 1.0, r=0.05, L=0.25)
    for w, q in zip(g.wheels, rates, strict=True):
        assert q > 0
        tangent = np.cross(Z, w.hub * [1, 1, 0])
        assert np.dot(tangent, w.rolling_direction) > 0
    # Driving forward: the right wheel of the differential robot turns positive, the left
    # one negative, both rolling the robot along +y_m.
    d = differential_robot()
    traj = plan_trajectory([[0.0, 0.0], [1.0, 0.0]], DIFFERENTIAL)
    moving = traj.wheel_rates[len(traj.t) // 2]
    assert moving[0] > 0 > moving[1]
    for w, q in zip(d.wheels, moving, strict=True):
        assert q * w.rolling_direction[1] > 0


def test_spinning_keeps_the_wheel_on_its_axle(geom):
    w = geom.wheels[0]
    for angle in (0.3, 2.0, -5.0):
        placed = (
            trimesh.transform_points(w.marking.vertices, wheel_transform(w, angle))
            - w.hub
        )
        ref = w.marking.vertices
        # Distance to the axle line and position along it are invariant.
        along = placed @ w.axle
        assert_allclose(along, ref @ w.axle, atol=1e-12)
        assert_allclose(
            np.linalg.norm(placed - np.outer(along, w.axle), axis=1),
            np.linalg.norm(ref - np.outer(ref @ w.axle, w.axle), axis=1),
            atol=1e-12,
        )


def test_omni_wheels_have_rollers_and_plain_wheels_have_spokes():
    omni = holonomic_robot(n_rollers=6).wheels[0].marking
    plain = differential_robot().wheels[0].marking
    assert pieces(omni) == 2 * 6 + 1  # two rows of rollers plus a stripe
    assert pieces(plain) == 6  # three spokes on each face


def test_body_heading_and_caster():
    g = differential_robot(radius=0.4, wheel_radius=0.05, wheel_distance=0.3)
    assert g.radius == 0.4
    assert_allclose(g.body.bounds[:, :2], [[-0.4, -0.4], [0.4, 0.4]], atol=1e-3)
    assert g.heading.centroid[1] > 0.1  # the marker points forward, +y_m
    assert g.caster is not None
    assert g.caster.centroid[1] < 0  # caster at the back
    assert g.caster.bounds[0, 2] == pytest.approx(0.0, abs=1e-9)


def test_point_robot_gets_a_body_around_the_wheels():
    g = robot_geometry(geometry.RobotParams("holonomic", 0.05, 0.25, radius=0.0))
    assert g.radius == pytest.approx(0.3)


def test_to_mesh_and_parts_follow_wheel_angles(geom):
    k = len(geom.wheels)
    still = geom.to_mesh()
    turned = geom.to_mesh(np.full(k, 1.0))
    assert len(still.vertices) == len(turned.vertices)
    assert not np.allclose(still.vertices, turned.vertices)
    assert len(still.visual.vertex_colors) == len(still.vertices)
    with pytest.raises(ValueError, match="wheel angles"):
        geom.parts(np.zeros(k + 1))


def test_frames_and_quaternions_agree():
    for phi in (0.0, 0.7, math.pi / 2, -2.0):
        t = robot_transform([1.0, 2.0, phi])
        assert_allclose(t[:3, :3], quat_to_matrix(yaw_wxyz(phi)), atol=1e-12)
        # y_m (forward) goes to the heading direction, x_m (right) to its right.
        assert_allclose(
            t[:3, :3] @ [0, 1, 0], [math.cos(phi), math.sin(phi), 0.0], atol=1e-12
        )
        assert_allclose(
            t[:3, :3] @ [1, 0, 0], [math.sin(phi), -math.cos(phi), 0.0], atol=1e-12
        )
    axis = np.array([1.0, -2.0, 0.5])
    assert_allclose(
        quat_to_matrix(axis_angle_wxyz(axis, 0.8)),
        rotation_matrix(axis, 0.8),
        atol=1e-12,
    )


def test_kinematics_imports_no_ui_or_plotting():
    code = (
        "import sys, kinematics; "
        "bad = [m for m in ('viser', 'matplotlib', 'app', 'planners', 'pyglet') if m in sys.modules]; "
        "print(bad)"
    )
    assert run_code(code).strip() == "[]"
