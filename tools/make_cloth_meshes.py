#!/usr/bin/env python3
"""Writes the cloth meshes of the shipped scenes (Wavefront OBJ, metres, Y up, lying flat in
the xz plane with the faces wound so their normals point up, +Y) and, on request, the regular
grid meshes the benchmarks compare with the built-in grid.

    tools/make_cloth_meshes.py                 # scenes/meshes/*.obj
    tools/make_cloth_meshes.py --grid 100 out.obj   # a 100 x 100 regular grid of 30 cm

No downloads and no third-party packages: every mesh is made here, deterministically (the
same bytes on every run).

- towel.obj: a 50 x 70 cm towel, an irregular triangulation (a jittered grid split along
  the Delaunay diagonal; smallest angle above 25 degrees), texture coordinates over [0, 1]^2.
- round-tablecloth.obj: a round tablecloth of 60 cm radius, rings of quads around a fan of
  triangles (polygons kept), texture coordinates of the disc's plan view.
- grid-N.obj (--grid N): the built-in grid's particles (N x N over 30 cm, particle (i, j) at
  vertex j * N + i) with one diagonal per cell, as `Grid::triangles` winds them.
"""

import math
import sys
from pathlib import Path


def write_obj(path, vertices, faces, uvs=None, face_uvs=None, comment=""):
    lines = []
    if comment:
        lines.append(f"# {comment}")
    for x, y, z in vertices:
        x, y, z = x + 0.0, y + 0.0, z + 0.0
        lines.append(f"v {x:.9g} {y:.9g} {z:.9g}")
    if uvs:
        for u, v in uvs:
            lines.append(f"vt {u:.9g} {v:.9g}")
    for k, f in enumerate(faces):
        if face_uvs:
            lines.append("f " + " ".join(f"{a + 1}/{t + 1}" for a, t in zip(f, face_uvs[k])))
        else:
            lines.append("f " + " ".join(str(a + 1) for a in f))
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    Path(path).write_text("\n".join(lines) + "\n")


def angle(a, b, c):
    """Angle at a of triangle (a, b, c) in the xz plane, radians."""
    u = (b[0] - a[0], b[2] - a[2])
    v = (c[0] - a[0], c[2] - a[2])
    dot = u[0] * v[0] + u[1] * v[1]
    cross = u[0] * v[1] - u[1] * v[0]
    return math.atan2(abs(cross), dot)


def grid(n, size=0.3):
    h = size / (n - 1)
    verts = [
        (i * h - size / 2, 0.0, j * h - size / 2) for j in range(n) for i in range(n)
    ]
    faces = []
    for j in range(n - 1):
        for i in range(n - 1):
            a = j * n + i
            b, c, d = a + 1, a + 1 + n, a + n
            faces.append((a, c, b))
            faces.append((a, d, c))
    uvs = [(i / (n - 1), j / (n - 1)) for j in range(n) for i in range(n)]
    return verts, faces, uvs


def towel(width=0.5, height=0.7, nx=21, nz=29, jitter=0.2):
    hx, hz = width / (nx - 1), height / (nz - 1)
    verts, uvs = [], []
    state = 0x9E3779B97F4A7C15

    def rnd():
        nonlocal state
        state ^= (state << 13) & 0xFFFFFFFFFFFFFFFF
        state ^= state >> 7
        state ^= (state << 17) & 0xFFFFFFFFFFFFFFFF
        return (state >> 11) / float(1 << 53) * 2.0 - 1.0

    for j in range(nz):
        for i in range(nx):
            x, z = i * hx - width / 2, j * hz - height / 2
            if 0 < i < nx - 1 and 0 < j < nz - 1:
                x += jitter * hx * rnd()
                z += jitter * hz * rnd()
            verts.append((x, 0.0, z))
            uvs.append(((x + width / 2) / width, (z + height / 2) / height))
    faces = []
    for j in range(nz - 1):
        for i in range(nx - 1):
            a = j * nx + i
            b, c, d = a + 1, a + 1 + nx, a + nx
            p = verts
            ac = angle(p[b], p[a], p[c]) + angle(p[d], p[a], p[c])
            bd = angle(p[a], p[b], p[d]) + angle(p[c], p[b], p[d])
            if ac <= bd:
                faces += [(a, c, b), (a, d, c)]
            else:
                faces += [(a, d, b), (b, d, c)]
    return verts, faces, uvs


def round_tablecloth(radius=0.6, rings=14, inner=8):
    """Rings of quads; ring r has inner * r points (ring 0 is the centre)."""
    verts = [(0.0, 0.0, 0.0)]
    start = [0]
    for r in range(1, rings + 1):
        start.append(len(verts))
        m = inner * r
        for k in range(m):
            a = 2 * math.pi * k / m
            rr = radius * r / rings
            verts.append((rr * math.cos(a), 0.0, -rr * math.sin(a)))
    faces = []
    # Centre fan of triangles (wound up: counter-clockwise seen from +Y is x -> -z).
    for k in range(inner):
        faces.append((0, start[1] + k, start[1] + (k + 1) % inner))
    # Between ring r (m = inner r points) and ring r + 1 (inner (r + 1) points): each sector of
    # the inner ring's r segments meets r + 1 outer segments: quads and one triangle.
    for r in range(1, rings):
        m, mo = inner * r, inner * (r + 1)
        for s in range(inner):
            for q in range(r + 1):
                o0 = start[r + 1] + (s * (r + 1) + q) % mo
                o1 = start[r + 1] + (s * (r + 1) + q + 1) % mo
                if q < r:
                    i0 = start[r] + (s * r + q) % m
                    i1 = start[r] + (s * r + q + 1) % m
                    faces.append((i0, o0, o1, i1))
                else:
                    i0 = start[r] + (s * r + q) % m
                    faces.append((i0, o0, o1))
    uvs = [(0.5 + x / (2 * radius), 0.5 - z / (2 * radius)) for x, _, z in verts]
    return verts, faces, uvs


def check_up(verts, faces):
    for f in faces:
        a, b, c = verts[f[0]], verts[f[1]], verts[f[2]]
        ny = (b[2] - a[2]) * (c[0] - a[0]) - (b[0] - a[0]) * (c[2] - a[2])
        assert ny > 0, f"face {f} is wound down"


def main(argv):
    if len(argv) == 3 and argv[0] == "--grid":
        n = int(argv[1])
        v, f, t = grid(n)
        check_up(v, f)
        write_obj(argv[2], v, f, t, f, f"a regular {n} x {n} grid of 30 cm")
        return
    if argv:
        sys.exit(__doc__)
    root = Path(__file__).resolve().parent.parent / "scenes" / "meshes"
    v, f, t = towel()
    check_up(v, f)
    write_obj(root / "towel.obj", v, f, t, f, "a 50 x 70 cm towel (tools/make_cloth_meshes.py)")
    v, f, t = round_tablecloth()
    check_up(v, f)
    write_obj(
        root / "round-tablecloth.obj",
        v,
        f,
        t,
        f,
        "a round tablecloth of 60 cm radius (tools/make_cloth_meshes.py)",
    )
    v, f, t = round_tablecloth(radius=0.15, rings=24, inner=6)
    check_up(v, f)
    write_obj(
        root / "cusick-disc.obj",
        v,
        f,
        t,
        f,
        "a 30 cm disc for the Cusick drape test (tools/make_cloth_meshes.py)",
    )


if __name__ == "__main__":
    main(sys.argv[1:])
