"""The independent checker (tools/check/cpmesh_check.py) on hand-made meshes: a good one passes, and each kind of
breakage it exists to find makes it fail, naming the check."""
import gzip
import io
import os
import sys
import tempfile
import unittest
from contextlib import redirect_stdout

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "..", "tools", "check"))
import cpmesh_check as cc  # noqa: E402

# The unit cube cut into six tets around its main diagonal (Kuhn), material 1.
CUBE = np.array([[x, y, z] for z in (0, 1) for y in (0, 1) for x in (0, 1)], dtype=float)
KUHN = np.array([[0, 1, 3, 7], [0, 1, 5, 7], [0, 2, 3, 7], [0, 2, 6, 7], [0, 4, 5, 7], [0, 4, 6, 7]])


def boundary(tets, material):
    """The faces between materials (outside = 0), with their sorted pairs."""
    faces = {}
    for t, m in zip(tets.tolist(), material.tolist()):
        for f in ([t[1], t[2], t[3]], [t[0], t[2], t[3]], [t[0], t[1], t[3]], [t[0], t[1], t[2]]):
            faces.setdefault(tuple(sorted(f)), []).append(m)
    tris, pairs = [], []
    for f, ms in faces.items():
        a, b = (ms + [0])[:2]
        if a != b:
            tris.append(list(f))
            pairs.append(sorted((a, b)))
    return np.array(tris), np.array(pairs)


def write_vtp(path, points, tris, pairs, feature):
    def arr(kind, name, comps, values):
        return (f'<DataArray type="{kind}" Name="{name}" NumberOfComponents="{comps}" format="ascii">\n'
                + " ".join(str(v) for v in np.asarray(values).ravel().tolist()) + "\n</DataArray>\n")
    with open(path, "w") as f:
        f.write('<?xml version="1.0"?>\n<VTKFile type="PolyData"><PolyData>'
                f'<Piece NumberOfPoints="{len(points)}" NumberOfPolys="{len(tris)}">\n<Points>'
                + arr("Float64", "Points", 3, points) + "</Points><Polys>" + arr("Int64", "connectivity", 1, tris)
                + arr("Int64", "offsets", 1, 3 * np.arange(1, len(tris) + 1)) + "</Polys><CellData>"
                + arr("UInt16", "material_pair", 2, pairs) + "</CellData><PointData>" + arr("UInt8", "feature", 1, feature)
                + "</PointData></Piece></PolyData></VTKFile>\n")


def write_vtu(path, points, tets, material):
    def arr(kind, name, values):
        return (f'<DataArray type="{kind}" Name="{name}" format="ascii">\n'
                + " ".join(str(v) for v in np.asarray(values).ravel().tolist()) + "\n</DataArray>\n")
    with open(path, "w") as f:
        f.write('<?xml version="1.0"?>\n<VTKFile type="UnstructuredGrid"><UnstructuredGrid>'
                f'<Piece NumberOfPoints="{len(points)}" NumberOfCells="{len(tets)}"><Points>'
                + arr("Float64", "Points", points) + "</Points><Cells>" + arr("Int64", "connectivity", tets)
                + arr("Int64", "offsets", 4 * np.arange(1, len(tets) + 1)) + arr("UInt8", "types", np.full(len(tets), 10))
                + "</Cells><CellData>" + arr("UInt16", "material", material) + "</CellData></Piece></UnstructuredGrid></VTKFile>\n")


def write_nrrd(path, labels, dims):
    header = (f"NRRD0004\ntype: uint16\ndimension: 3\nsizes: {dims[0]} {dims[1]} {dims[2]}\n"
              "space directions: (1,0,0) (0,1,0) (0,0,1)\nendian: little\nencoding: gzip\n\n")
    with open(path, "wb") as f:
        f.write(header.encode() + gzip.compress(np.asarray(labels, dtype="<u2").tobytes()))


class CheckerTest(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.TemporaryDirectory()
        self.points, self.tets, self.material = CUBE.copy(), KUHN.copy(), np.ones(6, dtype=int)
        self.labels = [1]

    def tearDown(self):
        self.dir.cleanup()

    def run_checker(self, tris=None, pairs=None, feature=None, extra=()):
        d = self.dir.name
        t, p = boundary(self.tets, self.material)
        tris = t if tris is None else tris
        pairs = p if pairs is None else pairs
        feature = np.full(len(self.points), 2) if feature is None else feature
        write_vtp(f"{d}/s.vtp", self.points, tris, pairs, feature)
        write_vtu(f"{d}/v.vtu", self.points, self.tets, self.material)
        write_nrrd(f"{d}/l.nrrd", self.labels, [len(self.labels), 1, 1])
        out = io.StringIO()
        with redirect_stdout(out):
            code = cc.main(["--surfaces", f"{d}/s.vtp", "--tets", f"{d}/v.vtu", "--volume", f"{d}/l.nrrd",
                            "--radius-ratio-mean", "0.8", "--min-label-voxels", "1", "--volume-min-voxels", "1",
                            "--json", f"{d}/r.json", *extra])
        return code, out.getvalue()

    def test_a_good_mesh_passes(self):
        code, text = self.run_checker()
        self.assertEqual(code, 0, text)
        self.assertIn("cpmesh-check: ok", text)

    def test_a_missing_triangle_opens_the_material_and_the_interface(self):
        t, p = boundary(self.tets, self.material)
        code, text = self.run_checker(t[1:], p[1:])
        self.assertEqual(code, 1)
        self.assertIn("FAIL closure: material 1", text)
        self.assertIn("off the triple curves", text)
        self.assertIn("FAIL conformity", text)

    def test_an_edge_in_three_triangles_of_one_interface(self):
        t, p = boundary(self.tets, self.material)
        self.points = np.vstack([self.points, [[0.5, -1.0, -1.0]]])
        fin = np.array([[0, 1, 8]])  # on edge 0-1 of the cube, a fin outside it
        code, text = self.run_checker(np.vstack([t, fin]), np.vstack([p, [[0, 1]]]), extra=["--only", "interfaces"])
        self.assertEqual(code, 1)
        self.assertIn("in 3 triangles", text)

    def test_a_wrong_face(self):
        t, p = boundary(self.tets, self.material)
        p = p.copy()
        p[0] = [1, 2]  # vertex tags say interface: a vertex now touches materials 0, 1 and 2
        code, text = self.run_checker(t, p, extra=["--only", "wrong faces"])
        self.assertEqual(code, 1)
        self.assertIn("FAIL wrong faces", text)
        tagged = np.full(len(self.points), 0)  # as quadruple points, up to four materials are allowed
        code, text = self.run_checker(t, p, feature=tagged, extra=["--only", "wrong faces"])
        self.assertEqual(code, 0, text)

    def test_a_junction_point_of_more_than_four_materials_where_the_volume_has_them(self):
        # Five materials at cube corner 0; the 2 x 2 x 2 volume's voxels within a voxel of it hold labels 1-4, and
        # 0 lies beyond its faces.
        t, p = boundary(self.tets, self.material)
        self.labels = [1, 2, 3, 4, 1, 1, 1, 1]
        d = self.dir.name
        at_corner = [i for i, tri in enumerate(t.tolist()) if 0 in tri]
        for mats, expected in (([0, 1, 2, 3, 4], 0), ([0, 1, 2, 3, 9], 1)):
            p = p.copy()
            for k, i in enumerate(at_corner):
                p[i] = sorted((mats[k % 5], mats[(k + 1) % 5]))
            write_nrrd(f"{d}/l2.nrrd", self.labels, [2, 2, 2])
            write_vtp(f"{d}/s.vtp", self.points, t, p, np.zeros(len(self.points), dtype=int))
            out = io.StringIO()
            with redirect_stdout(out):
                code = cc.main(["--surfaces", f"{d}/s.vtp", "--volume", f"{d}/l2.nrrd", "--only", "wrong faces"])
            self.assertEqual(code, expected, out.getvalue())
            self.assertIn("wrong_faces                  0" if expected == 0 else "FAIL wrong faces", out.getvalue())

    def test_crossing_triangles(self):
        p = np.array([[0, 0, 0], [2, 0, 0], [0, 2, 0], [0.5, 0.5, -1], [0.5, 0.5, 1], [1.5, 1.5, 0.2],
                      [5, 5, 5], [6, 5, 5], [5, 6, 5]], dtype=float)
        tris = np.array([[0, 1, 2], [3, 4, 5], [6, 7, 8]])
        self.assertEqual(cc.crossing_pairs(p, tris).tolist(), [[0, 1]])
        touching = np.array([[0, 1, 2], [1, 3, 4]])  # sharing a vertex is not a crossing
        self.assertEqual(len(cc.crossing_pairs(p, touching)), 0)

    def test_a_sliver(self):
        self.points[7] = [0.5, 0.5, 0.02]  # the far corner pulled almost onto the bottom face
        code, text = self.run_checker(extra=["--only", "quality"])
        self.assertEqual(code, 1)
        self.assertIn("smallest dihedral", text)

    def test_a_tet_relabelled_breaks_conformity(self):
        t, p = boundary(self.tets, self.material)
        self.material[0] = 2
        code, text = self.run_checker(t, p, extra=["--only", "conformity"])
        self.assertEqual(code, 1)
        self.assertIn("FAIL conformity", text)

    def test_labels_missing_or_off_in_volume(self):
        self.labels = [1, 7, 7]  # label 7 has voxels and no mesh; label 1's voxel is the unit cube
        code, text = self.run_checker(extra=["--only", "labels"])
        self.assertEqual(code, 1)
        self.assertIn("label 7 (2 voxels) has no interface triangles", text)
        self.labels = [1]
        self.points = self.points * 1.1  # 33% too large
        code, text = self.run_checker(extra=["--only", "labels"])
        self.assertEqual(code, 1)
        self.assertIn("% off", text)

    def test_bad_input_is_exit_2(self):
        path = os.path.join(self.dir.name, "bad.vtp")
        with open(path, "w") as f:
            f.write("<VTKFile")
        with redirect_stdout(io.StringIO()):
            self.assertEqual(cc.main(["--surfaces", path]), 2)


if __name__ == "__main__":
    unittest.main()
