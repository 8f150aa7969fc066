"""Checks a run's USD caches with USD itself (the `usd-core` package), against the run's frames.

    python3 tools/usd_check.py RUN_DIR FILE.usda [FILE.usdc ...]

For every file: the stage metadata (Y up, 1 metre per unit, time codes per second and frames per
second equal to run.json's frame_rate, time codes 0 to frames - 1, a default prim); the cloth
Mesh (triangle counts and indices, vertex UVs and their values, points and normals at the
first, a middle and the last frame equal to the OBJ frames up to float32 round-off, one time
sample per frame); one prim per collider of run.json, of the right type and placed where
run.json says; every parameter of scene.toml as a custom attribute with its value; and USD's
compliance checker reporting no error. With several files, their layers must hold the same
data (the text and binary encodings of one stage). Exits 1 with the list of failures.

usd-core 26.5 or older is needed: later versions dropped UsdUtils.ComplianceChecker.
"""
import json
import math
import os
import sys
import tomllib

from pxr import Gf, Sdf, Usd, UsdGeom, UsdUtils

failures = []


def check(ok, what):
    if not ok:
        failures.append(what)
    return ok


def read_obj(path, corners=None):
    """The v, vn and vt lines and the faces (0-based vertex indices) of an OBJ frame; with a
    list `corners`, each corner's 0-based texture-coordinate index appended to it."""
    v, vn, vt, faces = [], [], [], []
    with open(path) as f:
        for line in f:
            w = line.split()
            if not w:
                continue
            if w[0] == "v":
                v.append(tuple(float(x) for x in w[1:4]))
            elif w[0] == "vn":
                vn.append(tuple(float(x) for x in w[1:4]))
            elif w[0] == "vt":
                vt.append(tuple(float(x) for x in w[1:3]))
            elif w[0] == "f":
                faces.append([int(c.split("/")[0]) - 1 for c in w[1:]])
                if corners is not None:
                    corners.extend(int(c.split("/")[1]) - 1 for c in w[1:])
    return v, vn, vt, faces


def close(a, b, tol=2e-7):
    """Equal up to float32 round-off: relative 2^-23 (and an absolute floor near zero)."""
    return all(abs(x - y) <= tol * max(1.0, abs(y)) + 1e-12 for x, y in zip(a, b))


def flatten(prefix, value, out):
    """scene.toml as the exporter names its custom attributes."""
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


def check_stage(path, run_dir, run):
    name = os.path.basename(path)
    stage = Usd.Stage.Open(path)
    if not check(stage is not None, f"{name}: USD cannot open it"):
        return
    frames = run["frames"]
    rate = run["frame_rate"]
    mesh_cloth = run.get("mesh")
    check(UsdGeom.GetStageUpAxis(stage) == UsdGeom.Tokens.y, f"{name}: upAxis is not Y")
    check(UsdGeom.GetStageMetersPerUnit(stage) == 1.0, f"{name}: metersPerUnit is not 1")
    check(stage.GetTimeCodesPerSecond() == rate, f"{name}: timeCodesPerSecond != {rate}")
    check(stage.GetFramesPerSecond() == rate, f"{name}: framesPerSecond != {rate}")
    check(stage.GetStartTimeCode() == 0, f"{name}: startTimeCode != 0")
    check(stage.GetEndTimeCode() == frames - 1, f"{name}: endTimeCode != {frames - 1}")
    root = stage.GetDefaultPrim()
    if not check(root and root.GetTypeName() == "Xform", f"{name}: no Xform default prim"):
        return

    cloth = root.GetChild("cloth")
    if not check(cloth and cloth.GetTypeName() == "Mesh", f"{name}: no Mesh prim 'cloth'"):
        return
    mesh = UsdGeom.Mesh(cloth)
    corners = []
    v0, _, vt, faces = read_obj(os.path.join(run_dir, "frames", "frame_0000.obj"), corners)
    counts = mesh.GetFaceVertexCountsAttr().Get()
    indices = mesh.GetFaceVertexIndicesAttr().Get()
    if mesh_cloth:
        # A mesh cloth: the file's polygons, in its order and winding.
        check(list(counts) == [len(f) for f in faces], f"{name}: face counts differ from the OBJ's polygons")
    else:
        nx, nz = run["resolution"]
        tris = 2 * (nx - 1) * (nz - 1)
        check(len(counts) == tris and set(counts) == {3}, f"{name}: {len(counts)} faces, not {tris} triangles")
    check(list(indices) == [i for f in faces for i in f], f"{name}: face indices differ from the OBJ")
    st = UsdGeom.PrimvarsAPI(cloth).GetPrimvar("st")
    if mesh_cloth:
        # Face-varying and indexed: each corner's texture coordinate is the OBJ's f v/vt.
        check(st and st.GetInterpolation() == UsdGeom.Tokens.faceVarying and st.IsIndexed(), f"{name}: no indexed face-varying primvar st")
        if st:
            uv = st.Get()
            check(len(uv) == len(vt) and all(close(a, b) for a, b in zip(uv, vt)), f"{name}: UVs differ from the OBJ's vt")
            check(list(st.GetIndices()) == corners, f"{name}: st indices differ from the OBJ's f v/vt")
            flat = st.ComputeFlattened()
            check(len(flat) == len(corners) and all(close(flat[i], vt[c]) for i, c in enumerate(corners)), f"{name}: flattened st differs")
    else:
        check(st and st.GetInterpolation() == UsdGeom.Tokens.vertex, f"{name}: no vertex primvar st")
        if st:
            uv = st.Get()
            check(len(uv) == nx * nz and all(close(a, b) for a, b in zip(uv, vt)), f"{name}: UVs differ")
    check(mesh.GetNormalsInterpolation() == UsdGeom.Tokens.vertex, f"{name}: normals not per vertex")
    samples = mesh.GetPointsAttr().GetTimeSamples()
    check(samples == [float(k) for k in range(frames)], f"{name}: points sampled at {samples[:5]}..., not 0..{frames - 1}")
    check(len(mesh.GetNormalsAttr().GetTimeSamples()) == frames, f"{name}: normals not sampled every frame")
    for k in sorted({0, frames // 2, frames - 1}):
        v, vn, _, _ = read_obj(os.path.join(run_dir, "frames", f"frame_{k:04d}.obj"))
        pts = mesh.GetPointsAttr().Get(k)
        nrm = mesh.GetNormalsAttr().Get(k)
        bad = [i for i, (a, b) in enumerate(zip(pts, v)) if not close(a, b)]
        check(len(pts) == len(v) and not bad, f"{name}: frame {k}: {len(bad)} points differ from the OBJ (first {bad[:3]})")
        check(len(nrm) == len(vn) and all(close(a, b) for a, b in zip(nrm, vn)), f"{name}: frame {k}: normals differ")
        lo, hi = mesh.GetExtentAttr().Get(k)
        want = [tuple(min(p[a] for p in v) for a in range(3)), tuple(max(p[a] for p in v) for a in range(3))]
        check(close(lo, want[0]) and close(hi, want[1]), f"{name}: frame {k}: extent {lo}, {hi} != {want}")
        # Between frames USD interpolates linearly.
        if k + 1 < frames:
            mid = mesh.GetPointsAttr().Get(k + 0.5)
            nxt = mesh.GetPointsAttr().Get(k + 1)
            check(close(mid[0], [(a + b) / 2 for a, b in zip(pts[0], nxt[0])], 1e-6), f"{name}: no linear interpolation at {k + 0.5}")

    colliders = root.GetChild("colliders")
    for i, c in enumerate(run["colliders"]):
        shape = c["shape"]
        prim = colliders.GetChild(f"{shape}_{i}") if colliders else None
        want_type = {"plane": "Mesh", "sphere": "Sphere", "box": "Cube"}[shape]
        if not check(prim and prim.GetTypeName() == want_type, f"{name}: no {want_type} prim {shape}_{i}"):
            continue
        check(prim.GetAttribute("wetcloth:friction").Get() == c["friction"], f"{name}: {shape}_{i}: friction")
        world = UsdGeom.Xformable(prim).ComputeLocalToWorldTransform(0)
        if shape == "plane":
            pts = UsdGeom.Mesh(prim).GetPointsAttr().Get()
            n, p0 = c["normal"], c["point"]
            off = [sum((q[a] - p0[a]) * n[a] for a in range(3)) for q in pts]
            check(len(pts) == 4 and max(map(abs, off)) < 1e-6, f"{name}: {shape}_{i} is not in the plane")
            e1 = [pts[1][a] - pts[0][a] for a in range(3)]
            e2 = [pts[2][a] - pts[0][a] for a in range(3)]
            cr = Gf.Vec3d(*e1) ^ Gf.Vec3d(*e2)
            check(cr * Gf.Vec3d(*n) > 0, f"{name}: {shape}_{i} does not face its normal")
        elif shape == "sphere":
            check(UsdGeom.Sphere(prim).GetRadiusAttr().Get() == c["radius"], f"{name}: {shape}_{i}: radius")
            check(close(world.ExtractTranslation(), c["center"], 1e-12), f"{name}: {shape}_{i}: centre")
        else:
            box = world.Transform(Gf.Vec3d(1, 1, 1))
            want = [c["center"][a] + c["half_extents"][a] for a in range(3)]
            check(UsdGeom.Cube(prim).GetSizeAttr().Get() == 2.0, f"{name}: {shape}_{i}: size")
            check(close(box, want, 1e-12), f"{name}: {shape}_{i}: corner {box} != {want}")

    scene_path = os.path.join(run_dir, "scene.toml")
    if os.path.exists(scene_path):
        with open(scene_path, "rb") as f:
            params = {}
            flatten("wetcloth", tomllib.load(f), params)
        for key, want in params.items():
            attr = root.GetAttribute(key)
            got = attr.Get() if attr else None
            if isinstance(got, (Gf.Vec2i, Gf.Vec3i, Gf.Vec4i, Gf.Vec2d, Gf.Vec3d, Gf.Vec4d)):
                got = list(got)
            elif got is not None and hasattr(got, "__len__") and not isinstance(got, str):
                got = list(got)
            check(attr and attr.IsCustom() and same_value(got, want), f"{name}: custom attribute {key} = {got}, scene.toml has {want}")
        print(f"{name}: {len(params)} scene parameters as custom attributes")

    checker = UsdUtils.ComplianceChecker()
    checker.CheckCompliance(path)
    for w in checker.GetWarnings():
        print(f"{name}: compliance warning: {w}")
    for e in checker.GetErrors() + checker.GetFailedChecks():
        check(False, f"{name}: compliance: {e}")
    print(
        f"{name}: {cloth.GetTypeName()} with {len(counts)} {'faces' if mesh_cloth else 'triangles'}, {frames} time samples at "
        f"{stage.GetTimeCodesPerSecond()} per second, {len(run['colliders'])} collider(s); "
        f"compliance checker: {len(checker.GetErrors())} errors, {len(checker.GetFailedChecks())} failed checks"
    )


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    run_dir, files = sys.argv[1], sys.argv[2:]
    with open(os.path.join(run_dir, "run.json")) as f:
        run = json.load(f)
    for path in files:
        check_stage(path, run_dir, run)
    if len(files) > 1:
        text = [Sdf.Layer.FindOrOpen(p).ExportToString() for p in files]
        for p, t in zip(files[1:], text[1:]):
            check(t == text[0], f"{os.path.basename(p)} and {os.path.basename(files[0])} hold different data")
        print(f"{len(files)} files hold the same layer data")
    if failures:
        print("FAILED:", *failures, sep="\n  ")
        sys.exit(1)
    print("USD check passed")


if __name__ == "__main__":
    main()
