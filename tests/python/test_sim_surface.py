"""pleat.sim.surface: the cloth's faces, not only its vertices, against the body. A coarse cloth whose vertices all
sit on a sphere cuts chords through it (every vertex outside, the faces inside by up to the sagitta); pushed out by
more than the sagitta, nothing is inside."""
import numpy as np

from pleat.sim.surface import face_samples, surface_inside


def _sphere(radius, rings, segments):
    """A UV sphere: vertices [V, 3], outward triangles [F, 3]."""
    theta = np.linspace(0, np.pi, rings + 1)[1:-1]
    phi = np.linspace(0, 2 * np.pi, segments, endpoint=False)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    v = np.stack([np.sin(t) * np.cos(p), np.cos(t), np.sin(t) * np.sin(p)], -1).reshape(-1, 3)
    v = np.vstack([[0, 1, 0], v, [0, -1, 0]]) * radius
    faces, n = [], segments
    for j in range(n):
        faces.append([0, 1 + (j + 1) % n, 1 + j])
    for i in range(rings - 2):
        for j in range(n):
            a, b = 1 + i * n + j, 1 + i * n + (j + 1) % n
            c, d = a + n, b + n
            faces += [[a, b, d], [a, d, c]]
    last = len(v) - 1
    base = 1 + (rings - 2) * n
    for j in range(n):
        faces.append([last, base + j, base + (j + 1) % n])
    return v, np.array(faces)


def test_face_samples_lie_inside_the_triangle_and_cover_it():
    b = face_samples(4000)
    assert np.allclose(b.sum(axis=1), 1.0) and (b >= 0).all()
    assert np.allclose(b.mean(axis=0), 1 / 3, atol=0.02)               # uniform: the mean is the centroid


def test_a_coarse_cloth_on_a_sphere_cuts_chords_and_an_offset_one_does_not():
    r = 0.05
    body_v, body_f = _sphere(r, 60, 120)                                # fine body: 1.3 mm edges
    cloth_v, cloth_f = _sphere(r * 1.0005, 6, 10)                       # coarse cloth: 3 cm edges, vertices outside
    got = surface_inside([body_v], body_f, [cloth_v], cloth_f)
    assert got["frames"] == 1 and got["inside_pct"] > 40.0
    # the deepest a face of the cloth's can dip is below its circumscribed sphere's sagitta bound
    edge = np.linalg.norm(cloth_v[cloth_f[:, 1]] - cloth_v[cloth_f[:, 0]], axis=1).max()
    assert 1.0 < got["median_depth_mm"] < got["max_depth_mm"] <= 1000 * edge ** 2 / (2 * r)
    pushed = surface_inside([body_v], body_f, [cloth_v * (1 + got["max_depth_mm"] / 1000 / r + 0.03)], cloth_f)
    assert pushed["inside_pct"] == 0.0 and pushed["max_depth_mm"] == 0.0
