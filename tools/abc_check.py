"""Checks a run's Alembic cache with the reference Alembic library (its Python bindings, the
`alembic3d` package), against the run's frames.

    python3 tools/abc_check.py RUN_DIR FILE.abc

Checks: the object tree (/<scene>/cloth an Xform holding one PolyMesh, /<scene>/colliders/
<shape>_<k> an Xform holding one PolyMesh per collider of run.json); one time sampling,
uniform at run.json's frame_rate from time 0, one sample per frame; the cloth's topology
constant (faces and counts stored once) and equal to rest.obj's triangles, each written
clockwise (reversed), as Alembic lists faces; the vertex UVs equal to the OBJ's vt lines;
every frame's points equal to the OBJ frame's as float32, and .selfBnds their bounds; each
collider's mesh where run.json puts it (a plane's square in the plane, facing its normal once
the reader reverses it; a sphere's points on the sphere; a box's points on its corners) and a
moving collider's transform, per frame, moving its centre and corners as its keys say; every
parameter of scene.toml as a user property of /<scene> with its value. Exits 1 with the list
of failures.
"""
import json
import math
import os
import struct
import sys
import tomllib

from alembic3d import Abc, AbcGeom

failures = []


def check(ok, what):
    if not ok:
        failures.append(what)
    return ok


def f32(x):
    return struct.unpack("<f", struct.pack("<f", x))[0]


def read_obj(path, corners=None):
    """The v and vt lines (as float32) and the faces (0-based) of an OBJ frame; with a list
    `corners`, each face's texture-coordinate indices (0-based) appended to it as a list."""
    v, vt, faces = [], [], []
    with open(path) as f:
        for line in f:
            w = line.split()
            if not w:
                continue
            if w[0] == "v":
                v.append(tuple(f32(float(x)) for x in w[1:4]))
            elif w[0] == "vt":
                vt.append(tuple(f32(float(x)) for x in w[1:3]))
            elif w[0] == "f":
                faces.append([int(c.split("/")[0]) - 1 for c in w[1:]])
                if corners is not None:
                    corners.append([int(c.split("/")[1]) - 1 for c in w[1:]])
    return v, vt, faces


def flatten(prefix, value, out):
    """scene.toml as the exporter names its parameters."""
    if isinstance(value, dict):
        for k, v in value.items():
            flatten(f"{prefix}:{k}", v, out)
    elif isinstance(value, list) and value and not all(
        isinstance(x, (int, float)) and not isinstance(x, bool) for x in value
    ):
        for i, v in enumerate(value):
            flatten(f"{prefix}_{i}", v, out)
    elif not (isinstance(value, list) and not value):
        out[prefix] = value


def same_value(got, want):
    if isinstance(want, bool):
        return got == want
    if isinstance(want, (int, float)):
        return got is not None and float(got) == float(want)
    if isinstance(want, list):
        return got is not None and len(got) == len(want) and all(
            float(g) == float(w) for g, w in zip(got, want)
        )
    return got == want


def offset_at(keys, t):
    """A collider's offset (m) and added rotation (degrees) at t (s), as wetcloth moves it."""
    if not keys:
        return [0.0] * 3, [0.0] * 3
    if t <= keys[0]["time"]:
        return keys[0]["offset"], keys[0].get("rotation", [0.0] * 3)
    if t >= keys[-1]["time"]:
        return keys[-1]["offset"], keys[-1].get("rotation", [0.0] * 3)
    for a, b in zip(keys, keys[1:]):
        if a["time"] <= t < b["time"]:
            s = (t - a["time"]) / (b["time"] - a["time"])
            ra, rb = a.get("rotation", [0.0] * 3), b.get("rotation", [0.0] * 3)
            return (
                [x + (y - x) * s for x, y in zip(a["offset"], b["offset"])],
                [x + (y - x) * s for x, y in zip(ra, rb)],
            )


def rotate(deg, p):
    """p rotated about x, then y, then z by deg (degrees)."""
    x, y, z = p
    a, b, c = (math.radians(d) for d in deg)
    y, z = y * math.cos(a) - z * math.sin(a), y * math.sin(a) + z * math.cos(a)
    x, z = x * math.cos(b) + z * math.sin(b), -x * math.sin(b) + z * math.cos(b)
    x, y = x * math.cos(c) - y * math.sin(c), x * math.sin(c) + y * math.cos(c)
    return [x, y, z]


def apply(m, p):
    """Point p through the Alembic (row-vector) matrix m."""
    return [sum(p[i] * m[i][j] for i in range(3)) + m[3][j] for j in range(3)]


def near(a, b, tol):
    return all(abs(x - y) <= tol for x, y in zip(a, b))


def at_frame(k, rate):
    """The sample selector of frame k: its time, k / rate (the bindings read a bare integer as
    a time too)."""
    return Abc.ISampleSelector(k / rate)


def mesh_of(xform_obj, name):
    """The one PolyMesh child of an Xform object."""
    kids = [c for c in xform_obj.children if AbcGeom.IPolyMesh.matches(c.getMetaData())]
    if not check(len(kids) == 1 and xform_obj.getNumChildren() == 1, f"{name}: not an Xform holding one PolyMesh"):
        return None
    return AbcGeom.IPolyMesh(kids[0], Abc.WrapExistingFlag.kWrapExisting).getSchema()


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    run_dir, path = sys.argv[1], sys.argv[2]
    with open(os.path.join(run_dir, "run.json")) as f:
        run = json.load(f)
    frames, rate = run["frames"], run["frame_rate"]
    archive = Abc.IArchive(path)
    top = archive.getTop()
    check(archive.getNumTimeSamplings() == 2, f"{archive.getNumTimeSamplings()} time samplings, not 2 (identity and the frames')")
    info = Abc.GetArchiveInfo(archive)
    check(info["appName"].startswith("wetcloth"), f"application {info['appName']!r}")
    scenes = [c for c in top.children]
    if not check(len(scenes) == 1 and AbcGeom.IXform.matches(scenes[0].getMetaData()), "the top does not hold one Xform"):
        return finish()
    scene = scenes[0]
    cloth_x = scene.getChild("cloth")
    if not check(cloth_x is not None and AbcGeom.IXform.matches(cloth_x.getMetaData()), "no Xform /<scene>/cloth"):
        return finish()
    xs = AbcGeom.IXform(cloth_x, Abc.WrapExistingFlag.kWrapExisting).getSchema()
    check(xs.isConstantIdentity(), "cloth: its Xform is not the identity")
    mesh = mesh_of(cloth_x, "cloth")
    if mesh is None:
        return finish()

    # Time: one uniform sampling at the frame rate from 0, a sample per frame.
    ts = mesh.getTimeSampling()
    tst = ts.getTimeSamplingType()
    check(tst.isUniform() and tst.getTimePerCycle() == 1.0 / rate, f"time sampling: {tst.getTimePerCycle()} s per sample, not 1/{rate}")
    check(list(ts.getStoredTimes()) == [0.0], "time sampling does not start at 0")
    check(mesh.getNumSamples() == frames, f"{mesh.getNumSamples()} samples, not {frames}")
    check(archive.getMaxNumSamplesForTimeSamplingIndex(1) == frames, "max samples of the frames' sampling")
    check(math.isclose(ts.getSampleTime(frames - 1), (frames - 1) / rate, rel_tol=1e-12), "last sample time")

    # Topology: constant, rest.obj's triangles reversed.
    check(mesh.getTopologyVariance() == AbcGeom.MeshTopologyVariance.kHomogenousTopology, f"topology variance {mesh.getTopologyVariance()}")
    props = mesh.getFaceIndicesProperty()
    check(props.isConstant() and mesh.getFaceCountsProperty().isConstant(), "faces are not stored once")
    rcorners = []
    rv, rvt, rfaces = read_obj(os.path.join(run_dir, "rest.obj"), rcorners)
    s0 = mesh.getValue(at_frame(0, rate))
    counts = list(s0.getFaceCounts())
    indices = list(s0.getFaceIndices())
    check(counts == [len(f) for f in rfaces], "face counts differ from rest.obj")
    want = [i for f in rfaces for i in reversed(f)]
    check(indices == want, "face indices are not rest.obj's faces reversed (clockwise)")

    # UVs: the grid's per vertex, the OBJ's vt; a mesh cloth's indexed per face corner, each
    # face's corners reversed as its vertices are.
    uv = mesh.getUVsParam()
    if check(uv.valid(), "no uv") and "mesh" in run:
        check(uv.getScope() == AbcGeom.GeometryScope.kFacevaryingScope and uv.isIndexed(), "uv not indexed per face corner")
        sample = uv.getIndexedValue()
        vals = [tuple(p) for p in sample.getVals()]
        idx = list(sample.getIndices())
        check(vals == rvt, "uv values differ from the OBJ's vt")
        check(idx == [i for c in rcorners for i in reversed(c)], "uv indices are not the OBJ's f v/vt reversed")
        expanded = [tuple(p) for p in uv.getExpandedValue().getVals()]
        check(expanded == [rvt[i] for c in rcorners for i in reversed(c)], "expanded uv differ")
        md = uv.getMetaData()
        check(md.get("notUV") != "1" and md.get("podExtent") == "2" and md.get("isGeomParam") == "true", "uv not marked as UVs")
    elif uv.valid():
        check(uv.getScope() == AbcGeom.GeometryScope.kVertexScope and not uv.isIndexed(), "uv not per vertex")
        vals = [tuple(p) for p in uv.getExpandedValue().getVals()]
        check(vals == rvt, "uv differ from the OBJ's vt")
        md = uv.getMetaData()
        check(md.get("notUV") != "1" and md.get("podExtent") == "2" and md.get("isGeomParam") == "true", "uv not marked as UVs")

    # Every frame's points as float32, and their bounds.
    bad = []
    for k in range(frames):
        v, _, _ = read_obj(os.path.join(run_dir, "frames", f"frame_{k:04d}.obj"))
        s = mesh.getValue(at_frame(k, rate))
        p = [tuple(q) for q in s.getPositions()]
        if p != v:
            bad.append(k)
            continue
        b = s.getSelfBounds()
        lo = [min(q[a] for q in v) for a in range(3)]
        hi = [max(q[a] for q in v) for a in range(3)]
        if list(b.min()) != lo or list(b.max()) != hi:
            bad.append(k)
    check(not bad, f"frames whose points or bounds differ from the OBJ: {bad[:5]}")
    # Between frames k and k + 1 (at a quarter), the reader picks the nearer one, frame k.
    k = frames // 2
    s = mesh.getValue(Abc.ISampleSelector((k + 0.25) / rate))
    v, _, _ = read_obj(os.path.join(run_dir, "frames", f"frame_{k:04d}.obj"))
    check([tuple(q) for q in s.getPositions()] == v, f"time ({k} + 0.25)/{rate} s does not give frame {k}")

    # Colliders.
    colliders = scene.getChild("colliders") if run["colliders"] else None
    if "mesh" in run:
        lo, hi = run["mesh"]["bounds"]
        size = max(hi[0] - lo[0], hi[2] - lo[2])
    else:
        size = max(run["size"])
    for i, c in enumerate(run["colliders"]):
        name = f"{c['shape']}_{i}"
        obj = colliders.getChild(name) if colliders else None
        if not check(obj is not None and AbcGeom.IXform.matches(obj.getMetaData()), f"no Xform colliders/{name}"):
            continue
        cm = mesh_of(obj, name)
        if cm is None:
            continue
        x = AbcGeom.IXform(obj, Abc.WrapExistingFlag.kWrapExisting).getSchema()
        up = x.getUserProperties()
        check(Abc.IScalarProperty(up, "wetcloth:shape").getValue() == c["shape"], f"{name}: wetcloth:shape")
        check(Abc.IScalarProperty(up, "wetcloth:friction").getValue() == c["friction"], f"{name}: wetcloth:friction")
        s = cm.getValue(at_frame(0, rate))
        pts = [list(q) for q in s.getPositions()]
        fi, fc = list(s.getFaceIndices()), list(s.getFaceCounts())
        check(sum(fc) == len(fi) and max(fi) < len(pts), f"{name}: faces out of range")
        keys = c.get("keys", [])
        check(x.isConstant() == (not keys), f"{name}: Xform constant = {x.isConstant()}, keys = {len(keys)}")
        check(x.getNumSamples() == (frames if keys else 1), f"{name}: {x.getNumSamples()} transform samples, not {frames if keys else 1}")
        # The points as placed at frame k (the reader's transform applied).
        for k in sorted({0, frames // 2, frames - 1}) if keys else [0]:
            m = x.getValue(at_frame(k, rate)).getMatrix()
            world = [apply(m, q) for q in pts]
            off, rot = offset_at(keys, k / rate)
            if c["shape"] == "plane":
                n, p0 = c["normal"], [a + b for a, b in zip(c["point"], off)]
                n = rotate(rot, n)
                d = [sum((q[a] - p0[a]) * n[a] for a in range(3)) for q in world]
                check(len(world) == 4 and max(map(abs, d)) < 1e-5, f"{name}: frame {k}: not in the plane")
                # Reversed back (as readers do), the quad faces the normal.
                a, b, cc = world[fi[3]], world[fi[2]], world[fi[1]]
                e1 = [b[j] - a[j] for j in range(3)]
                e2 = [cc[j] - a[j] for j in range(3)]
                cr = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]]
                check(sum(cr[j] * n[j] for j in range(3)) > 0, f"{name}: does not face its normal")
                half = max(5.0 * size, 1.0)
                check(math.isclose(math.dist(world[0], world[1]), 2 * half, rel_tol=1e-5), f"{name}: side {math.dist(world[0], world[1])}")
            elif c["shape"] == "sphere":
                ctr = [a + b for a, b in zip(c["center"], off)]
                r = [math.dist(q, ctr) for q in world]
                check(max(abs(x - c["radius"]) for x in r) < 1e-5, f"{name}: frame {k}: points off the sphere (radius {min(r)}..{max(r)})")
            elif c["shape"] == "box":
                ctr = [a + b for a, b in zip(c["center"], off)]
                he = c["half_extents"]
                corners = [rotate(rot, [sx * he[0], sy * he[1], sz * he[2]]) for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]
                corners = [[ctr[j] + q[j] for j in range(3)] for q in corners]
                ok = all(min(math.dist(q, w) for w in corners) < 1e-5 for q in world)
                check(ok and len(world) >= 8, f"{name}: frame {k}: points off the box's corners")
                # Outward faces once reversed back: each face's normal points away from the centre.
                out = 0
                start = 0
                for n_ in fc:
                    f = [world[j] for j in reversed(fi[start:start + n_])]
                    start += n_
                    e1 = [f[1][j] - f[0][j] for j in range(3)]
                    e2 = [f[2][j] - f[0][j] for j in range(3)]
                    cr = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]]
                    g = [sum(q[j] for q in f) / len(f) - ctr[j] for j in range(3)]
                    out += sum(cr[j] * g[j] for j in range(3)) > 0
                check(out == len(fc), f"{name}: {len(fc) - out} of {len(fc)} faces point inwards")
        if keys:
            print(f"{name}: moving, {x.getNumSamples()} transform samples checked at frames 0, {frames // 2}, {frames - 1}")

    # Scene parameters as user properties of /<scene>.
    scene_path = os.path.join(run_dir, "scene.toml")
    if os.path.exists(scene_path):
        with open(scene_path, "rb") as f:
            params = {}
            flatten("wetcloth", tomllib.load(f), params)
        up = AbcGeom.IXform(scene, Abc.WrapExistingFlag.kWrapExisting).getSchema().getUserProperties()
        for key, want in params.items():
            h = up.getPropertyHeader(key)
            got = None
            if h is not None and h.isScalar():
                got = Abc.IScalarProperty(up, key).getValue()
            elif h is not None and h.isArray():
                got = list(Abc.IArrayProperty(up, key).getValue())
            check(same_value(got, want), f"user property {key} = {got}, scene.toml has {want}")
        print(f"{len(params)} scene parameters as user properties")

    print(
        f"{os.path.basename(path)}: PolyMesh with {len(counts)} faces, {mesh.getNumSamples()} samples at "
        f"{1 / tst.getTimePerCycle():g} per second, {len(run['colliders'])} collider(s)"
    )
    finish()


def finish():
    if failures:
        print("FAILED:", *failures, sep="\n  ")
        sys.exit(1)
    print("Alembic check passed")


if __name__ == "__main__":
    main()
