"""Signed distance functions and the sampled implicit-vs-implicit test (docs/physics.md section 1).

implicit_overlap samples both boundaries, so its depth is the largest penetration -phi_other over
the samples: never more than the exact depth, and short of it by at most the drop of -phi_other
between the exact deepest point and the nearest sample. That drop has a closed form for spheres
(below), which is the "sampling error" the depth is held to.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from penalty_env.physics import Bowl, Sphere, implicit_overlap


def _unit(v):
    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v)


def _nearest_sample_angle(shape, direction, n_samples):
    """Angle between ``direction`` (from the shape's centre) and the closest boundary sample."""
    pts = shape.surface_points(n_samples) - np.asarray(shape.center)
    cos = pts @ _unit(direction) / shape.radius
    return float(np.arccos(np.clip(cos.max(), -1.0, 1.0)))


@pytest.mark.parametrize("d", [2, 3])
def test_sdf_of_sphere_and_bowl_match_the_closed_forms(d):
    rng = np.random.default_rng(0)
    c = rng.normal(size=d)
    R = 1.7
    pts = c + rng.normal(size=(50, d)) * 2.0
    dist = np.linalg.norm(pts - c, axis=1)
    s, b = Sphere(tuple(c), R), Bowl(tuple(c), R)
    np.testing.assert_allclose(s.phi(pts), dist - R, atol=1e-14)
    np.testing.assert_allclose(b.phi(pts), R - dist, atol=1e-14)
    np.testing.assert_allclose(s.grad_phi(pts), (pts - c) / dist[:, None], atol=1e-14)
    np.testing.assert_allclose(b.grad_phi(pts), (c - pts) / dist[:, None], atol=1e-14)
    # grad phi is the derivative of phi (central differences)
    eps = 1e-6
    for shape in (s, b):
        num = np.stack([(shape.phi(pts + eps * e) - shape.phi(pts - eps * e)) / (2 * eps) for e in np.eye(d)], axis=1)
        np.testing.assert_allclose(shape.grad_phi(pts), num, atol=1e-8)
    # samples lie on the boundary
    for shape in (s, b):
        np.testing.assert_allclose(shape.phi(shape.surface_points(257)), 0.0, atol=1e-12)


def _sphere_sphere_drop(RA, d, theta):
    """Depth lost by the sample at angle theta from A's deepest point into sphere B (centres d apart)."""
    return math.sqrt(d * d - 2 * d * RA * math.cos(theta) + RA * RA) - (d - RA)


def _sphere_bowl_drop(r, d, theta):
    """Depth lost by the sample at angle theta from the deepest point of a sphere (radius r, centre at
    distance d from the bowl's centre) into the bowl's solid."""
    return (d + r) - math.sqrt(d * d + 2 * d * r * math.cos(theta) + r * r)


def _cases(d):
    """(label, a, b, exact overlap, exact depth, the shape whose boundary holds the deepest point,
    unit direction of that point from its centre, drop of the depth as a function of the angle)."""
    e = _unit([0.6, -0.48, 0.64][:d] if d == 3 else [0.6, 0.8])
    out = []
    # two solid spheres, overlapping by 0.5
    A = Sphere(tuple(np.zeros(d)), 1.0)
    B = Sphere(tuple(1.5 * e), 1.0)
    out.append(("sphere/sphere overlapping", A, B, True, 0.5, A, e, lambda th: _sphere_sphere_drop(1.0, 1.5, th)))
    # two solid spheres 0.3 apart: no overlap, depth = -(gap)
    B2 = Sphere(tuple(2.3 * e), 1.0)
    out.append(("sphere/sphere apart", A, B2, False, -0.3, A, e, lambda th: _sphere_sphere_drop(1.0, 2.3, th)))
    # a small sphere wholly inside a big one (off centre, d >= r): depth R + r - d
    big = Sphere(tuple(np.zeros(d)), 2.0)
    small = Sphere(tuple(0.8 * e), 0.5)
    # (the deepest point is the small sphere's point nearest the big centre: the same geometry
    # as two spheres, so the same drop formula)
    out.append(
        (
            "sphere wholly inside sphere",
            big,
            small,
            True,
            2.0 + 0.5 - 0.8,
            small,
            -e,
            lambda th: _sphere_sphere_drop(0.5, 0.8, th),
        )
    )
    # a ball pressing 0.1 into the wall of a bowl (R = 3): depth d + r - R
    bowl = Bowl(tuple(np.zeros(d)), 3.0)
    ball = Sphere(tuple(2.6 * e), 0.5)
    out.append(("sphere/bowl wall", ball, bowl, True, 0.1, ball, e, lambda th: _sphere_bowl_drop(0.5, 2.6, th)))
    # a ball floating in the bowl, 0.4 clear of the wall
    ball2 = Sphere(tuple(2.1 * e), 0.5)
    out.append(
        ("sphere inside bowl, clear", ball2, bowl, False, -0.4, ball2, e, lambda th: _sphere_bowl_drop(0.5, 2.1, th))
    )
    # a ball wholly inside the bowl's solid (beyond its sphere): depth d + r - R
    ball3 = Sphere(tuple(4.0 * e), 0.5)
    out.append(
        (
            "sphere wholly inside bowl solid",
            ball3,
            bowl,
            True,
            1.5,
            ball3,
            e,
            lambda th: _sphere_bowl_drop(0.5, 4.0, th),
        )
    )
    return out


@pytest.mark.parametrize("d", [2, 3])
@pytest.mark.parametrize("n_samples", [64, 2048])
@pytest.mark.parametrize("swap", [False, True], ids=["a,b", "b,a"])
def test_implicit_overlap_agrees_with_the_exact_answer_within_sampling_error(d, n_samples, swap):
    for label, a, b, overlapping, depth, deep_shape, direction, drop in _cases(d):
        first, second = (b, a) if swap else (a, b)
        res = implicit_overlap(first, second, n_samples=n_samples)
        assert bool(res) is overlapping and res.overlapping is overlapping, label
        theta = _nearest_sample_angle(deep_shape, direction, n_samples)
        err = drop(theta)
        assert depth - err - 1e-12 <= res.depth <= depth + 1e-12, (
            f"{label}: depth {res.depth:.6g}, exact {depth:.6g}, sampling error bound {err:.3g}"
        )
        # the reported point is a boundary sample of one shape at that depth inside the other
        on_a, on_b = abs(float(a.phi(res.point))) < 1e-12, abs(float(b.phi(res.point))) < 1e-12
        assert on_a or on_b, label
        other = b if on_a else a
        assert float(other.phi(res.point)) == pytest.approx(-res.depth, abs=1e-12), label


def test_implicit_overlap_depth_converges_to_the_exact_depth():
    d = 3
    label, a, b, _, depth, *_ = _cases(d)[0]
    errors = [depth - implicit_overlap(a, b, n_samples=n).depth for n in (128, 512, 2048, 8192)]
    assert all(e >= -1e-12 for e in errors)
    assert errors[-1] < 1e-3 * depth
    assert errors[-1] < errors[0] / 10


def test_implicit_overlap_rejects_mixed_dimensions_and_bad_sample_counts():
    with pytest.raises(ValueError, match="dimension"):
        implicit_overlap(Sphere((0, 0), 1.0), Sphere((0, 0, 0), 1.0))
    with pytest.raises(ValueError, match="n_samples"):
        implicit_overlap(Sphere((0, 0), 1.0), Sphere((1, 0), 1.0), n_samples=0)
    with pytest.raises(ValueError, match="radius"):
        Sphere((0, 0), -1.0)
    with pytest.raises(ValueError, match="radius"):
        Bowl((0, 0, 0), 0.0)
    with pytest.raises(ValueError, match="center"):
        Bowl((0, 0, 0, 0), 1.0)
    with pytest.raises(ValueError, match="center"):
        Sphere((0, float("nan")), 1.0)


# --------------------------------------------------------------------------------------------
# General shapes (docs/physics.md section 1): the sampled test against closed-form depths and
# distances of boxes, spheres and capsules, converging as the samples grow
# --------------------------------------------------------------------------------------------


def _segment_segment_distance(p1, q1, p2, q2, m=4001):
    """Distance between two segments, by a dense parameter grid on one and the exact projection on
    the other (independent of the kernels)."""
    t = np.linspace(0.0, 1.0, m)[:, None]
    pts = p1 + t * (q1 - p1)
    ab = q2 - p2
    u = np.clip(((pts - p2) @ ab) / (ab @ ab), 0.0, 1.0)
    return float(np.linalg.norm(pts - p2 - u[:, None] * ab, axis=1).min())


def _general_cases(d):
    """(label, a, b, exact depth: > 0 overlapping, < 0 minus the distance)."""
    from penalty_env.physics import Box, Capsule

    e = np.eye(d)
    z = np.zeros(d)
    cases = []
    big = Box(z, np.ones(d))
    for offset, depth in ((1.8, 0.2), (2.3, -0.3)):  # a box's face into (or 0.3 short of) another's
        cases.append((f"box-box {offset}", big, Box(offset * e[0], np.r_[1.0, np.full(d - 1, 0.5)]), depth))
    for D, depth in ((0.35, 0.15), (0.8, -0.3)):  # a sphere 0.35 (0.8) off a face, radius 0.5
        cases.append((f"box-sphere {D}", big, Sphere(tuple((1.0 + D) * e[-1]), 0.5), depth))
    # crossed capsules: axes along x and along the last axis... offset along y by s
    p1, q1 = -e[0], e[0]
    for s in (0.45, 0.75):
        p2 = s * e[1] + 0.3 * e[0] - 0.8 * e[-1] if d == 3 else s * e[1] + 0.3 * e[0] - 0.8 * e[1] * 0
        q2 = p2 + (1.6 * e[-1] if d == 3 else 0.6 * e[0])
        dist = _segment_segment_distance(p1, q1, p2, q2)
        cases.append((f"capsule-capsule {s}", Capsule(p1, q1, 0.3), Capsule(p2, q2, 0.25), 0.55 - dist))
    return cases


@pytest.mark.parametrize("d", [2, 3])
def test_implicit_overlap_of_boxes_spheres_and_capsules_converges_to_the_closed_forms(d):
    for label, a, b, exact in _general_cases(d):
        errors = []
        for n in (64, 256, 1024, 4096):
            res = implicit_overlap(a, b, n_samples=n)
            assert bool(res) is (exact > 0), (label, n, res.depth, exact)
            errors.append(abs(res.depth - exact))
        assert errors[-1] < 2e-3 * max(abs(exact), 0.1), (label, errors)
        assert errors[-1] <= errors[0] + 1e-12, (label, errors)
