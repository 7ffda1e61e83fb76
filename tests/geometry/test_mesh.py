"""Vessels from surface meshes (softrnn.geometry.mesh): the gap of meshed spheres and tubes against
the analytic one within the mesh's own deviation, the exact reference against brute force, the
one-line errors for open, degenerate, inverted and mis-scaled meshes, mesh files read with meshio,
the record's round trip, the shipped arch and its centreline."""

from importlib.resources import files

import meshio
import numpy as np
import pytest

from softrnn.errors import SoftrnnInputError
from softrnn.geometry import Contact, MeshVessel, Obstacle, contact_from_record, contact_record, load_mesh
from softrnn.geometry._marching import tube_tree_surface
from softrnn.geometry._mesh_build import closest_on_triangles
from softrnn.geometry.mesh import ARCH_FILE, arch_centrelines, write_surface

SCENARIOS = files("softrnn.scenarios")


def icosphere(radius: float, levels: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """A sphere's mesh: an icosahedron subdivided ``levels`` times, its vertices on the sphere."""
    t = (1 + 5**0.5) / 2
    v = [[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t], [0, -1, -t], [0, 1, -t],
         [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]]
    f = [[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4], [11, 10, 2], [10, 7, 6],
         [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10],
         [8, 6, 7], [9, 8, 1]]
    v = [np.array(p, dtype=float) for p in v]
    for _ in range(levels):
        mid, out = {}, []
        for a, b, c in f:
            m = []
            for i, j in ((a, b), (b, c), (c, a)):
                key = (min(i, j), max(i, j))
                if key not in mid:
                    mid[key] = len(v)
                    v.append((v[i] + v[j]) / 2)
                m.append(mid[key])
            out += [[a, m[0], m[2]], [b, m[1], m[0]], [c, m[2], m[1]], [m[0], m[1], m[2]]]
        f = out
    v = np.array(v)
    return radius * v / np.linalg.norm(v, axis=1)[:, None], np.array(f)


def brute_distance(vertices, faces, points):
    """Unsigned distances (n,) of points (n, 3) to every face, the least (brute force)."""
    x = vertices[faces]
    best = np.full(len(points), np.inf)
    for p_index, p in enumerate(points):
        q, _ = closest_on_triangles(np.repeat(p[None], len(faces), 0), x[:, 0], x[:, 1], x[:, 2])
        best[p_index] = np.sqrt(np.min(np.sum((q - p) ** 2, axis=1)))
    return best


def test_a_meshed_sphere_gives_the_analytic_gap_within_its_sagitta():
    R, r = 0.01, 0.0005
    v, f = icosphere(R)
    sphere = MeshVessel(v, f)
    sagitta = R - np.min(np.abs(np.einsum("ij,ij->i", sphere.face_normals, v[f[:, 0]])))
    assert sagitta < 0.01 * R
    rng = np.random.default_rng(1)
    d = rng.normal(size=(400, 3))
    x = d / np.linalg.norm(d, axis=1)[:, None] * rng.uniform(0.5 * R, 1.05 * R, size=(400, 1))
    gap, normal = sphere.gap(x, np.full(400, r))
    exact = R - np.linalg.norm(x, axis=1) - r
    assert np.all(gap <= exact + 1e-12) and np.all(gap >= exact - sagitta - 1e-12)
    inward = -x / np.linalg.norm(x, axis=1)[:, None]
    assert np.all(np.einsum("ij,ij->i", normal, inward) > 0.95)


def test_a_meshed_tube_gives_the_analytic_gap_of_a_cylinder_within_its_deviation():
    R, r, spacing = 0.003, 0.0004, 0.0005
    v, f = tube_tree_surface([(np.array([[0.0, 0, 0], [0.04, 0, 0]]), R)], spacing)
    tube = MeshVessel(v, f)
    middle = (v[:, 0] > 0.005) & (v[:, 0] < 0.035)
    deviation = np.max(np.abs(np.linalg.norm(v[middle][:, 1:], axis=1) - R))      # vertices off the cylinder
    edges = np.linalg.norm(v[f] - v[np.roll(f, 1, axis=1)], axis=2).max()
    sagitta = edges**2 / (2 * R)                                                  # a face's chord inside it
    rng = np.random.default_rng(2)
    angle, rad = rng.uniform(0, 2 * np.pi, 300), rng.uniform(0.3 * R, 1.1 * R, 300)
    x = np.stack([rng.uniform(0.01, 0.03, 300), rad * np.cos(angle), rad * np.sin(angle)], axis=1)
    gap, _ = tube.gap(x, np.full(300, r))
    error = np.abs(gap - (R - rad - r))
    assert error.max() < deviation + sagitta + 1e-9
    assert error.max() < 0.05 * r                      # the stated error: under 5 % of the rod radius here


def test_the_reference_distance_is_exact_against_brute_force():
    v, f = tube_tree_surface([(np.array([[0.0, 0, 0], [0.02, 0, 0], [0.03, 0.01, 0]]), 0.003),
                              (np.array([[0.02, 0, 0], [0.02, 0.0, 0.02]]), 0.002)], 0.0008)
    mesh = MeshVessel(v, f)
    rng = np.random.default_rng(3)
    x = rng.uniform(v.min(0), v.max(0), size=(60, 3))
    signed, _, _ = mesh.signed_distance(x)
    np.testing.assert_allclose(np.abs(signed), brute_distance(mesh.vertices, mesh.faces, x), rtol=0, atol=1e-15)


def _cube():
    v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1.0]]) * 0.01
    f = np.array([[0, 2, 1], [0, 3, 2], [4, 5, 6], [4, 6, 7], [0, 1, 5], [0, 5, 4], [1, 2, 6], [1, 6, 5],
                  [2, 3, 7], [2, 7, 6], [3, 0, 4], [3, 4, 7]])
    return v, f


@pytest.mark.parametrize("edit, words", [
    (lambda v, f: (v, f[1:]), "a closed surface, every edge shared by exactly two faces"),
    (lambda v, f: (v, np.vstack([f, [[0, 1, 1]]])), "without degenerate faces"),
    (lambda v, f: (np.vstack([v, [[0.02, 0, 0]]]), np.vstack([f, [[0, 1, 8]]])), "without degenerate faces"),
    (lambda v, f: (v, f[:, ::-1]), "outward-facing normals"),
    (lambda v, f: (v, np.vstack([f[:1, ::-1], f[1:]])), "oriented consistently"),
])
def test_a_bad_surface_is_refused_in_one_line(edit, words):
    v, f = edit(*_cube())
    MeshVessel(*_cube())
    with pytest.raises(SoftrnnInputError) as info:
        MeshVessel(v, f)
    assert words in str(info.value) and "\n" not in str(info.value)


def test_units_must_be_known_and_give_a_plausible_size():
    v, f = _cube()
    with pytest.raises(SoftrnnInputError, match="\"m\" or \"mm\""):
        MeshVessel(v, f, units="cm")
    with pytest.raises(SoftrnnInputError, match="units = \"m\""):
        MeshVessel(v, f, units="mm")                   # a 17 mm cube stated in mm: 17 um across
    with pytest.raises(SoftrnnInputError, match="units = \"mm\""):
        MeshVessel(v * 1000, f, units="m")             # the same cube in mm stated in m: 17 m across
    np.testing.assert_allclose(MeshVessel(v * 1000, f, units="mm").vertices.max(), 0.01)


@pytest.mark.parametrize("ext", [".stl", ".obj", ".ply", ".vtu", ".vtk"])
def test_mesh_files_are_read_with_their_units(tmp_path, ext):
    v, f = icosphere(5.0, levels=2)                    # mm
    path = tmp_path / f"ball{ext}"
    meshio.write(str(path), meshio.Mesh(v, [("triangle", f)]))
    ball = load_mesh(path, "mm")
    assert len(ball.faces) == len(f) and abs(ball.vertices.max() - 0.005) < 1e-9
    assert ball.file == str(path.resolve()) and len(ball.sha256) == 64


def test_unreadable_files_are_refused_in_one_line(tmp_path):
    (tmp_path / "a.stl").write_text("solid nothing\nendsolid\n")
    (tmp_path / "b.txt").write_text("1 2 3\n")
    for name, words in (("missing.stl", "an existing surface mesh file"), ("b.txt", "a surface mesh file"),
                        ("a.stl", "a surface mesh")):
        with pytest.raises(SoftrnnInputError, match=words) as info:
            load_mesh(tmp_path / name, "m", where="contact.obstacles.0.file")
        assert "contact.obstacles.0.file" in str(info.value) and name in str(info.value)


def test_the_record_rebuilds_the_mesh_from_its_arrays_or_its_file(tmp_path):
    v, f = icosphere(0.01, levels=2)
    inline = MeshVessel(v, f, friction=0.2)
    back = Obstacle.from_record(inline.to_record())
    np.testing.assert_array_equal(back.vertices, inline.vertices)
    np.testing.assert_array_equal(back.faces, inline.faces)
    assert back.friction == 0.2
    path = tmp_path / "ball.vtu"
    write_surface(path, v * 1000, f)
    kept = load_mesh(path, "mm", inlet=(0, 0, 0))
    contact = contact_from_record(contact_record(Contact(obstacles=(kept,), friction=0.1)))
    again = contact.obstacles[0]
    assert again.file == kept.file and again.sha256 == kept.sha256 and again.inlet == (0.0, 0.0, 0.0)
    np.testing.assert_array_equal(again.vertices, kept.vertices)
    write_surface(path, v * 1001, f)                    # the file changed since
    with pytest.raises(SoftrnnInputError, match="restore that file"):
        contact_from_record(contact_record(Contact(obstacles=(kept,))))


def test_the_shipped_arch_is_a_closed_tree_with_four_ends_and_progress_along_them():
    arch = load_mesh(f"{SCENARIOS}/{ARCH_FILE}", "m", inlet=(0.0, 0.0, -0.2))
    tubes = arch_centrelines()
    ends = [tubes[0][0][-1]] + [line[-1] for line, _ in tubes[1:]]
    centre = arch.centreline
    assert len(centre.branches) == 4
    for end in ends:
        b = centre.nearest_branch(end)
        assert np.linalg.norm(centre.branches[b][-1] - end) < 0.012     # within the end's cap and a voxel
        assert np.linalg.norm(centre.branches[b][0] - [0, 0, -0.2]) < 0.008
    b = centre.nearest_branch(ends[1])
    s = arch.centreline_progress(np.array([[0, 0, -0.15], [0, 0, -0.05], ends[1]]), b)
    assert np.all(np.diff(s) > 0) and abs(s[1] - s[0] - 0.1) < 0.005
    gap, _ = arch.gap(np.array([[0.0, 0.0, -0.1], [0.0059, 0.0, -0.1]]), np.zeros(2))
    assert 0.006 - 1e-4 < gap[0] <= 0.006                # a face's chord inside the 6 mm wall: under 0.1 mm
    assert abs(gap[1] - 0.0001) < 2e-5                    # near a vertex
