"""Body shapes (orchestrator/shapes): the registry, the superquadric's and the rounded box's numbers,
the case's checks.

No engine runs here: the superquadric's mass and inertia are the true brick's (shapes/clump.py's
closed form, which test_brick_drop.py checks against the study's numbers), its own volume follows
Barr's closed form (checked against a Monte Carlo estimate within 1 %, 200 000 samples: σ ≈ 0.2 %).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from orchestrator.case import CaseError, parse_case
from orchestrator.shapes import KINDS, make_shape
from orchestrator.shapes.rigid import rounded_box_moments
from orchestrator.shapes.rounded_box import brick_rounded_box
from orchestrator.shapes.superquadric import brick_superquadric
from orchestrator.studies.brick_drop import study_brick


def _case(engine: str, shape: dict, fixed: bool = False) -> dict:
    return {"name": "s", "engine": engine, "time": {"duration": 0.1, "output_interval": 0.01},
            "materials": [{"name": "brick", "density": 1700.0}],
            "contacts": [{"materials": ["brick", "brick"], "law": "bilinear", "en2": 0.13, "mu": 0.86, "kn": 1e5, "kt_over_kn": 0.27}],
            "shapes": [shape], "bodies": {"clumps": [{"shape": "brick", "material": "brick", "position": [0, 0, 0], "fixed": fixed}]}}


def test_an_unknown_kind_names_the_kinds_that_exist() -> None:
    class Spec:
        kind = "polyhedron"

    with pytest.raises(ValueError, match=r"shapes.kind: unknown kind 'polyhedron'; known: \['clump', 'rounded_box', 'superquadric'\]"):
        make_shape(Spec(), 1700.0)
    assert sorted(KINDS) == ["clump", "rounded_box", "superquadric"]


def test_the_superquadric_brick_has_the_true_brick_mass_and_inertia() -> None:
    body = brick_superquadric(0.031, 0.015, 0.008, 1700.0, (6.0, 6.0), rounding=0.001)
    volume, _, second = rounded_box_moments(np.array([0.031, 0.015, 0.008]), 0.001)
    assert body.mass == pytest.approx(1700.0 * volume, rel=1e-12)
    assert body.principal_inertia / body.mass == pytest.approx([2.36912e-5, 8.45563e-5, 9.77668e-5], rel=1e-5)
    assert body.engine_density * body.superquadric_volume == pytest.approx(body.mass, rel=1e-12)
    assert body.face_contacts == 1 and body.kind == "superquadric"


def test_the_superquadric_volume_matches_a_monte_carlo_estimate() -> None:
    body = brick_superquadric(0.031, 0.015, 0.008, 1700.0, (6.0, 4.0))
    a, b, c = body.half_axes
    points = np.random.default_rng(1).uniform(-1.0, 1.0, (200_000, 3))
    inside = (np.abs(points[:, 0]) ** 4 + np.abs(points[:, 1]) ** 4) ** (6.0 / 4.0) + np.abs(points[:, 2]) ** 6 <= 1.0
    assert body.superquadric_volume == pytest.approx(inside.mean() * 8 * a * b * c, rel=0.01)


def test_the_surface_mesh_lies_on_the_superquadric_and_is_closed() -> None:
    body = brick_superquadric(0.031, 0.015, 0.008, 1700.0, (6.0, 6.0))
    vertices, triangles = body.surface_mesh(16)
    a, b, c = body.half_axes
    level = (np.abs(vertices[:, 0] / a) ** 6 + np.abs(vertices[:, 1] / b) ** 6) + np.abs(vertices[:, 2] / c) ** 6
    assert level == pytest.approx(1.0, abs=1e-9)
    edges = np.sort(np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]]), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    assert set(counts) == {2}  # every edge shared by two triangles: a closed surface
    turned = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # 90° about z
    assert body.lowest_points(np.stack([np.eye(3), turned])) == pytest.approx([-c, -c], abs=1e-12)
    on_edge = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])  # 90° about x: lies on its side
    assert body.lowest_points(on_edge[None])[0] == pytest.approx(-b, abs=1e-12)
    assert math.sqrt(a * a + b * b + c * c) > body.bounding_radius > a


def test_a_clump_lowest_point_is_its_lowest_sphere() -> None:
    body = make_shape(parse_case(_case("liggghts", study_brick())).shapes[0], 1700.0)
    assert body.kind == "clump"
    assert body.lowest_points(np.eye(3)[None])[0] == pytest.approx(-0.004, abs=1e-12)


def test_an_engine_without_superquadrics_names_the_engines_that_have_them() -> None:
    with pytest.raises(CaseError, match=r"shapes.0.kind: yade takes clump bodies, not superquadric; engines that can: liggghts"):
        parse_case(_case("yade", study_brick(kind="superquadric")))
    parse_case(_case("liggghts", study_brick(kind="superquadric")))


def test_a_case_made_from_a_study_names_the_studys_fields() -> None:
    """parse_case(fields=…): the avalanche study's `brick` is its case's `shapes.0`, so the error names
    `brick.kind`; a field path is renamed whole (shapes.01, bodies.shapes.0 would stay)."""
    with pytest.raises(CaseError) as caught:
        parse_case(_case("yade", study_brick(kind="superquadric")), source="study s", fields={"shapes.0": "brick"})
    assert str(caught.value) == "study s: brick.kind: yade takes clump bodies, not superquadric; engines that can: liggghts"
    with pytest.raises(CaseError, match=r"^study s: brick: rounding: allowed: 0, or \[1e-06, 0.004\) m"):
        parse_case(_case("liggghts", study_brick(rounding=0.005)), source="study s", fields={"shapes.0": "brick"})
    with pytest.raises(CaseError, match=r"^case: shapes.0.kind: yade takes clump bodies"):  # without fields: the case's own names
        parse_case(_case("yade", study_brick(kind="superquadric")))


def test_glue_is_refused_where_the_engine_cannot_glue_that_kind() -> None:
    sphere_engine = _case("cocd", study_brick(), fixed=True)
    with pytest.raises(CaseError, match="bodies.clumps"):
        parse_case(sphere_engine)
    parse_case(_case("yade", study_brick(), fixed=True))


def test_a_superquadric_brick_cannot_be_bevelled() -> None:
    with pytest.raises(CaseError, match=r"bevel_deg: a superquadric brick has no bevelled faces"):
        parse_case(_case("liggghts", {**study_brick(kind="superquadric"), "rounding": 0.0, "bevel_deg": 2.0}))


def test_blockiness_out_of_range_names_the_field() -> None:
    with pytest.raises(CaseError, match="blockiness"):
        parse_case(_case("liggghts", study_brick(kind="superquadric", blockiness=(1.0, 6.0))))


def test_the_rounded_box_is_the_study_brick_in_closed_form() -> None:
    """Mass and inertia: the rounded solid's (the study's I/m, 5 digits); the surface mesh's volume
    converges on it (divergence theorem: within 0.02 % at resolution 24); every mesh vertex lies on
    the surface (penetration 0 to 1e-15 m); the lowest point is the lowest inner corner less r."""
    body = brick_rounded_box(0.031, 0.015, 0.008, 1700.0, 0.001)
    assert body.kind == "rounded_box" and body.particles == 1 and body.face_contacts == 4
    assert body.principal_inertia / body.mass == pytest.approx([2.36912e-5, 8.45563e-5, 9.77668e-5], rel=1e-5)
    assert body.inner_half_extents == pytest.approx([0.0145, 0.0065, 0.003], abs=1e-15)
    vertices, triangles = body.surface_mesh(24)
    p = vertices[triangles]
    mesh_volume = np.einsum("ij,ij->i", p[:, 0], np.cross(p[:, 1], p[:, 2])).sum() / 6.0
    assert mesh_volume == pytest.approx(body.volume, rel=2e-4)
    assert np.abs(body.penetration(vertices)).max() < 1e-15
    assert body.penetration(np.zeros((1, 3)))[0] == pytest.approx(0.004, abs=1e-15)  # the centre: 4 mm below the big face
    farthest = np.linalg.norm(vertices, axis=1).max()  # the mesh misses the exact corner direction: within 0.1 %
    assert farthest <= body.bounding_radius < farthest * 1.001
    tilt = math.radians(30.0)
    about_x = np.array([[1.0, 0.0, 0.0], [0.0, math.cos(tilt), -math.sin(tilt)], [0.0, math.sin(tilt), math.cos(tilt)]])
    assert body.lowest_points(np.stack([np.eye(3), about_x])) == pytest.approx(
        [-0.004, -(0.0065 * math.sin(tilt) + 0.003 * math.cos(tilt)) - 0.001], abs=1e-15)


def test_a_rounded_box_needs_its_rounding_and_the_bilinear_law() -> None:
    with pytest.raises(CaseError, match=r"rounding: a rounded_box brick is swept by a sphere of this radius"):
        parse_case(_case("liggghts", study_brick(kind="rounded_box", rounding=0.0)))
    linear = _case("liggghts", study_brick(kind="rounded_box"))
    linear["contacts"][0] = {"materials": ["brick", "brick"], "law": "linear", "en2": 0.13, "mu": 0.86, "kn": 1e5, "kt_over_kn": 0.27}
    with pytest.raises(CaseError, match=r"contacts.law: rounded_box bodies touch by the bilinear law .* allowed: bilinear \(got linear\)"):
        parse_case(linear)
    with pytest.raises(CaseError, match=r"record_contacts: liggghts does not record the contacts of rounded_box bodies; allowed: false"):
        parse_case({**_case("liggghts", study_brick(kind="rounded_box")), "record_contacts": True})
    with pytest.raises(CaseError, match=r"shapes.0.kind: yade takes clump bodies, not rounded_box; engines that can: liggghts"):
        parse_case(_case("yade", study_brick(kind="rounded_box")))
    parse_case(_case("liggghts", study_brick(kind="rounded_box")))
