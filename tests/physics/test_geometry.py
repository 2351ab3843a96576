"""General implicit geometry (docs/physics.md section 1): every shape's phi against exact distances,
the height field's bound, bounces against the closed forms, inclines, moving shapes, containers,
CSG where it is only a bound, user SDFs, and every stepping path.

Exact distances come from formulas written independently of the kernels' (the closest point by
clamping, the distance to a segment) or, for the cone and the torus, from brute force over dense
samples of the surface.
"""

from __future__ import annotations

import math
import warnings

import numba
import numpy as np
import pytest

from penalty_env.physics import (
    SDF,
    Bowl,
    Box,
    Capsule,
    Cone,
    Cylinder,
    Difference,
    HeightField,
    Inside,
    Intersection,
    Plane,
    Sphere,
    Torus,
    Union,
    World,
    rotation_matrix,
    theory,
)
from penalty_env.physics.geometry.evaluate import evaluate
from penalty_env.physics.geometry.pack import pack_table


def _rot(d, rng):
    if d == 2:
        return rotation_matrix(rng.uniform(-np.pi, np.pi))
    return rotation_matrix(rng.normal(size=3), rng.uniform(-np.pi, np.pi))


def _evaluate_all(shapes, points):
    """(m, S, 4) phi and normals of every shape, through one shape table (compiled once for any)."""
    table, rows = pack_table(shapes, 1, shapes[0].dim)
    out = np.zeros((len(points), len(shapes), 4))
    evaluate(table, 0, np.ascontiguousarray(points), out, (0.0,) * shapes[0].dim)
    return out[:, list(rows)]


# --------------------------------------------------------------------------------------------
# phi against exact distances
# --------------------------------------------------------------------------------------------


def _exact_box(q, h):
    outside = np.linalg.norm(q - np.clip(q, -h, h), axis=-1)
    inside = -np.min(h - np.abs(q), axis=-1)
    return np.where(np.all(np.abs(q) <= h, axis=-1), inside, outside)


def _meridian(q, d):
    rho = np.linalg.norm(q[:, :2], axis=-1) if d == 3 else np.abs(q[:, 0])
    return rho, q[:, -1]


def _exact_cylinder(q, r, h, d):
    rho, z = _meridian(q, d)
    p = np.stack([rho, z], -1)
    return _exact_box(p, np.array([r, h]))  # rho >= 0: the box of (rho, z) is exact


def _segment_distance(p, a, b):
    ab = b - a
    t = np.clip(((p - a) @ ab) / (ab @ ab), 0.0, 1.0)
    return np.linalg.norm(p - a - t[:, None] * ab, axis=-1)


def _brute(surface, pts, inside):
    """Distance from each point to the nearest of dense surface samples, signed by ``inside``."""
    best = np.full(len(pts), np.inf)
    for chunk in np.array_split(surface, max(1, len(surface) // 20000)):
        dist = np.sqrt(((pts[:, None, :] - chunk[None]) ** 2).sum(-1)).min(1)
        best = np.minimum(best, dist)
    return np.where(inside, -best, best)


def _points(d, rng, scale, m=300):
    return rng.uniform(-scale, scale, (m, d))


@pytest.mark.parametrize("d", [pytest.param(2, marks=pytest.mark.slow), 3])
def test_every_primitive_phi_is_the_exact_signed_distance_inside_and_outside(d):
    rng = np.random.default_rng(1)
    c = rng.normal(size=d) * 0.3
    R = _rot(d, rng)
    h = np.array([0.7, 0.4, 0.9][:d])
    box = Box(c, h, R)
    a, b = rng.normal(size=d), rng.normal(size=d)
    cap = Capsule(a, b, 0.35)
    cyl = Cylinder(c, 0.6, 0.45, rotation=R)
    plane = Plane(c, R[:, 0])
    pts = c + _points(d, rng, 2.0)
    got = _evaluate_all([box, cap, cyl, plane], pts)
    q = (pts - c) @ R
    np.testing.assert_allclose(got[:, 0, 0], _exact_box(q, h), atol=1e-12)
    np.testing.assert_allclose(got[:, 1, 0], _segment_distance(pts, a, b) - 0.35, atol=1e-12)
    np.testing.assert_allclose(got[:, 2, 0], _exact_cylinder(q, 0.6, 0.45, d), atol=1e-12)
    np.testing.assert_allclose(got[:, 3, 0], (pts - c) @ R[:, 0], atol=1e-12)
    # |grad phi| = 1 (the distance is exact) and grad phi is phi's derivative away from creases
    n = got[:, :, 1 : 1 + d]
    np.testing.assert_allclose(np.linalg.norm(n, axis=-1), 1.0, atol=1e-12)
    eps = 1e-6
    num = np.stack(
        [(_evaluate_all([box, cap, cyl, plane], pts + eps * e)[:, :, 0] - got[:, :, 0]) / eps for e in np.eye(d)], -1
    )
    smooth = np.abs(num - n).max(-1) < 1e-4  # creases (a box's inner diagonals) have a one-sided derivative
    assert smooth.mean() > 0.97, smooth.mean()


@pytest.mark.parametrize("d", [pytest.param(2, marks=pytest.mark.slow), 3])
def test_cone_and_torus_phi_match_brute_force_distance_to_their_surface(d):
    rng = np.random.default_rng(2)
    c = rng.normal(size=d) * 0.2
    R = _rot(d, rng)
    cone = Cone(c, 0.8, 0.3, 0.5, rotation=R)
    torus = Torus(c, 0.9, 0.3, rotation=R)
    pts = c + _points(d, rng, 1.6, m=200)
    got = _evaluate_all([cone, torus], pts)
    q = (pts - c) @ R
    rho, z = _meridian(q, d)
    # the cone: its meridian trapezoid, sampled densely (spacing s < 3e-5)
    t = np.linspace(0.0, 1.0, 40001)[:, None]
    segs = [((0.0, -0.5), (0.8, -0.5)), ((0.8, -0.5), (0.3, 0.5)), ((0.3, 0.5), (0.0, 0.5))]
    poly = np.concatenate([np.array(p0) + t * (np.array(p1) - np.array(p0)) for p0, p1 in segs])
    inside = (np.abs(z) <= 0.5) & (rho <= 0.8 + (0.3 - 0.8) * (z + 0.5))
    _assert_matches_brute(got[:, 0, 0], _brute(poly, np.stack([rho, z], -1), inside), 3e-5)
    # the torus: |(rho - R, z)| - r, checked on the surface itself: the foot x - phi n lies on it
    foot = pts - got[:, 1, :1] * got[:, 1, 1 : 1 + d]
    rf, zf = _meridian((foot - c) @ R, d)
    np.testing.assert_allclose(np.hypot(rf - 0.9, zf), 0.3, atol=1e-12)
    ang = np.linspace(0, 2 * np.pi, 200001)
    circle = np.stack([0.9 + 0.3 * np.cos(ang), 0.3 * np.sin(ang)], -1)  # spacing < 1e-5
    _assert_matches_brute(got[:, 1, 0], _brute(circle, np.stack([rho, z], -1), np.hypot(rho - 0.9, z) < 0.3), 1e-5, 0.3)


def _assert_matches_brute(phi, brute, spacing, curvature_radius=np.inf):
    """The nearest of samples spaced ``spacing`` apart is never nearer than the surface, and farther
    by at most min(s / 2, s^2 (1 + d / rho) / 8d) (a line: sqrt(d^2 + (s/2)^2) - d; a circle of
    radius rho seen from outside: the same to leading order, times 1 + d / rho)."""
    d = np.abs(phi)
    assert np.array_equal(np.sign(phi), np.sign(brute))
    excess = np.abs(brute) - d
    assert np.all(excess >= -1e-12), excess.min()
    allowed = np.minimum(spacing / 2, spacing**2 * (1.0 + d / curvature_radius) / (8 * np.maximum(d, 1e-300)))
    assert np.all(excess <= allowed + 1e-12), (excess - allowed).max()


def test_shapes_evaluate_through_their_public_phi_and_a_pose_moves_them_rigidly():
    rng = np.random.default_rng(3)
    box = Box((0.1, -0.2, 0.3), (0.5, 0.3, 0.2))
    R = rotation_matrix((1.0, 2.0, 0.5), 0.7)
    t = np.array([0.4, -1.0, 2.0])
    moved = box.transformed(translation=t, rotation=R)
    pts = rng.normal(size=(100, 3))
    np.testing.assert_allclose(moved.phi(pts @ R.T + t), box.phi(pts), atol=1e-12)
    np.testing.assert_allclose(moved.grad_phi(pts @ R.T + t), box.grad_phi(pts) @ R.T, atol=1e-12)
    # Inside is the complement, and Inside(Sphere) is the Bowl
    np.testing.assert_allclose(Inside(box).phi(pts), -box.phi(pts), atol=0)
    assert Inside(Sphere((0, 0, 1), 2.0)) == Bowl((0, 0, 1), 2.0)


# --------------------------------------------------------------------------------------------
# Height fields
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("d", [2, 3])
def test_height_field_of_a_tilted_plane_is_the_exact_distance(d):
    rng = np.random.default_rng(4)
    slope = np.array([0.3, -0.45][: d - 1])
    cell = 0.25
    axes = [np.arange(17) * cell - 2.0 for _ in range(d - 1)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), -1)
    hf = HeightField(0.2 + grid @ slope, cell, origin=(-2.0,) * (d - 1))
    pts = np.concatenate([rng.uniform(-1.9, 1.9, (300, d - 1)), rng.uniform(-1.5, 1.5, (300, 1))], -1)
    n = np.append(-slope, 1.0) / math.sqrt(1.0 + slope @ slope)
    exact = (pts - np.append(np.zeros(d - 1), 0.2)) @ n
    np.testing.assert_allclose(hf.phi(pts), exact, atol=1e-12)
    np.testing.assert_allclose(hf.grad_phi(pts), np.broadcast_to(n, pts.shape), atol=1e-12)


def _sinusoid_bound(delta, K, cell, d):
    """The height field's documented error bound (docs/physics.md section 1): curvature K, vertical gap
    delta, node spacing cell (interpolation error of the heights and of their slope included)."""
    dims = d - 1
    return K * (0.5 * delta**2 + dims * cell**2 / 8.0 + 0.385 * dims * cell * np.abs(delta))


@pytest.mark.parametrize("d", [2, 3])
def test_height_field_of_a_sinusoid_stays_within_its_curvature_bound(d):
    A, k, cell = 0.15, 2.0, 0.05
    f = (lambda x: A * np.sin(k * x)) if d == 2 else (lambda x, y: A * np.sin(k * x) * np.cos(k * y))
    K = A * k * k * (1.0 if d == 2 else 2.0)  # the largest |second directional derivative|
    axes = [np.arange(121) * cell - 3.0 for _ in range(d - 1)]
    grid = np.meshgrid(*axes, indexing="ij")
    hf = HeightField(f(*grid), cell, origin=(-3.0,) * (d - 1))
    rng = np.random.default_rng(5)
    m = 150 if d == 2 else 60
    foot = rng.uniform(-1.5, 1.5, (m, d - 1))
    delta = rng.uniform(-0.3, 0.3, m)
    pts = np.concatenate([foot, (f(*foot.T) + delta)[:, None]], -1)
    # true distance to z = f: brute force over a dense sampling of the surface near each point
    if d == 2:
        xs = np.linspace(-2.0, 2.0, 80001)
        surf = np.stack([xs, f(xs)], -1)
        exact = _brute(surf, pts, delta < 0)
    else:
        exact = np.empty(m)
        for i, p in enumerate(pts):
            gx = np.linspace(p[0] - 0.35, p[0] + 0.35, 351)
            gy = np.linspace(p[1] - 0.35, p[1] + 0.35, 351)
            X, Y = np.meshgrid(gx, gy, indexing="ij")
            surf = np.stack([X.ravel(), Y.ravel(), f(X, Y).ravel()], -1)
            exact[i] = _brute(surf, p[None], np.array([delta[i] < 0]))[0]
    brute_err = 2e-3**2 * K if d == 3 else 1e-9  # the brute-force samples' spacing
    err = np.abs(hf.phi(pts) - exact)
    bound = _sinusoid_bound(delta, K, cell, d) + brute_err
    assert np.all(err <= bound), (err / bound).max()
    # and the bound means something: the error is of its order, not far below it
    assert (err / bound).max() > 0.05


# --------------------------------------------------------------------------------------------
# Bounces, inclines, moving shapes: one World per dimension holds every case (one compile)
# --------------------------------------------------------------------------------------------

KS, MASS, RADIUS, ZETA, SPC = 1e4, 1.0, 0.1, 0.3, 128
FAR = 1e3  # where a shape that a world does not use is parked


def _shapes(d):
    """Plane, Box and Capsule, kinematic (zero velocity: the static case, bit for bit)."""
    z = (0.0,) * d
    up = (0.0,) * (d - 1) + (1.0,)
    return [
        Plane(z, up, velocity=z),
        Box(z, (0.5,) * d, velocity=z),
        Capsule((-0.4,) + (0.0,) * (d - 1), (0.4,) + (0.0,) * (d - 1), 0.2, velocity=z),
    ]


def _kinematic_world(d, x, v, gravity=None, kd=None):
    """B worlds of one ball and the three shapes; the caller places each world's shapes."""
    dt = theory.contact_time(KS, 2.0 * ZETA * math.sqrt(KS * MASS), MASS) / SPC
    kd = 2.0 * ZETA * math.sqrt(KS * MASS) if kd is None else kd
    g = (0.0,) * d if gravity is None else gravity
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the shapes start on top of the balls until parked
        return World(x, [RADIUS], [MASS], v, terrain=_shapes(d), ks=KS, kd=kd, dt=dt, gravity=g, stepping="lanes")


def _park(w, keep):
    """In each world b, every shape but keep[b] goes far away (the plane far below: it is unbounded)."""
    d = w.dim
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the shapes start on top of the balls until parked
        for s in range(len(w.terrain)):
            away = -FAR * np.eye(d)[-1] if isinstance(w.terrain[s], Plane) else np.full(d, FAR)
            far = np.where((np.asarray(keep) == s)[:, None], 0.0, 1.0) * away
            w.set_shape_pose(s, position=far + np.asarray(w.terrain[s].center))


@pytest.mark.parametrize("d", [pytest.param(2, marks=pytest.mark.slow), 3])
def test_ball_bouncing_on_a_plane_a_box_face_and_a_capsule_matches_closed_forms_worst_over_phase(d):
    rng = np.random.default_rng(6)
    phases = 256
    # cases: (shape index, unit normal at the impact point, surface point, rotation of the shape)
    cases = []
    for _ in range(3):  # planes of random orientation
        n = rng.normal(size=d)
        n /= np.linalg.norm(n)
        cases.append((0, n, np.zeros(d), _rot_to(n)))
    up = np.eye(d)[-1]
    cases.append((1, up, 0.5 * up, np.eye(d)))  # the box's top face
    side = np.eye(d)[1]
    cases.append((2, side, 0.2 * side, np.eye(d)))  # the capsule's side
    kd = 2.0 * ZETA * math.sqrt(KS * MASS)
    dt = theory.contact_time(KS, kd, MASS) / SPC
    speed = 1.0
    ph = np.tile(np.arange(phases) / phases, len(cases))
    gap = speed * dt * (1.0 + ph)
    normal = np.repeat(np.array([c[1] for c in cases]), phases, 0)
    surface = np.repeat(np.array([c[2] for c in cases]), phases, 0)
    x = (surface + (RADIUS + gap)[:, None] * normal)[:, None, :]
    v = (-speed * normal)[:, None, :]
    w = _kinematic_world(d, x, v)
    keep = np.repeat([c[0] for c in cases], phases)
    _park(w, keep)
    rots = np.repeat(np.array([c[3] for c in cases]), phases, 0)
    w.set_shape_pose(0, rotation=rots)  # the planes' normals (the identity where the plane is parked)
    steps = int(1.6 * SPC) + 8
    w.step(steps)
    pos, vel = w.positions[:, 0], w.velocities[:, 0]
    u = np.einsum("bd,bd->b", vel, normal)  # separation speed
    gap_end = np.einsum("bd,bd->b", pos - surface, normal) - RADIUS
    e_exact = theory.restitution(KS, kd, MASS)
    tc_exact = theory.contact_time(KS, kd, MASS)
    e_err = np.abs(u / speed / e_exact - 1.0).reshape(len(cases), phases).max(1)
    t_contact = steps * dt - gap_end / u - gap / speed
    tc_err = np.abs(t_contact / tc_exact - 1.0).reshape(len(cases), phases).max(1)
    assert np.all(gap_end > 0) and np.all(u > 0)
    assert np.all(e_err < 0.015), e_err  # the bowl's bound at 128 steps per contact
    assert np.all(tc_err < 0.015), tc_err


def _rot_to(n):
    """A rotation taking the last axis to n (the plane's frame)."""
    from penalty_env.physics.geometry.shapes import _axis_rotation

    return _axis_rotation(tuple(n))


@pytest.mark.parametrize("d", [2, 3])
def test_frictionless_ball_slides_down_a_tilted_plane_at_g_sin_theta_resting_m_g_cos_theta_over_ks(d):
    g, theta = 9.81, math.radians(25.0)
    n = np.zeros(d)
    n[0], n[-1] = -math.sin(theta), math.cos(theta)
    x = (RADIUS * n)[None, None, :].repeat(16, 0)
    gravity = (0.0,) * (d - 1) + (-g,)
    w = _kinematic_world(d, x, np.zeros_like(x), gravity=gravity, kd=2.0 * math.sqrt(KS * MASS))  # critically damped
    _park(w, np.zeros(16, dtype=int))
    w.set_shape_pose(0, rotation=_rot_to(n))
    w.step(4000)  # the normal transient dies out
    t0 = w.positions[0, 0].copy(), w.velocities[0, 0].copy()
    steps = 4000
    w.step(steps)
    T = steps * w.dt
    along = np.zeros(d)
    along[0], along[-1] = math.cos(theta), math.sin(theta)  # up the slope
    accel = (w.velocities[0, 0] - t0[1]) @ along / T
    assert accel == pytest.approx(-g * math.sin(theta), rel=1e-9)
    overlap = RADIUS - w.positions[0, 0] @ n
    assert overlap == pytest.approx(MASS * g * math.cos(theta) / KS, rel=1e-6)


@pytest.mark.parametrize("d", [2, 3])
def test_ball_rides_a_rising_plane_at_its_speed_and_a_frictionless_plane_moving_sideways_leaves_it(d):
    g = 9.81
    x = np.zeros((16, 1, d))
    x[:, 0, -1] = RADIUS - MASS * g / KS
    w = _kinematic_world(d, x, np.zeros_like(x), gravity=(0.0,) * (d - 1) + (-g,), kd=2.0 * math.sqrt(KS * MASS))
    _park(w, np.zeros(16, dtype=int))
    rise, slide = 0.3, 0.7
    vel = np.zeros((16, d))
    vel[:8, -1] = rise  # worlds 0-7: the plane rises
    vel[8:, 0] = slide  # worlds 8-15: it slides along its own surface
    w.set_shape_pose(0, velocity=vel)
    w.step(5000)
    np.testing.assert_allclose(w.velocities[:8, 0, -1], rise, rtol=1e-9)
    t = 5000 * w.dt
    np.testing.assert_allclose(w.shape_pose(0, world=0)["position"][-1], rise * t, rtol=1e-12)
    # the ball rests on the rising plane at its resting overlap m g / ks
    overlap = RADIUS - (w.positions[:8, 0, -1] - rise * t)
    np.testing.assert_allclose(overlap, MASS * g / KS, rtol=1e-6)
    # the sliding plane: no friction, so nothing drags the ball sideways
    assert np.all(w.velocities[8:, 0, :-1] == 0.0) and np.all(w.positions[8:, 0, :-1] == 0.0)


@pytest.mark.slow
def test_a_zero_velocity_kinematic_sphere_and_bowl_give_exactly_the_static_numbers():
    rng = np.random.default_rng(7)
    x = np.stack(np.meshgrid([-0.4, 0.0, 0.4], [-0.4, 0.0, 0.4], [0.8, 1.1], indexing="ij"), -1).reshape(-1, 3)[:-1]
    x = x[:20] if len(x) >= 20 else x
    v = rng.normal(size=x.shape)
    kw = dict(ks=1e4, kd=20.0, dt=2e-4, mu=0.3)
    n = len(x)
    static = World(x, np.full(n, 0.1), np.ones(n), v, terrain=(Bowl((0, 0, 3.0), 3.0), Sphere((0, 0, 0.2), 0.3)), **kw)
    moving = World(
        x,
        np.full(n, 0.1),
        np.ones(n),
        v,
        terrain=(Bowl((0, 0, 3.0), 3.0, velocity=(0, 0, 0)), Sphere((0, 0, 0.2), 0.3, angular_velocity=(0, 0, 0))),
        **kw,
    )
    for w in (static, moving):
        w.step(3000)
    assert np.array_equal(static.positions, moving.positions)
    assert np.array_equal(static.velocities, moving.velocities)


# --------------------------------------------------------------------------------------------
# Containers: planes in a corner against one Inside(Box)
# --------------------------------------------------------------------------------------------


@pytest.mark.slow
def test_ball_in_a_corner_feels_both_walls_built_from_planes_but_only_the_nearest_of_an_inside_box():
    """A ball pressed into an inside corner along its diagonal: two planes push it out along both
    normals and it rests at overlap m g cos45 / ks on each wall; one Inside(Box) gives a single
    normal (the nearest wall's) at a time, so nothing holds it against the other and it sinks
    deeper (docs/physics.md section 1: use planes for a container a ball reaches the corners of)."""
    g = 9.81
    gravity = (-g / math.sqrt(2.0), -g / math.sqrt(2.0))
    kd = 2.0 * math.sqrt(KS * MASS)
    kw = dict(ks=KS, kd=kd, dt=theory.contact_time(KS, 0.6 * kd, MASS) / SPC, gravity=gravity)
    x = np.array([[RADIUS + 0.01, RADIUS + 0.02]])
    planes = World(x, [RADIUS], [MASS], terrain=(Plane((0, 0), (1, 0)), Plane((0, 0), (0, 1))), **kw)
    box = World(x, [RADIUS], [MASS], terrain=Inside(Box((1.0, 1.0), (1.0, 1.0))), **kw)
    for w in (planes, box):
        w.step(20000)
    expected = MASS * g / math.sqrt(2.0) / KS
    np.testing.assert_allclose(RADIUS - planes.positions[0], expected, rtol=1e-6)
    assert np.linalg.norm(planes.velocities) < 1e-9
    deepest = RADIUS - box.positions[0].min()
    assert deepest > 1.5 * expected, (deepest, expected)


# --------------------------------------------------------------------------------------------
# CSG: exact in places, a bound elsewhere
# --------------------------------------------------------------------------------------------


@pytest.mark.slow
def test_csg_min_max_is_exact_inside_an_intersection_and_a_bound_outside_it_near_an_edge():
    h = np.array([0.5, 0.4, 0.3])
    box = Box((0.0, 0.0, 0.0), h)
    slab = Intersection(*[Plane(s * h[k] * np.eye(3)[k], s * np.eye(3)[k]) for k in range(3) for s in (1.0, -1.0)])
    rng = np.random.default_rng(8)
    pts = rng.uniform(-1.0, 1.0, (400, 3))
    both = _evaluate_all([box, slab], pts)
    exact, csg = both[:, 0, 0], both[:, 1, 0]
    inside = exact < 0
    np.testing.assert_allclose(csg[inside], exact[inside], atol=1e-12)  # exact inside
    assert np.all(csg[~inside] <= exact[~inside] + 1e-12)  # a lower bound outside
    # where it matters: a ball off a convex edge, clear of the true box, is pushed by the CSG one
    diag = np.array([1.0, 1.0, 0.0]) / math.sqrt(2.0)
    x = np.array([[h[0], h[1], 0.0] + 1.2 * RADIUS * diag])
    kw = dict(ks=KS, kd=0.0, dt=1e-4, gravity=(0.0, 0.0, 0.0))
    wb = World(x, [RADIUS], [MASS], terrain=box, **kw)
    wc = World(x, [RADIUS], [MASS], terrain=slab, **kw)
    wb.step(1)
    wc.step(1)
    assert np.all(wb.velocities == 0.0)  # the exact box: no contact at 1.2 r from the edge
    assert np.linalg.norm(wc.velocities) > 0.0  # the intersection of planes: a ghost contact


def test_a_difference_carves_a_cavity_that_a_ball_rests_in():
    """A hopper-like cavity: a block minus a sphere; a ball dropped in comes to rest at the cavity's
    bottom, resting overlap m g / ks (the CSG is exact there: inside the difference, far from its
    creases)."""
    g = 9.81
    cavity = Difference(Box((0, 0, 0), (1.0, 1.0, 1.0)), Sphere((0, 0, 0.6), 0.8))
    x = np.array([[0.0, 0.0, 0.3]])
    w = World(x, [RADIUS], [MASS], terrain=cavity, ks=KS, kd=2.0 * math.sqrt(KS * MASS), dt=1e-4)
    w.step(30000)
    bottom = np.array([0.0, 0.0, 0.6 - 0.8])
    np.testing.assert_allclose(w.positions[0], bottom + np.array([0, 0, RADIUS - MASS * g / KS]), atol=1e-7)


# --------------------------------------------------------------------------------------------
# User SDFs
# --------------------------------------------------------------------------------------------


@numba.njit
def _unit_sphere_phi(p):
    return math.sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]) - 1.0


@numba.njit
def _nan_phi(p):
    return math.sqrt(p[2]) - 2.0  # NaN below z = 0


@pytest.mark.slow
def test_a_user_sdf_bounces_like_the_builtin_sphere_and_bad_ones_are_refused():
    user = SDF(_unit_sphere_phi, dim=3, bounds=((-1.2,) * 3, (1.2,) * 3))
    pts = np.random.default_rng(9).normal(size=(50, 3))
    np.testing.assert_allclose(user.phi(pts), np.linalg.norm(pts, axis=1) - 1.0, atol=1e-14)
    # central differences give the normal to ~1e-10
    np.testing.assert_allclose(user.grad_phi(pts), pts / np.linalg.norm(pts, axis=1, keepdims=True), atol=1e-8)
    x = np.array([[0.0, 0.0, 1.0 + RADIUS + 1e-3]])
    v = np.array([[0.0, 0.0, -1.0]])
    kw = dict(ks=KS, kd=2.0 * ZETA * math.sqrt(KS * MASS), dt=1e-5, gravity=(0.0, 0.0, 0.0))
    wu = World(x, [RADIUS], [MASS], v, terrain=user, **kw)
    ws = World(x, [RADIUS], [MASS], v, terrain=Sphere((0, 0, 0), 1.0), **kw)
    for w in (wu, ws):
        w.step(4000)
    np.testing.assert_allclose(wu.velocities, ws.velocities, atol=1e-8)
    # samples on its zero level set by projection
    np.testing.assert_allclose(np.linalg.norm(user.surface_points(200), axis=1), 1.0, atol=1e-7)
    with pytest.raises(TypeError, match="phi must be a numba.njit function"):
        SDF(lambda p: p[0], dim=3)
    with pytest.raises(ValueError, match="not finite"):
        World(x, [RADIUS], [MASS], terrain=SDF(_nan_phi, dim=3), ks=KS, dt=1e-4)


# --------------------------------------------------------------------------------------------
# Stepping paths
# --------------------------------------------------------------------------------------------


@pytest.mark.slow
def test_lanes_step_general_shapes_bit_for_bit_as_the_scalar_path():
    rng = np.random.default_rng(10)
    B, n = 20, 4
    x = rng.uniform(-0.3, 0.3, (B, n, 3)) + np.array([0, 0, 0.6])
    v = rng.normal(size=(B, n, 3))
    terrain = (
        Plane((0, 0, 0), (0.1, 0.0, 1.0), velocity=(0.0, 0.1, 0.0)),
        Bowl((0, 0, 2.0), 2.0),
        Union(Box((0.3, 0, 0.1), (0.1, 0.1, 0.1)), Capsule((-0.3, 0, 0.1), (-0.3, 0.2, 0.2), 0.1)),
    )
    kw = dict(terrain=terrain, ks=1e4, kd=10.0, dt=2e-4, mu=0.4)
    ws = World(x, np.full(n, 0.08), np.ones(n), v, stepping="scalar", **kw)
    wl = World(x, np.full(n, 0.08), np.ones(n), v, stepping="lanes", **kw)
    for w in (ws, wl):
        w.step(1500)
    assert np.array_equal(ws.positions, wl.positions) and np.array_equal(ws.velocities, wl.velocities)
    assert np.array_equal(ws.shape_pose(0, 3)["position"], wl.shape_pose(0, 3)["position"])


@pytest.mark.slow
def test_neighbour_list_path_agrees_with_the_grid_in_a_container_of_planes():
    """Two layers of balls on a jittered lattice, the outer ones already pressing the walls and the
    floor: the list path's serial passes for the general shapes give the grid's forces (to round-off:
    they are summed in another order, and the pile's chaos amplifies that ~10x per 100 steps)."""
    rng = np.random.default_rng(11)
    side = (np.arange(18) - 8.5) * 0.105
    X, Y, Z = np.meshgrid(side, side, [0.0475, 0.1525], indexing="ij")
    x = np.stack([X.ravel(), Y.ravel(), Z.ravel()], -1) + rng.uniform(-1e-3, 1e-3, (X.size, 3))
    n = len(x)
    walls = [Plane((0, 0, 0), (0, 0, 1))] + [
        Plane(-s * 0.94 * np.eye(3)[k], s * np.eye(3)[k]) for k in range(2) for s in (1, -1)
    ]
    kw = dict(terrain=walls, ks=1e4, kd=10.0, dt=2e-4, broadphase="grid")
    wl = World(x, np.full(n, 0.05), np.ones(n), stepping="neighbour_list", **kw)
    wg = World(x, np.full(n, 0.05), np.ones(n), stepping="scalar", **kw)
    for w in (wl, wg):
        w.step(300)
    np.testing.assert_allclose(wl.positions, wg.positions, rtol=0, atol=1e-10)
    np.testing.assert_allclose(wl.velocities, wg.velocities, rtol=0, atol=1e-8)
    assert wl.neighbour_list_stats()["near_terrain"].sum() > n // 2  # the walls' balls were tested
    moved = np.abs(wl.positions - x).max()
    assert moved > 1e-4, moved  # the walls pushed (it is not a trivial agreement)


def test_implicit_euler_rests_a_ball_on_a_box():
    g = 9.81
    w = World(
        np.array([[0.1, 0.0, 0.5 + RADIUS]]),
        [RADIUS],
        [MASS],
        terrain=Box((0, 0, 0), (0.5, 0.5, 0.5)),
        ks=KS,
        kd=50.0,
        dt=2e-3,
        integrator="implicit_euler",
    )
    w.step(3000)
    assert 0.5 + RADIUS - w.positions[0, 2] == pytest.approx(MASS * g / KS, rel=1e-6)


def test_events_locate_a_planes_contact_switches_as_a_bowls_to_the_closed_form():
    """Event location works on any shape of the table: RK4 with events rebounds off a plane (a
    general shape: its gap is phi - r, its rate the normal speed) to the closed form with gravity
    within 1e-4 at 16 steps per contact, as off the bowl; plain RK4 does not get within 1e-3."""
    from penalty_env.scenarios import bowl_drop

    floor = (Plane((0.0, 0.0, 0.0), (0.0, 0.0, 1.0)),)
    located = bowl_drop("rk4", True, "linear", 0.3, 16, 256, terrain=floor)
    plain = bowl_drop("rk4", False, "linear", 0.3, 16, 256, terrain=floor)
    assert located.errors["restitution"] < 1e-4 and located.errors["peak_overlap"] < 1e-4, located.errors
    assert plain.errors["restitution"] > 1e-3, plain.errors


@pytest.mark.slow
def test_kinematic_rotation_is_exact_and_set_heights_changes_one_world():
    w0 = 0.8
    box = Box((0, 0, -5.0), (0.2, 0.2, 0.2), angular_velocity=(0.0, 0.0, w0))
    hf = HeightField(np.zeros((3, 3)), 1.0, origin=(-1.0, -1.0))
    w = World(np.zeros((2, 1, 3)) + np.array([0, 0, 0.5]), [RADIUS], [MASS], terrain=(box, hf), ks=KS, dt=1e-3)
    w.step(1000)
    np.testing.assert_allclose(w.shape_pose(0)["rotation"], rotation_matrix((0, 0, 1), w0 * 1.0), atol=1e-12)
    # both balls parked 0.02 above the flat field: raising world 1's field by 0.05 overlaps only it
    w.set_state(np.zeros((2, 1, 3)) + np.array([0, 0, RADIUS + 0.02]), np.zeros((2, 1, 3)))
    assert np.all(w.max_penetration() == 0.0)
    w.set_heights(1, np.full((3, 3), 0.05), worlds=[1])
    pen = w.max_penetration()
    assert pen[0] == 0.0
    assert pen[1] == pytest.approx(0.03 / RADIUS, rel=1e-9)
    with pytest.raises(ValueError, match="static Sphere"):
        World(np.zeros((1, 3)), [RADIUS], [MASS], terrain=Sphere((0, 0, -1), 0.5), ks=KS, dt=1e-3).set_shape_pose(
            0, position=(0, 0, 0)
        )


def test_shape_distances_of_many_worlds_are_each_worlds_shape_distance_bit_for_bit():
    """World.shape_distances: one call for the points of several worlds, each world's own height
    field (and a static bowl, shared), bit for bit shape_distance of each world in turn; points
    that do not match the worlds are refused naming the argument."""
    rng = np.random.default_rng(3)
    hf = HeightField(rng.uniform(0.0, 0.1, (6, 5)), 0.4, origin=(-1.0, -0.8))
    bowl = Bowl((0.0, 0.0, 2.0), 2.0)
    w = World(np.zeros((4, 1, 3)) + np.array([0, 0, 0.5]), [RADIUS], [MASS], terrain=(hf, bowl), ks=KS, dt=1e-3)
    w.set_heights(0, rng.uniform(0.0, 0.2, (4, 6, 5)))
    worlds = np.array([3, 0, 2])
    pts = rng.uniform(-1.5, 1.5, (3, 7, 3))
    for shape in (0, 1):
        phi, normal = w.shape_distances(shape, pts, worlds)
        assert phi.shape == (3, 7) and normal.shape == (3, 7, 3)
        for t, b in enumerate(worlds):
            one_phi, one_normal = w.shape_distance(shape, pts[t], world=int(b))
            assert np.array_equal(phi[t], one_phi) and np.array_equal(normal[t], one_normal)
    assert not np.array_equal(w.shape_distances(0, pts[:1], [3])[0], w.shape_distances(0, pts[:1], [0])[0])
    with pytest.raises(ValueError, match=r"points must have shape \(2, \.\.\., 3\)"):
        w.shape_distances(0, pts, [0, 1])
    with pytest.raises(ValueError, match="worlds must index"):
        w.shape_distances(0, pts, [0, 1, 9])


# --------------------------------------------------------------------------------------------
# Bad arguments
# --------------------------------------------------------------------------------------------

BAD = [
    (lambda: Box((0, 0, 0), (1, 0, 1)), "half_extents must all be > 0"),
    (lambda: Box((0, 0, 0), (1, -1, 1)), "half_extents must all be > 0"),
    (lambda: Box((0, 0, float("nan")), (1, 1, 1)), "center must be finite"),
    (lambda: Box((0, 0, 0), (1, 1, 1), np.diag([1.0, 1.0, 2.0])), "rotation must be a rotation matrix"),
    (lambda: Box((0, 0, 0), (1, 1, 1), np.diag([1.0, 1.0, -1.0])), "rotation must be a rotation matrix"),
    (lambda: Plane((0, 0, 0), (0, 0, 0)), "normal must be a non-zero vector"),
    (lambda: Capsule((0, 0, 0), (0, 0, 1), 0.0), "radius must be a finite number > 0"),
    (lambda: Cylinder((0, 0, 0), 1.0, -1.0), "half_height must be a finite number > 0"),
    (lambda: Cone((0, 0, 0), 0.0, 0.0, 1.0), "must not both be 0"),
    (lambda: Torus((0, 0, 0), 1.0, float("inf")), "minor_radius must be a finite number > 0"),
    (lambda: HeightField(np.array([[0.0, np.nan], [0.0, 0.0]]), 1.0), "heights must be finite"),
    (lambda: HeightField(np.zeros((2, 2, 2)), 1.0), "heights must have 1 or 2 dimensions"),
    (lambda: HeightField(np.zeros((1, 4)), 1.0), "at least 2 nodes"),
    (lambda: HeightField(np.zeros((3, 3)), 0.0), "cell_size must be one number > 0"),
    (lambda: Union(Box((0, 0), (1, 1))), "Union needs at least 2 shapes"),
    (lambda: Union(Box((0, 0), (1, 1)), Box((0, 0, 0), (1, 1, 1))), "one dimension"),
    (lambda: Union(Box((0, 0), (1, 1), velocity=(1, 0)), Box((0, 0), (1, 1))), "motion of its own"),
    (lambda: Union(Box((0, 0), (1, 1)), HeightField(np.zeros(3), 1.0)), "HeightField"),
    (lambda: Box((0, 0), (1, 1), angular_velocity=(1.0, 2.0)), "one number in 2D"),
    (
        lambda: World(np.zeros((1, 3)), [0.1], [1.0], terrain=Box((0, 0), (1, 1)), ks=1e4, dt=1e-3),
        "2D but positions are 3D",
    ),
    (
        lambda: World(np.zeros((1, 3)), [0.1], [1.0], terrain=("bowl",), ks=1e4, dt=1e-3),
        "terrain\\[0\\] must be a Shape",
    ),
]


@pytest.mark.parametrize("make,message", BAD)
def test_bad_shape_arguments_are_refused_naming_the_argument(make, message):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(ValueError, match=message):
            make()
