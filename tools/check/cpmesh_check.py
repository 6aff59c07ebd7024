#!/usr/bin/env python3
"""cpmesh-check: an independent checker of the meshes cpmesh writes.

It reads the written files only (the input label volume as NRRD, interfaces.vtp, volume.vtu) with its own parsers and
its own geometry (NumPy), and shares no code with the engine, so a bug in the pipeline's own counters cannot hide a
bad mesh. What it checks (docs/design.md, "The guarantee"):

  interfaces   every interface (material pair) is edge-manifold: no edge in more than two of its triangles; an
               edge in one of them (a boundary edge) lies on a triple curve (three or more interface triangles
               share it, and both its ends are tagged curve or quadruple point)
  vertices     every vertex's umbrella within an interface is one fan (vertex-manifold; stricter than the
               guarantee, which asks for edge-manifold interfaces)
  closure      every material's boundary (the triangles with it on one side, the outside counting as label 0) is
               closed: every edge in an even number of them
  wrong faces  a vertex tagged as an interface vertex has triangles of one material pair only; a curve vertex of
               at most three materials, a junction point of at most four, or of more where the volume (--volume)
               has each of them within a voxel of it (around a voxel corner up to eight labels meet; a label of
               fewer than --min-label-voxels voxels stands also for the labels it touches, as cpmesh merges it)
  crossings    no two triangles that share no vertex intersect (edge-triangle tests on candidate pairs from a grid)
  conformity   the tet faces between two materials (or on the hull) are exactly the interface triangles
  labels       every label with at least --min-label-voxels voxels has tets and interface triangles; the tet volume
               of every label with at least --volume-min-voxels voxels is within --volume-tolerance of its voxels'
  quality      smallest tet dihedral angle at least --min-dihedral; interface radius ratio mean and min at least
               --radius-ratio-mean and --radius-ratio-min

Exit status: 0 when every check passes, 1 when one fails (each failure printed with where it is), 2 for bad input.
"""
import argparse
import gzip
import json
import re
import sys
import xml.etree.ElementTree as ET

import numpy as np


class InputError(Exception):
    pass


# ---------------------------------------------------------------------------------------------------------- readers
NRRD_TYPES = {
    "uchar": "u1", "unsigned char": "u1", "uint8": "u1", "uint8_t": "u1",
    "signed char": "i1", "int8": "i1", "int8_t": "i1",
    "ushort": "u2", "unsigned short": "u2", "uint16": "u2", "uint16_t": "u2",
    "short": "i2", "signed short": "i2", "int16": "i2", "int16_t": "i2",
    "uint": "u4", "unsigned int": "u4", "uint32": "u4", "uint32_t": "u4",
    "int": "i4", "signed int": "i4", "int32": "i4", "int32_t": "i4",
}


def read_nrrd(path):
    """The labels (x fastest, as a flat array), dims, spacing and origin of an attached NRRD (raw or gzip)."""
    with open(path, "rb") as f:
        data = f.read()
    end = data.find(b"\n\n")
    if not data.startswith(b"NRRD") or end < 0:
        raise InputError(f"{path}: expected an attached NRRD header ending in a blank line")
    fields = {}
    for line in data[:end].decode("latin-1").split("\n")[1:]:
        if line.startswith("#") or ":" not in line:
            continue
        key, value = line.split(":", 1)
        fields[key.strip().lower()] = value.strip().lstrip("=").strip()
    if "data file" in fields:
        raise InputError(f"{path}: field 'data file': detached data is not supported by the checker")
    kind = NRRD_TYPES.get(fields.get("type", "").lower())
    if kind is None:
        raise InputError(f"{path}: field 'type': expected an integer label type, got '{fields.get('type')}'")
    dims = [int(s) for s in fields.get("sizes", "").split()]
    if len(dims) != 3:
        raise InputError(f"{path}: field 'sizes': expected three sizes")
    spacing = [1.0, 1.0, 1.0]
    if "space directions" in fields:
        vectors = re.findall(r"\(([^)]*)\)", fields["space directions"])
        spacing = [float(np.linalg.norm([float(x) for x in v.split(",")])) for v in vectors]
    elif "spacings" in fields:
        spacing = [float(s) for s in fields["spacings"].split()]
    origin = [0.0, 0.0, 0.0]
    if "space origin" in fields:
        origin = [float(x) for x in re.findall(r"\(([^)]*)\)", fields["space origin"])[0].split(",")]
    payload = data[end + 2:]
    if fields.get("encoding", "raw") in ("gzip", "gz"):
        payload = gzip.decompress(payload)
    endian = "<" if fields.get("endian", "little") == "little" else ">"
    labels = np.frombuffer(payload, dtype=endian + kind)
    if labels.size != dims[0] * dims[1] * dims[2]:
        raise InputError(f"{path}: expected {dims[0] * dims[1] * dims[2]} samples, got {labels.size}")
    return labels.astype(np.int64), dims, spacing, origin


class LabelsNear:
    """The labels of the voxels whose centres lie within one voxel (per axis) of a point, and 0 beyond the faces; a
    label of fewer than min_voxels voxels (which cpmesh merges into one it touches) brings the labels it touches."""

    def __init__(self, labels, dims, spacing, origin, min_voxels):
        self.grid = labels.reshape(dims[2], dims[1], dims[0])
        self.dims, self.spacing, self.origin = np.array(dims), np.array(spacing), np.array(origin)
        ids, counts = np.unique(labels, return_counts=True)
        padded = np.pad(self.grid, 1, constant_values=0)
        self.touching = {}
        for label in ids[counts < min_voxels].tolist():
            z, y, x = np.nonzero(padded == label)
            near = set()
            for dz, dy, dx in ((1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)):
                near.update(np.unique(padded[z + dz, y + dy, x + dx]).tolist())
            self.touching[label] = near

    def __call__(self, point):
        ijk = (np.asarray(point) - self.origin) / self.spacing
        lo, hi = np.floor(ijk - 1).astype(int), np.ceil(ijk + 1).astype(int)
        found = set()
        if (lo < 0).any() or (hi >= self.dims).any():
            found.add(0)
        lo, hi = np.clip(lo, 0, self.dims - 1), np.clip(hi, 0, self.dims - 1)
        found.update(np.unique(self.grid[lo[2]:hi[2] + 1, lo[1]:hi[1] + 1, lo[0]:hi[0] + 1]).tolist())
        for label in [l for l in found if l in self.touching]:
            found |= self.touching[label]
        return found


def vtk_arrays(path):
    """Name -> flat NumPy array of every ASCII DataArray of a VTK XML file, and the piece's attributes."""
    try:
        root = ET.parse(path).getroot()
    except (ET.ParseError, OSError) as e:
        raise InputError(f"{path}: {e}")
    piece = root.find(".//Piece")
    if piece is None:
        raise InputError(f"{path}: expected a Piece element")
    arrays = {}
    for a in root.iter("DataArray"):
        if a.get("format") != "ascii":
            raise InputError(f"{path}: DataArray '{a.get('Name')}': expected format ascii")
        kind = float if a.get("type", "").startswith("Float") else np.int64
        arrays[a.get("Name")] = np.array((a.text or "").split(), dtype=kind)
    return arrays, piece.attrib


def read_vtp(path):
    arrays, piece = vtk_arrays(path)
    n, m = int(piece["NumberOfPoints"]), int(piece["NumberOfPolys"])
    points = arrays["Points"].reshape(n, 3)
    if not np.all(arrays["offsets"] == 3 * np.arange(1, m + 1)):
        raise InputError(f"{path}: field 'offsets': expected triangles only")
    triangles = arrays["connectivity"].reshape(m, 3)
    pairs = np.sort(arrays["material_pair"].reshape(m, 2), axis=1)
    feature = arrays.get("feature", np.full(n, 2)).astype(np.int64)
    return points, triangles, pairs, feature


def read_vtu(path):
    arrays, piece = vtk_arrays(path)
    n, m = int(piece["NumberOfPoints"]), int(piece["NumberOfCells"])
    if not np.all(arrays["types"] == 10):
        raise InputError(f"{path}: field 'types': expected tetrahedra (10) only")
    return arrays["Points"].reshape(n, 3), arrays["connectivity"].reshape(m, 4), arrays["material"]


# ------------------------------------------------------------------------------------------------------- geometry
def edge_table(triangles, groups):
    """Per (group, edge) the number of triangles: arrays of keys (group, a, b) with a < b, and counts."""
    e = np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]])
    e.sort(axis=1)
    g = np.tile(groups, 3)
    keys = np.stack([g, e[:, 0], e[:, 1]], axis=1)
    uniq, counts = np.unique(keys, axis=0, return_counts=True)
    return uniq, counts


def radius_ratio(p, triangles):
    a, b, c = p[triangles[:, 0]], p[triangles[:, 1]], p[triangles[:, 2]]
    la, lb, lc = np.linalg.norm(b - c, axis=1), np.linalg.norm(c - a, axis=1), np.linalg.norm(a - b, axis=1)
    s = (la + lb + lc) / 2
    with np.errstate(invalid="ignore", divide="ignore"):
        q = 8 * (s - la) * (s - lb) * (s - lc) / (la * lb * lc)
    return np.nan_to_num(q, nan=0.0)


def dihedral_angles(p, tets):
    """The six dihedral angles (degrees) of every tet, shape (k, 6)."""
    x = p[tets]
    faces = [(1, 2, 3), (0, 3, 2), (0, 1, 3), (0, 2, 1)]  # face f is opposite vertex f
    normals = []
    for f in faces:
        n = np.cross(x[:, f[1]] - x[:, f[0]], x[:, f[2]] - x[:, f[0]])
        normals.append(n / np.maximum(np.linalg.norm(n, axis=1), 1e-300)[:, None])
    out = []
    for i in range(4):
        for j in range(i + 1, 4):
            cos = -np.sum(normals[i] * normals[j], axis=1)
            out.append(np.degrees(np.arccos(np.clip(cos, -1, 1))))
    return np.stack(out, axis=1)


def tet_volumes(p, tets):
    x = p[tets]
    return np.abs(np.einsum("ij,ij->i", np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]), x[:, 3] - x[:, 0])) / 6


def segment_hits_triangle(s0, s1, a, b, c, eps=1e-9):
    """Whether segment s0-s1 crosses the interior of triangle abc (Moller-Trumbore), vectorised over rows."""
    d = s1 - s0
    e1, e2 = b - a, c - a
    h = np.cross(d, e2)
    det = np.sum(e1 * h, axis=1)
    ok = np.abs(det) > 1e-14 * np.maximum(np.linalg.norm(e1, axis=1) * np.linalg.norm(e2, axis=1) * np.linalg.norm(d, axis=1), 1e-300)
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
    s = s0 - a
    u = inv * np.sum(s * h, axis=1)
    q = np.cross(s, e1)
    v = inv * np.sum(d * q, axis=1)
    t = inv * np.sum(e2 * q, axis=1)
    return ok & (u > eps) & (v > eps) & (u + v < 1 - eps) & (t > eps) & (t < 1 - eps)


def candidate_pairs(p, triangles):
    """Pairs (i < j) of triangles whose boxes share a grid cell."""
    lo, hi = p[triangles].min(axis=1), p[triangles].max(axis=1)
    cell = max(float(np.percentile((hi - lo).max(axis=1), 99)), 1e-12)
    clo, chi = np.floor(lo / cell).astype(np.int64), np.floor(hi / cell).astype(np.int64)
    span = chi - clo + 1
    reps = span.prod(axis=1)
    tri = np.repeat(np.arange(len(triangles)), reps)
    # The cells of each triangle's box: offsets within the box from a running index.
    local = np.arange(reps.sum()) - np.repeat(np.cumsum(reps) - reps, reps)
    sx, sy = np.repeat(span[:, 0], reps), np.repeat(span[:, 1], reps)
    cx = np.repeat(clo[:, 0], reps) + local % sx
    cy = np.repeat(clo[:, 1], reps) + (local // sx) % sy
    cz = np.repeat(clo[:, 2], reps) + local // (sx * sy)
    key = (cx * 73856093) ^ (cy * 19349663) ^ (cz * 83492791)
    order = np.lexsort((tri, key))
    key, tri = key[order], tri[order]
    starts = np.flatnonzero(np.r_[True, key[1:] != key[:-1]])
    sizes = np.diff(np.r_[starts, len(key)])
    pairs = []
    for k in np.unique(sizes[sizes > 1]):
        group_starts = starts[sizes == k]
        ii, jj = np.triu_indices(int(k), 1)
        pairs.append(np.stack([tri[group_starts[:, None] + ii].ravel(), tri[group_starts[:, None] + jj].ravel()], axis=1))
    if not pairs:
        return np.zeros((0, 2), dtype=np.int64)
    return np.unique(np.sort(np.concatenate(pairs), axis=1), axis=0)


def crossing_pairs(p, triangles, chunk=1 << 20):
    pairs = candidate_pairs(p, triangles)
    ti, tj = triangles[pairs[:, 0]], triangles[pairs[:, 1]]
    shared = (ti[:, :, None] == tj[:, None, :]).any(axis=2).sum(axis=1)
    pairs = pairs[shared == 0]
    found = []
    for start in range(0, len(pairs), chunk):
        pr = pairs[start:start + chunk]
        hit = np.zeros(len(pr), dtype=bool)
        for first, second in ((0, 1), (1, 0)):
            t, o = triangles[pr[:, first]], triangles[pr[:, second]]
            for e in ((0, 1), (1, 2), (2, 0)):
                hit |= segment_hits_triangle(p[t[:, e[0]]], p[t[:, e[1]]], p[o[:, 0]], p[o[:, 1]], p[o[:, 2]])
        found.append(pr[hit])
    return np.concatenate(found) if found else np.zeros((0, 2), dtype=np.int64)


def fans_per_vertex(triangles, groups):
    """(group, vertex) keys whose triangles within the group form more than one fan (joined across shared edges)."""
    bad = []
    by = {}
    for t, (tri, g) in enumerate(zip(triangles.tolist(), groups.tolist())):
        for v in tri:
            by.setdefault((g, v), []).append(t)
    for (g, v), ts in by.items():
        if len(ts) < 2:
            continue
        parent = {t: t for t in ts}

        def find(x):
            while parent[x] != x:
                parent[x] = parent[parent[x]]
                x = parent[x]
            return x

        owner = {}
        for t in ts:
            for w in triangles[t].tolist():
                if w == v:
                    continue
                if w in owner:
                    parent[find(t)] = find(owner[w])
                else:
                    owner[w] = t
        if len({find(t) for t in ts}) > 1:
            bad.append((g, v))
    return bad


# --------------------------------------------------------------------------------------------------------- checks
class Report:
    def __init__(self):
        self.failures, self.values = [], {}

    def fail(self, check, message):
        self.failures.append({"check": check, "message": message})

    def where(self, p):
        return "(" + ", ".join(f"{x:.3f}" for x in p) + ")"


def pair_name(pair):
    return f"{int(pair[0])}/{int(pair[1])}"


def check_surfaces(r, p, triangles, pairs, feature, limit, labels_near=None):
    pair_ids, group = np.unique(pairs, axis=0, return_inverse=True)
    group = group.ravel()
    r.values["interfaces"] = len(pair_ids)
    r.values["interface_triangles"] = len(triangles)
    keys, counts = edge_table(triangles, group)
    all_keys, all_counts = edge_table(triangles, np.zeros(len(triangles), dtype=np.int64))
    total = dict(zip(map(tuple, all_keys[:, 1:].tolist()), all_counts.tolist()))
    bad_interfaces = set()
    for (g, a, b), c in zip(keys.tolist(), counts.tolist()):
        if c > 2:
            bad_interfaces.add(g)
            r.fail("interfaces", f"interface {pair_name(pair_ids[g])}: edge {a}-{b} at {r.where((p[a] + p[b]) / 2)} in {c} triangles")
        elif c == 1 and (total[(a, b)] < 3 or feature[a] == 2 or feature[b] == 2):
            bad_interfaces.add(g)
            r.fail("interfaces", f"interface {pair_name(pair_ids[g])}: boundary edge {a}-{b} at {r.where((p[a] + p[b]) / 2)} "
                                 f"off the triple curves ({total[(a, b)]} interface triangles share it)")
    r.values["manifold_interfaces"] = len(pair_ids) - len(bad_interfaces)
    fans = fans_per_vertex(triangles, group)
    r.values["nonmanifold_vertices"] = len(fans)
    for g, v in fans:
        r.fail("vertices", f"interface {pair_name(pair_ids[g])}: vertex {v} at {r.where(p[v])} joins two fans")

    # Closure: the boundary of each material, edge counts even.
    materials = np.unique(pairs)
    open_materials = 0
    for m in materials.tolist():
        sel = np.flatnonzero((pairs[:, 0] == m) | (pairs[:, 1] == m))
        k, c = edge_table(triangles[sel], np.zeros(len(sel), dtype=np.int64))
        odd = k[c % 2 == 1]
        if len(odd):
            open_materials += 1
            a, b = odd[0, 1], odd[0, 2]
            r.fail("closure", f"material {m}: {len(odd)} open edges, e.g. {a}-{b} at {r.where((p[a] + p[b]) / 2)}")
    r.values["materials_closed"] = f"{len(materials) - open_materials} of {len(materials)}"

    # Wrong faces: the materials around a vertex against what its tag allows.
    v = np.concatenate([triangles[:, 0], triangles[:, 1], triangles[:, 2], triangles[:, 0], triangles[:, 1], triangles[:, 2]])
    m = np.concatenate([pairs[:, 0]] * 3 + [pairs[:, 1]] * 3)
    vm = np.unique(np.stack([v, m], axis=1), axis=0)
    per_vertex = np.bincount(vm[:, 0], minlength=len(p))
    allowed = np.array([4, 3, 2])[np.clip(feature, 0, 2)]
    bad_vertices = np.flatnonzero(per_vertex > allowed)
    if labels_near is not None:
        # A junction point of more than four materials is right where those labels meet in the volume: around a
        # voxel corner up to eight do.
        touched = {}
        for vertex, material in vm[np.isin(vm[:, 0], bad_vertices) & (feature[vm[:, 0]] == 0)].tolist():
            touched.setdefault(vertex, set()).add(material)
        right = [v for v, ms in touched.items() if ms <= labels_near(p[v])]
        bad_vertices = np.setdiff1d(bad_vertices, right)
    wrong = np.isin(triangles, bad_vertices).any(axis=1)
    r.values["wrong_faces"] = int(wrong.sum())
    for t in np.flatnonzero(wrong)[:limit]:
        r.fail("wrong faces", f"triangle {t} ({pair_name(pairs[t])}) at {r.where(p[triangles[t]].mean(axis=0))}: a vertex "
                              f"touches more materials than its feature has")

    crossings = crossing_pairs(p, triangles)
    r.values["crossing_pairs"] = len(crossings)
    for i, j in crossings[:limit].tolist():
        r.fail("crossings", f"triangles {i} ({pair_name(pairs[i])}) and {j} ({pair_name(pairs[j])}) cross near "
                            f"{r.where(p[triangles[i]].mean(axis=0))}")

    q = radius_ratio(p, triangles)
    r.values["radius_ratio_mean"] = float(q.mean()) if len(q) else 0.0
    r.values["radius_ratio_min"] = float(q.min()) if len(q) else 0.0
    return pair_ids


def face_keys(p, faces):
    """A key per triangle from its vertices' coordinates (order-free), so two files' vertex numberings need not agree."""
    coords = p[faces]  # (n, 3, 3)
    order = np.lexsort((coords[:, :, 2], coords[:, :, 1], coords[:, :, 0]), axis=1)
    sorted_coords = np.take_along_axis(coords, order[:, :, None], axis=1)
    return [c.tobytes() for c in sorted_coords]


def check_tets(r, tp, tets, material, sp, triangles, pairs, args):
    r.values["tets"] = len(tets)
    vol = np.einsum("ij,ij->i", np.cross(tp[tets[:, 1]] - tp[tets[:, 0]], tp[tets[:, 2]] - tp[tets[:, 0]]), tp[tets[:, 3]] - tp[tets[:, 0]])
    inverted_or_flat = int((np.abs(vol) <= 1e-15 * np.abs(vol).max()).sum()) if len(vol) else 0
    r.values["flat_tets"] = inverted_or_flat
    if inverted_or_flat:
        r.fail("quality", f"{inverted_or_flat} tets of zero volume")
    angles = dihedral_angles(tp, tets)
    smallest = angles.min(axis=1)
    r.values["min_dihedral"] = float(smallest.min()) if len(smallest) else 0.0
    r.values["max_dihedral"] = float(angles.max()) if len(smallest) else 0.0
    below = np.flatnonzero(smallest < args.min_dihedral)
    r.values["tets_below_min_dihedral"] = len(below)
    for t in below[np.argsort(smallest[below])][: args.limit]:
        r.fail("quality", f"tet {t} (material {material[t]}) at {r.where(tp[tets[t]].mean(axis=0))}: smallest dihedral "
                          f"{smallest[t]:.2f} degrees")

    # Conformity: faces between materials (or on the hull) against the interface triangles.
    faces = np.concatenate([tets[:, [1, 2, 3]], tets[:, [0, 2, 3]], tets[:, [0, 1, 3]], tets[:, [0, 1, 2]]])
    owner = np.tile(np.arange(len(tets)), 4)
    sf = np.sort(faces, axis=1)
    uniq, inverse, counts = np.unique(sf, axis=0, return_inverse=True, return_counts=True)
    inverse = inverse.ravel()
    first = np.full(len(uniq), -1)
    second = np.full(len(uniq), -1)
    order = np.argsort(inverse, kind="stable")
    starts = np.r_[0, np.cumsum(counts)[:-1]]
    first = owner[order[starts]]
    second = np.where(counts > 1, owner[order[np.minimum(starts + 1, len(order) - 1)]], -1)
    if np.any(counts > 2):
        r.fail("conformity", f"{int((counts > 2).sum())} tet faces shared by more than two tets")
    m1 = material[first]
    m2 = np.where(second >= 0, material[np.maximum(second, 0)], 0)
    boundary = m1 != m2
    tet_faces = {}
    for key, a, b in zip(face_keys(tp, uniq[boundary]), m1[boundary].tolist(), m2[boundary].tolist()):
        tet_faces[key] = (min(a, b), max(a, b))
    surf = {}
    for key, pr in zip(face_keys(sp, triangles), pairs.tolist()):
        surf[key] = tuple(pr)
    missing = [k for k in surf if k not in tet_faces]
    extra = [k for k in tet_faces if k not in surf]
    relabelled = [k for k in surf if k in tet_faces and tet_faces[k] != surf[k]]
    r.values["nonconforming_faces"] = len(missing) + len(extra) + len(relabelled)
    if missing or extra or relabelled:
        r.fail("conformity", f"{len(missing)} interface triangles are no tet face between materials, {len(extra)} tet faces "
                             f"between materials are no interface triangle, {len(relabelled)} have other materials")
    return vol


def check_labels(r, labels, spacing, tets_material, tet_volume, pairs, args):
    ids, voxels = np.unique(labels, return_counts=True)
    voxel_volume = spacing[0] * spacing[1] * spacing[2]
    r.values["labels"] = int((ids != 0).sum())
    in_tets = set(np.unique(tets_material).tolist()) if tets_material is not None else None
    in_surfaces = set(np.unique(pairs).tolist())
    per_label = np.bincount(tets_material, weights=tet_volume, minlength=int(ids.max()) + 1) if tets_material is not None else None
    worst, missing = 0.0, 0
    for l, n in zip(ids.tolist(), voxels.tolist()):
        if l == 0 or n < args.min_label_voxels:
            continue
        if l not in in_surfaces or (in_tets is not None and l not in in_tets):
            missing += 1
            r.fail("labels", f"label {l} ({n} voxels) has no {'interface triangles' if l not in in_surfaces else 'tets'}")
            continue
        if per_label is not None and n >= args.volume_min_voxels:
            err = abs(per_label[l] - n * voxel_volume) / (n * voxel_volume)
            worst = max(worst, err)
            if err > args.volume_tolerance:
                r.fail("labels", f"label {l} ({n} voxels): tet volume {per_label[l]:.4g} against {n * voxel_volume:.4g} "
                                 f"({100 * err:.1f}% off)")
    r.values["labels_missing"] = missing
    r.values["worst_label_volume_error"] = worst


def main(argv=None):
    ap = argparse.ArgumentParser(prog="cpmesh-check", description=__doc__.split("\n\n")[0])
    ap.add_argument("--volume", help="the input label volume (NRRD): the labels to find and their voxel volumes")
    ap.add_argument("--surfaces", required=True, help="interfaces.vtp as cpmesh writes it")
    ap.add_argument("--tets", help="volume.vtu as cpmesh writes it")
    ap.add_argument("--min-dihedral", type=float, default=10.0)
    ap.add_argument("--radius-ratio-mean", type=float, default=0.93)
    ap.add_argument("--radius-ratio-min", type=float, default=0.2)
    ap.add_argument("--min-label-voxels", type=int, default=8)
    ap.add_argument("--volume-min-voxels", type=int, default=1000)
    ap.add_argument("--volume-tolerance", type=float, default=0.03)
    ap.add_argument("--only", help="comma-separated checks to judge (the others are measured and reported only)")
    ap.add_argument("--limit", type=int, default=5, help="failures listed per check")
    ap.add_argument("--json", help="also write the measures and failures here")
    args = ap.parse_args(argv)
    r = Report()
    try:
        volume = read_nrrd(args.volume) if args.volume else None
        sp, triangles, pairs, feature = read_vtp(args.surfaces)
        check_surfaces(r, sp, triangles, pairs, feature, args.limit,
                       LabelsNear(*volume, args.min_label_voxels) if volume else None)
        if r.values["radius_ratio_mean"] < args.radius_ratio_mean or r.values["radius_ratio_min"] < args.radius_ratio_min:
            r.fail("quality", f"interface radius ratio mean {r.values['radius_ratio_mean']:.3f} (at least "
                              f"{args.radius_ratio_mean}), min {r.values['radius_ratio_min']:.3f} (at least {args.radius_ratio_min})")
        tet_material = tet_volume = None
        if args.tets:
            tp, tets, tet_material = read_vtu(args.tets)
            check_tets(r, tp, tets, tet_material, sp, triangles, pairs, args)
            tet_volume = tet_volumes(tp, tets)
        if args.volume:
            labels, dims, spacing, _ = volume
            check_labels(r, labels, spacing, tet_material, tet_volume, pairs, args)
    except (InputError, KeyError) as e:
        print(f"cpmesh-check: error: {e}", file=sys.stderr)
        return 2
    judged = set(args.only.split(",")) if args.only else None
    failures = [f for f in r.failures if judged is None or f["check"] in judged]
    for k, v in r.values.items():
        print(f"  {k:28s} {v:.4g}" if isinstance(v, float) else f"  {k:28s} {v}")
    shown = {}
    for f in failures:
        shown[f["check"]] = shown.get(f["check"], 0) + 1
        if shown[f["check"]] <= args.limit:
            print(f"FAIL {f['check']}: {f['message']}")
    for check, n in shown.items():
        if n > args.limit:
            print(f"FAIL {check}: ... {n - args.limit} more")
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"values": r.values, "failures": r.failures}, f, indent=1)
    print("cpmesh-check: " + ("ok" if not failures else f"{len(failures)} failures"))
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
