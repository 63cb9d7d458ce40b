"""The cycloid profile's contact-search table (rvtool.geometry.cycloid.CycloidProfile.table), whose
dense grid's trigonometry and unrotated points are kept between calls, against the table computed
from scratch (the formula as it stands in the module docstring, written out here): bit for bit."""
import dataclasses

import numpy as np
import pytest

from rvtool import designs, load_design


def table_from_scratch(p, n_samples):
    """The arc-length table without anything kept between calls: every point from
    Eq. (cycloid_geometry) on the dense grid, arc length, resampling, normals, curvature, order."""
    def rotate(xy):
        if p.rotation_mod == 0.0:
            return xy
        c, s = np.cos(p.rotation_mod), np.sin(p.rotation_mod)
        return np.stack([c * xy[..., 0] - s * xy[..., 1], s * xy[..., 0] + c * xy[..., 1]], axis=-1)

    def points(phi):
        R, K1, zb = p.R, p.K1, p.n_pins
        E = R * np.stack([np.sin(phi) - K1 / zb * np.sin(zb * phi), np.cos(phi) - K1 / zb * np.cos(zb * phi)], axis=-1)
        dE = R * np.stack([np.cos(phi) - K1 * np.cos(zb * phi), -np.sin(phi) + K1 * np.sin(zb * phi)], axis=-1)
        D = np.linalg.norm(dE, axis=-1) / R
        inward = np.stack([K1 * np.sin(zb * phi) - np.sin(phi), K1 * np.cos(zb * phi) - np.cos(phi)], axis=-1) / D[..., None]
        return rotate(E + p.generating_radius(phi)[..., None] * inward)
    dense = np.linspace(0, 2 * np.pi, 16 * n_samples, endpoint=False)
    P = points(dense)
    seg = np.linalg.norm(np.diff(np.vstack([P, P[:1]]), axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    phi = np.interp(np.arange(n_samples) * s[-1] / n_samples, s, np.concatenate([dense, [2 * np.pi]]))
    pts = points(phi)
    _, dE, _ = p.epitrochoid(phi)
    tang = rotate(dE / np.linalg.norm(dE, axis=-1)[..., None])
    nrm = np.stack([-tang[..., 1], tang[..., 0]], axis=-1)
    polar = np.mod(np.arctan2(pts[:, 1], pts[:, 0]), 2 * np.pi)
    order = np.argsort(polar)
    return pts[order], nrm[order], p.curvature_of_points(phi)[order], polar[order], s[-1] / n_samples, phi[order]


def _profiles():
    rd = load_design(designs.path("rd40")).profile
    yield "rd40", rd
    yield "rd40 wheel 2 (rotated)", dataclasses.replace(rd, rotation_mod=np.pi / rd.n_teeth)
    yield "rd40 variant mods", dataclasses.replace(rd, equidistant_mod=1.3e-6, offset_mod=-0.7e-6, rotation_mod=-0.01)
    yield "tabulated radial mod", dataclasses.replace(rd, radial_mod_table=((0.0, 0.0), (0.05, 2e-6), (0.1, 0.0)))
    yield "rv40e", load_design(designs.path("rv40e")).profile


@pytest.mark.parametrize("name,profile", list(_profiles()), ids=[n for n, _ in _profiles()])
def test_the_table_equals_the_one_computed_from_scratch_bit_for_bit(name, profile):
    n = 40 * profile.n_teeth
    for _ in range(2):                              # the second call takes the kept grid and points
        got = profile.table(n)
        for a, b in zip(got, table_from_scratch(profile, n), strict=True):
            assert np.array_equal(a, b)


def test_the_wheels_of_one_reducer_share_their_unrotated_points_but_not_their_tables():
    """Two profiles that differ in the rotation only: the second's table is its own (rotated), and
    writing into a returned table leaves the next one unchanged."""
    rd = load_design(designs.path("rd40")).profile
    other = dataclasses.replace(rd, rotation_mod=0.3)
    a, b = rd.table(960), other.table(960)
    assert not np.allclose(a[0], b[0])
    for x, y in zip(b, table_from_scratch(other, 960)):
        assert np.array_equal(x, y)
    for x in a:
        if isinstance(x, np.ndarray):
            x[...] = 0.0
    for x, y in zip(rd.table(960), table_from_scratch(rd, 960)):
        assert np.array_equal(x, y)
