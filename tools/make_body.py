#!/usr/bin/env python3
"""Generates scenes/body/: a stylised mannequin for garments (mannequin.obj) and its motions as
point caches (arms-raise.pc2, walk.pc2).

    python3 tools/make_body.py [--sequence] [OUT_DIR]   (default: scenes/body/ beside tools/)

Metres, Y up, the body faces +Z, its soles on y = 0. The output is deterministic.
"""

import math
import os
import struct
import sys

# ---------------------------------------------------------------------------------------------
# Small vector helpers (tuples of three floats).


def sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def add(a, b):
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


def mul(a, s):
    return (a[0] * s, a[1] * s, a[2] * s)


def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def norm(a):
    return math.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])


def unit(a):
    n = norm(a)
    return (a[0] / n, a[1] / n, a[2] / n)


def lerp(a, b, t):
    return (a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t, a[2] + (b[2] - a[2]) * t)


def rot_axis(axis, angle):
    """The 3x3 rotation (rows) by `angle` radians about the unit vector `axis`."""
    x, y, z = axis
    c, s = math.cos(angle), math.sin(angle)
    t = 1.0 - c
    return (
        (t * x * x + c, t * x * y - s * z, t * x * z + s * y),
        (t * x * y + s * z, t * y * y + c, t * y * z - s * x),
        (t * x * z - s * y, t * y * z + s * x, t * z * z + c),
    )


def mat_vec(m, v):
    return (dot(m[0], v), dot(m[1], v), dot(m[2], v))


def mat_mul(a, b):
    cols = [(b[0][j], b[1][j], b[2][j]) for j in range(3)]
    return tuple(tuple(dot(a[i], cols[j]) for j in range(3)) for i in range(3))


IDENTITY = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))


def smoothstep(t):
    t = min(1.0, max(0.0, t))
    return t * t * (3.0 - 2.0 * t)


def tri_normal(p, q, r):
    """The unnormalised normal (twice the area) of triangle p q r, counter-clockwise."""
    return cross(sub(q, p), sub(r, p))


def tri_angles(p, q, r):
    """The three angles of a triangle, radians."""
    out = []
    for a, b, c in ((p, q, r), (q, r, p), (r, p, q)):
        u, v = sub(b, a), sub(c, a)
        out.append(math.atan2(norm(cross(u, v)), dot(u, v)))
    return out


# ---------------------------------------------------------------------------------------------
# The body: bones and the primitives attached to them.

ARM_ANGLE = math.radians(45.0)  # the A-pose: each arm 45 degrees out from the body's side
ELBOW_BEND = math.radians(10.0)  # the rest pose's forearm, bent forward a little


def skeleton():
    """The bones of the rest pose: a list of (name, parent index or -1, joint position)."""
    bones = []

    def bone(name, parent, joint):
        bones.append((name, [b[0] for b in bones].index(parent) if parent else -1, joint))

    bone("pelvis", None, (0.0, 0.95, 0.0))
    bone("spine", "pelvis", (0.0, 1.02, -0.01))
    bone("chest", "spine", (0.0, 1.17, -0.01))
    bone("neck", "chest", (0.0, 1.45, -0.015))
    bone("head", "neck", (0.0, 1.56, 0.0))
    for side, s in (("L", 1.0), ("R", -1.0)):
        shoulder, elbow, wrist, _ = arm_points(s)
        bone("clavicle." + side, "chest", (0.03 * s, 1.42, -0.01))
        bone("upperarm." + side, "clavicle." + side, shoulder)
        bone("forearm." + side, "upperarm." + side, elbow)
        bone("hand." + side, "forearm." + side, wrist)
        bone("thigh." + side, "pelvis", (0.092 * s, 0.90, 0.0))
        bone("shin." + side, "thigh." + side, (0.105 * s, 0.49, 0.01))
        bone("foot." + side, "shin." + side, (0.115 * s, 0.085, -0.015))
    return bones


def arm_points(s):
    """Shoulder, elbow and wrist joints and the forearm's direction of the arm on side s (+1 the
    body's left, at +x; -1 its right)."""
    shoulder = (0.185 * s, 1.405, -0.015)
    down = (math.sin(ARM_ANGLE) * s, -math.cos(ARM_ANGLE), 0.0)
    elbow = add(shoulder, mul(down, 0.29))
    fore = unit(add(mul(down, math.cos(ELBOW_BEND)), (0.0, 0.0, math.sin(ELBOW_BEND))))
    wrist = add(elbow, mul(fore, 0.25))
    return shoulder, elbow, wrist, fore


def primitives():
    """The shapes the body's field blends, each attached to a bone, in blending order:
    ("ell", bone, op, k, centre, axes (three unit rows), radii) for an ellipsoid and
    ("cone", bone, op, k, a, b, ra, rb) for a capsule whose radius goes from ra at a to rb at b.
    op is "add" (smooth union) or "cut" (smooth subtraction); k is the blend's width, m."""
    P = []
    X, Y, Z = (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)
    axes = (X, Y, Z)

    def ell(bone, k, c, r, ax=axes, op="add"):
        P.append(("ell", bone, op, k, c, ax, r))

    def cone(bone, k, a, b, ra, rb, op="add"):
        P.append(("cone", bone, op, k, a, b, ra, rb))

    # Torso, pelvis up. The back has shoulder blades and buttocks that stand out of the lower
    # back's hollow, and a groove down the spine.
    ell("pelvis", 0.0, (0.0, 0.93, -0.005), (0.165, 0.115, 0.105))
    for s in (1.0, -1.0):
        ell("pelvis", 0.03, (0.068 * s, 0.875, -0.045), (0.085, 0.095, 0.075))
    ell("spine", 0.05, (0.0, 1.08, 0.01), (0.14, 0.15, 0.095))
    ell("chest", 0.05, (0.0, 1.27, 0.0), (0.155, 0.19, 0.10))
    ell("chest", 0.04, (0.0, 1.375, -0.015), (0.165, 0.075, 0.09))
    for s in (1.0, -1.0):
        ell("chest", 0.03, (0.075 * s, 1.305, 0.05), (0.08, 0.06, 0.055))
        ell("chest", 0.03, (0.085 * s, 1.32, -0.065), (0.065, 0.08, 0.05))
    for s, side in ((1.0, "L"), (-1.0, "R")):
        cone("clavicle." + side, 0.03, (0.03 * s, 1.45, -0.025), (0.17 * s, 1.43, -0.02), 0.045, 0.04)
    cone("chest", 0.012, (0.0, 1.00, -0.100), (0.0, 1.20, -0.113), 0.012, 0.012, op="cut")
    cone("chest", 0.012, (0.0, 1.20, -0.113), (0.0, 1.40, -0.110), 0.012, 0.012, op="cut")
    # Neck and head.
    cone("neck", 0.025, (0.0, 1.40, -0.02), (0.0, 1.58, 0.0), 0.056, 0.05)
    ell("head", 0.02, (0.0, 1.64, 0.012), (0.078, 0.11, 0.098))
    ell("head", 0.02, (0.0, 1.575, 0.035), (0.062, 0.055, 0.07))
    ell("head", 0.008, (0.0, 1.625, 0.108), (0.012, 0.025, 0.018))
    # Arms: deltoid, upper arm, forearm and a mitten of a hand, palm towards the thigh.
    for s, side in ((1.0, "L"), (-1.0, "R")):
        shoulder, elbow, wrist, fore = arm_points(s)
        down = unit(sub(elbow, shoulder))
        ell("upperarm." + side, 0.03, add(shoulder, mul(down, 0.02)), (0.052, 0.052, 0.052))
        cone("upperarm." + side, 0.02, shoulder, elbow, 0.047, 0.037)
        cone("forearm." + side, 0.015, elbow, wrist, 0.038, 0.027)
        palm = unit((-math.cos(ARM_ANGLE) * s, -math.sin(ARM_ANGLE), 0.0))
        palm = unit(sub(palm, mul(fore, dot(palm, fore))))
        width = cross(fore, palm)
        ell("hand." + side, 0.015, add(wrist, mul(fore, 0.085)), (0.095, 0.02, 0.046), (fore, palm, width))
        # Legs: thigh, shin with its calf, foot with its sole on y = 0.
        hip, knee, ankle = (0.092 * s, 0.90, 0.0), (0.105 * s, 0.49, 0.01), (0.115 * s, 0.085, -0.015)
        cone("thigh." + side, 0.035, hip, knee, 0.085, 0.052)
        cone("shin." + side, 0.02, knee, ankle, 0.05, 0.034)
        ell("shin." + side, 0.02, (0.107 * s, 0.36, -0.015), (0.048, 0.1, 0.05))
        ell("foot." + side, 0.03, (0.118 * s, 0.038, 0.055), (0.045, 0.038, 0.125))
    return P


class Field:
    """The body as a signed distance-like field: negative inside, zero on the skin, about the
    distance (m) outside. Primitives are blended in order by a quadratic smooth minimum of width
    k (a smooth maximum for cuts); a primitive whose lower bound is past the blend adds nothing,
    so it is skipped exactly."""

    def __init__(self, bones, prims, y_shift=0.0):
        self.bones = bones
        self.names = [b[0] for b in bones]
        self.y_shift = y_shift
        self.prims = []
        self.cells = {}
        for p in prims:
            bone = self.names.index(p[1])
            op = 1 if p[2] == "add" else -1
            k = p[3]
            if p[0] == "ell":
                c, ax, r = p[4], p[5], p[6]
                c = (c[0], c[1] + y_shift, c[2])
                rmax, rmin = max(r), min(r)
                self.prims.append((0, bone, op, k, c, rmax, rmin / rmax, ax, r))
            else:
                a, b, ra, rb = p[4], p[5], p[6], p[7]
                a = (a[0], a[1] + y_shift, a[2])
                b = (b[0], b[1] + y_shift, b[2])
                ab = sub(b, a)
                L2 = dot(ab, ab)
                mid = lerp(a, b, 0.5)
                self.prims.append((1, bone, op, k, mid, math.sqrt(L2) / 2 + max(ra, rb), 1.0, (a, ab, L2), (ra, rb)))

    @staticmethod
    def prim_value(pr, p):
        """One primitive's distance-like value and (approximate) unit gradient at p."""
        if pr[0] == 0:
            c, ax, r = pr[4], pr[7], pr[8]
            d = (p[0] - c[0], p[1] - c[1], p[2] - c[2])
            q0 = ax[0][0] * d[0] + ax[0][1] * d[1] + ax[0][2] * d[2]
            q1 = ax[1][0] * d[0] + ax[1][1] * d[1] + ax[1][2] * d[2]
            q2 = ax[2][0] * d[0] + ax[2][1] * d[1] + ax[2][2] * d[2]
            a0, a1, a2 = q0 / r[0], q1 / r[1], q2 / r[2]
            b0, b1, b2 = a0 / r[0], a1 / r[1], a2 / r[2]
            k0 = math.sqrt(a0 * a0 + a1 * a1 + a2 * a2)
            k1 = math.sqrt(b0 * b0 + b1 * b1 + b2 * b2)
            if k1 < 1e-12:
                return -min(r), (0.0, 1.0, 0.0)
            v = k0 * (k0 - 1.0) / k1
            g = (
                (ax[0][0] * b0 + ax[1][0] * b1 + ax[2][0] * b2) / k1,
                (ax[0][1] * b0 + ax[1][1] * b1 + ax[2][1] * b2) / k1,
                (ax[0][2] * b0 + ax[1][2] * b1 + ax[2][2] * b2) / k1,
            )
            return v, g
        a, ab, L2 = pr[7]
        ra, rb = pr[8]
        d = (p[0] - a[0], p[1] - a[1], p[2] - a[2])
        t = (d[0] * ab[0] + d[1] * ab[1] + d[2] * ab[2]) / L2
        t = 0.0 if t < 0.0 else (1.0 if t > 1.0 else t)
        e = (d[0] - ab[0] * t, d[1] - ab[1] * t, d[2] - ab[2] * t)
        n = math.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2])
        if n < 1e-12:
            return -(ra + (rb - ra) * t), (0.0, 1.0, 0.0)
        return n - (ra + (rb - ra) * t), (e[0] / n, e[1] / n, e[2] / n)

    CELL = 0.05

    def candidates(self, p):
        """The primitives that can shape the field near the surface within p's cell (5 cm): a
        primitive is left out where its lower bound over the cell is past every other's upper
        bound by more than two blend widths (it could only change values far from the skin)."""
        key = (math.floor(p[0] / self.CELL), math.floor(p[1] / self.CELL), math.floor(p[2] / self.CELL))
        got = self.cells.get(key)
        if got is None:
            m = tuple((key[i] + 0.5) * self.CELL for i in range(3))
            hd = self.CELL * math.sqrt(3.0) / 2
            lbs, ub = [], 1e9
            for pr in self.prims:
                v = self.prim_value(pr, m)[0]
                lbs.append((norm(sub(m, pr[4])) - pr[5] - hd) * pr[6] if norm(sub(m, pr[4])) > pr[5] + hd else -1e9)
                if pr[2] > 0:
                    ub = min(ub, v + 2.0 * hd)
            kmax = max(pr[3] for pr in self.prims)
            got = tuple(pr for pr, lb in zip(self.prims, lbs) if lb < ub + 2.0 * kmax + 0.02)
            self.cells[key] = got
        return got

    def value(self, p):
        return self.value_grad(p)[0]

    def value_grad(self, p):
        """The field and its (approximate) gradient at p."""
        acc = 1e9
        g = (0.0, 1.0, 0.0)
        x, y, z = p
        first = True
        pv = self.prim_value
        for pr in self.candidates(p):
            op, k, c = pr[2], pr[3], pr[4]
            if not first:
                dx, dy, dz = x - c[0], y - c[1], z - c[2]
                thr = ((acc + k) if op > 0 else (k - acc)) / pr[6] + pr[5]
                if thr <= 0.0 or dx * dx + dy * dy + dz * dz >= thr * thr:
                    continue
            v, gv = pv(pr, p)
            if first:
                acc, g = v, gv
                first = False
            elif op > 0:
                h = k - abs(acc - v)
                if h <= 0.0:
                    if v < acc:
                        acc, g = v, gv
                    continue
                h /= k
                # d/d(smaller) = 1 - h/2, d/d(larger) = h/2.
                if acc < v:
                    wa, wv = 1.0 - h / 2, h / 2
                else:
                    wa, wv = h / 2, 1.0 - h / 2
                acc = min(acc, v) - h * h * k / 4.0
                g = (wa * g[0] + wv * gv[0], wa * g[1] + wv * gv[1], wa * g[2] + wv * gv[2])
            else:
                nv = -v
                h = k - abs(acc - nv)
                if h <= 0.0:
                    if nv > acc:
                        acc, g = nv, (-gv[0], -gv[1], -gv[2])
                    continue
                h /= k
                if acc > nv:
                    wa, wv = 1.0 - h / 2, h / 2
                else:
                    wa, wv = h / 2, 1.0 - h / 2
                acc = max(acc, nv) + h * h * k / 4.0
                g = (wa * g[0] - wv * gv[0], wa * g[1] - wv * gv[1], wa * g[2] - wv * gv[2])
        return acc, g

    def bone_values(self, p):
        """Each bone's own distance-like value at p (its primitives' minimum, cuts ignored)."""
        out = [1e9] * len(self.bones)
        for pr in self.prims:
            if pr[2] < 0:
                continue
            v = self.prim_value(pr, p)[0]
            if v < out[pr[1]]:
                out[pr[1]] = v
        return out

    def project(self, p, iso=0.0, steps=4):
        """Moves p onto the level set field = iso along the gradient (Newton steps)."""
        for _ in range(steps):
            v, g = self.value_grad(p)
            gg = g[0] * g[0] + g[1] * g[1] + g[2] * g[2]
            s = (v - iso) / gg
            p = (p[0] - g[0] * s, p[1] - g[1] * s, p[2] - g[2] * s)
            if abs(v - iso) < 1e-7:
                break
        return p


# ---------------------------------------------------------------------------------------------
# Polygonisation: marching tetrahedra on a regular grid, each cube split into six tetrahedra
# around its main diagonal (the same split in every cube, so neighbouring cubes agree on their
# shared faces' diagonals and the surface is closed and 2-manifold).

CUBE = [(i & 1, (i >> 1) & 1, (i >> 2) & 1) for i in range(8)]
TETS = [(0, a, a | b, 7) for a, b in ((1, 2), (1, 4), (2, 1), (2, 4), (4, 1), (4, 2))]


def tet_table():
    """For each of the six tetrahedra and each pattern of inside corners (bit i set: corner i of
    the tetrahedron is inside), the triangles as triples of cube edges (pairs of cube corners),
    wound counter-clockwise seen from the outside. The winding is taken from the triangle
    through the edges' midpoints: the true vertices lie on the same edges at other fractions,
    which keeps the triangle's orientation relative to the tetrahedron."""
    table = []
    for tet in TETS:
        rows = []
        for mask in range(16):
            inside = [tet[i] for i in range(4) if mask >> i & 1]
            outside = [tet[i] for i in range(4) if not mask >> i & 1]
            if not inside or not outside:
                rows.append([])
                continue

            def mid(e):
                a, b = CUBE[e[0]], CUBE[e[1]]
                return ((a[0] + b[0]) / 2, (a[1] + b[1]) / 2, (a[2] + b[2]) / 2)

            cin = mul(tuple(map(sum, zip(*[CUBE[c] for c in inside]))), 1.0 / len(inside))
            cout = mul(tuple(map(sum, zip(*[CUBE[c] for c in outside]))), 1.0 / len(outside))
            out_dir = sub(cout, cin)
            if len(inside) == 1 or len(outside) == 1:
                apex, others = (inside[0], outside) if len(inside) == 1 else (outside[0], inside)
                tris = [[(apex, o) for o in others]]
            else:
                i0, i1 = inside
                o0, o1 = outside
                quad = [(i0, o0), (i0, o1), (i1, o1), (i1, o0)]
                tris = [quad]  # split later, at the shorter diagonal
            fixed = []
            for poly in tris:
                pts = [mid(e) for e in poly]
                n = tri_normal(pts[0], pts[1], pts[2])
                if dot(n, out_dir) < 0:
                    poly = poly[::-1]
                fixed.append([tuple(sorted(e)) for e in poly])
            rows.append(fixed)
        table.append(rows)
    return table


def march(func, lo, hi, h, coarse=4, lipschitz=1.3):
    """Polygonises {func < 0} in the box lo..hi at grid spacing h: returns (points, triangles).
    func is evaluated only near the surface: on a coarse grid first (every `coarse` points),
    then on the fine points of the coarse cells the surface may cross."""
    n = [int(math.ceil((hi[i] - lo[i]) / h)) + 1 for i in range(3)]
    nc = [(n[i] + coarse - 1) // coarse + 1 for i in range(3)]
    n = [nc[i] * coarse - coarse + 1 for i in range(3)]
    vals = {}

    def value(i, j, k):
        key = (i, j, k)
        v = vals.get(key)
        if v is None:
            v = func((lo[0] + i * h, lo[1] + j * h, lo[2] + k * h))
            if v == 0.0:
                v = 1e-12  # no grid value exactly on the surface: the surface stays manifold
            vals[key] = v
        return v

    H = coarse * h
    reach = lipschitz * H * math.sqrt(3.0) / 2
    cvals = {}
    for i in range(nc[0]):
        for j in range(nc[1]):
            for k in range(nc[2]):
                cvals[(i, j, k)] = value(i * coarse, j * coarse, k * coarse)
    table = tet_table()
    points, tris, index = [], [], {}

    def vertex(a, b, va, vb):
        key = (a, b) if a < b else (b, a)
        v = index.get(key)
        if v is None:
            t = va / (va - vb)
            t = min(0.98, max(0.02, t))
            pa = (lo[0] + a[0] * h, lo[1] + a[1] * h, lo[2] + a[2] * h)
            pb = (lo[0] + b[0] * h, lo[1] + b[1] * h, lo[2] + b[2] * h)
            points.append(lerp(pa, pb, t))
            v = index[key] = len(points) - 1
        return v

    for ci in range(nc[0] - 1):
        for cj in range(nc[1] - 1):
            for ck in range(nc[2] - 1):
                cs = [cvals[(ci + d[0], cj + d[1], ck + d[2])] for d in CUBE]
                if min(abs(c) for c in cs) > reach and (min(cs) > 0 or max(cs) < 0):
                    continue
                for i in range(ci * coarse, ci * coarse + coarse):
                    for j in range(cj * coarse, cj * coarse + coarse):
                        for k in range(ck * coarse, ck * coarse + coarse):
                            corner = [(i + d[0], j + d[1], k + d[2]) for d in CUBE]
                            v = [value(*c) for c in corner]
                            if min(v) > 0 or max(v) < 0:
                                continue
                            for t, tet in enumerate(TETS):
                                mask = sum(1 << m for m in range(4) if v[tet[m]] < 0)
                                for poly in table[t][mask]:
                                    ids = [vertex(corner[e[0]], corner[e[1]], v[e[0]], v[e[1]]) for e in poly]
                                    if len(ids) == 3:
                                        tris.append(ids)
                                    else:
                                        p = [points[x] for x in ids]
                                        if norm(sub(p[0], p[2])) <= norm(sub(p[1], p[3])):
                                            tris.append([ids[0], ids[1], ids[2]])
                                            tris.append([ids[0], ids[2], ids[3]])
                                        else:
                                            tris.append([ids[0], ids[1], ids[3]])
                                            tris.append([ids[1], ids[2], ids[3]])
    return points, tris


# ---------------------------------------------------------------------------------------------
# Remeshing on a level set: edge splits, collapses and flips towards a target edge length,
# tangential smoothing, and projection back onto the surface. A vertex may be tied to curves
# on the surface (a garment's cut edges, a seam): `tags[v]` is the tuple of curve ids it lies
# on (none: free on the surface; one: on that curve; two: a corner, fixed). Curves are
# functions p -> (value, gradient) whose zero set, on the surface, is the curve.


class Remesher:
    def __init__(self, field, iso, points, tris, curves=None, tags=None, seams=()):
        self.field, self.iso = field, iso
        self.V = list(points)
        self.F = [list(t) for t in tris]
        self.curves = curves or {}
        self.tags = list(tags) if tags else [()] * len(self.V)
        self.seam_ids = set(seams)
        self.feat = set()  # seam edges (interior edges that are features)
        self.alive = [True] * len(self.V)
        self.vf = [set() for _ in self.V]
        for f, t in enumerate(self.F):
            for v in t:
                self.vf[v].add(f)

    # -- queries ------------------------------------------------------------------------------
    def faces_of_edge(self, a, b):
        return self.vf[a] & self.vf[b]

    def neighbours(self, v):
        out = set()
        for f in self.vf[v]:
            out.update(self.F[f])
        out.discard(v)
        return out

    def is_boundary_edge(self, a, b):
        return len(self.vf[a] & self.vf[b]) == 1

    def is_feature(self, a, b):
        return len(self.vf[a] & self.vf[b]) == 1 or (min(a, b), max(a, b)) in self.feat

    def edges(self):
        out = set()
        for t in self.F:
            if t is None:
                continue
            a, b, c = t
            for u, w in ((a, b), (b, c), (c, a)):
                out.add((u, w) if u < w else (w, u))
        return sorted(out)

    def normal(self, f, moved=None):
        p = [moved.get(v, self.V[v]) if moved else self.V[v] for v in self.F[f]]
        return tri_normal(*p)

    # -- projection ---------------------------------------------------------------------------
    def constrain(self, p, tag, steps=5):
        """Moves p onto the surface and the curves of `tag` (a least-norm Newton step on all
        the constraints at once)."""
        if not tag:
            return self.field.project(p, self.iso, steps)
        for _ in range(steps):
            v, g = self.field.value_grad(p)
            rows, res = [g], [v - self.iso]
            for c in tag:
                cv, cg = self.curves[c](p)
                rows.append(cg)
                res.append(cv)
            n = len(rows)
            A = [[dot(rows[i], rows[j]) for j in range(n)] for i in range(n)]
            lam = solve(A, res)
            d = (0.0, 0.0, 0.0)
            for i in range(n):
                d = add(d, mul(rows[i], lam[i]))
            p = sub(p, d)
            if max(abs(r) for r in res) < 1e-7:
                break
        return p

    def surface_normal(self, p):
        return unit(self.field.value_grad(p)[1])

    # -- operations ---------------------------------------------------------------------------
    def add_vertex(self, p, tag):
        self.V.append(p)
        self.tags.append(tag)
        self.vf.append(set())
        self.alive.append(True)
        return len(self.V) - 1

    def add_face(self, t):
        self.F.append(list(t))
        f = len(self.F) - 1
        for v in t:
            self.vf[v].add(f)
        return f

    def remove_face(self, f):
        for v in self.F[f]:
            self.vf[v].discard(f)
        self.F[f] = None

    def split_tag(self, a, b):
        if not self.is_feature(a, b):
            return ()
        common = tuple(sorted(set(self.tags[a]) & set(self.tags[b])))
        if len(common) > 1:
            seam = (min(a, b), max(a, b)) in self.feat
            common = tuple(c for c in common if (c in self.seam_ids) == seam)
        return common[:1]

    def split(self, a, b, p=None, tag=None):
        """Splits edge a-b at p (default: its midpoint put back on the surface)."""
        if tag is None:
            tag = self.split_tag(a, b)
        if p is None:
            p = self.constrain(lerp(self.V[a], self.V[b], 0.5), tag)
        seam = (min(a, b), max(a, b)) in self.feat
        m = self.add_vertex(p, tag)
        for f in sorted(self.faces_of_edge(a, b)):
            t = self.F[f]
            i = t.index(a)
            if t[(i + 1) % 3] == b:
                p0, p1, r = a, b, t[(i + 2) % 3]
            else:
                p0, p1, r = b, a, t[(i + 1) % 3]
            self.remove_face(f)
            self.add_face((p0, m, r))
            self.add_face((m, p1, r))
        if seam:
            self.feat.discard((min(a, b), max(a, b)))
            self.feat.add((min(a, m), max(a, m)))
            self.feat.add((min(b, m), max(b, m)))
        return m

    def collapse(self, a, b, hi):
        """Collapses edge a-b if that keeps the mesh manifold, its features and its faces'
        orientation, and makes no edge longer than hi. Returns whether it did."""
        ta, tb = self.tags[a], self.tags[b]
        ra, rb = len(ta), len(tb)
        feature = self.is_feature(a, b)
        if ra < rb or (ra == rb and a > b):
            a, b, ta, tb, ra, rb = b, a, tb, ta, rb, ra
        # Keep a, remove b.
        if ra == rb:
            if ra == 2 or (ra == 1 and (ta != tb or not feature)):
                return False
            p = self.constrain(lerp(self.V[a], self.V[b], 0.5), ta)
        else:
            if not set(tb) <= set(ta) or (rb >= 1 and not feature):
                return False
            p = self.V[a]
        shared = self.faces_of_edge(a, b)
        na, nb = self.neighbours(a), self.neighbours(b)
        opposite = set()
        for f in shared:
            opposite.update(self.F[f])
        opposite -= {a, b}
        if (na & nb) != opposite:
            return False
        if not shared or len(shared) > 2:
            return False
        # A boundary vertex must not be joined to another boundary through the interior.
        if len(shared) == 2 and self.is_boundary_vertex(a) and self.is_boundary_vertex(b):
            return False
        moved = {a: p, b: p}
        for f in (self.vf[a] | self.vf[b]) - shared:
            n0 = self.normal(f)
            n1 = self.normal(f, moved)
            if dot(n0, n1) <= 0.0 or norm(n1) < 1e-3 * norm(n0):
                return False
            for v in self.F[f]:
                if v not in (a, b) and norm(sub(self.V[v], p)) > hi:
                    return False
        for f in sorted(shared):
            self.remove_face(f)
        for f in sorted(self.vf[b]):
            t = self.F[f]
            t[t.index(b)] = a
            self.vf[a].add(f)
        self.vf[b] = set()
        self.alive[b] = False
        self.V[a] = p
        for e in [e for e in self.feat if b in e]:
            self.feat.discard(e)
            o = e[0] if e[1] == b else e[1]
            if o != a:
                self.feat.add((min(a, o), max(a, o)))
        return True

    def is_boundary_vertex(self, v):
        for u in self.neighbours(v):
            if len(self.vf[u] & self.vf[v]) == 1:
                return True
        return False

    def flip(self, a, b):
        """Flips interior edge a-b if that raises the smaller angle of its two triangles and
        keeps the surface's shape. Returns whether it did."""
        if self.is_feature(a, b):
            return False
        f1, f2 = sorted(self.faces_of_edge(a, b))
        t1 = self.F[f1]
        i = t1.index(a)
        if t1[(i + 1) % 3] != b:
            f1, f2 = f2, f1
            t1 = self.F[f1]
            i = t1.index(a)
        c = t1[(i + 2) % 3]
        t2 = self.F[f2]
        d = [v for v in t2 if v != a and v != b][0]
        if c == d or (self.vf[c] & self.vf[d]):
            return False
        if len(self.vf[a]) <= 3 or len(self.vf[b]) <= 3:
            return False
        V = self.V
        old = min(min(tri_angles(V[a], V[b], V[c])), min(tri_angles(V[b], V[a], V[d])))
        new = min(min(tri_angles(V[a], V[d], V[c])), min(tri_angles(V[d], V[b], V[c])))
        if new <= old + 1e-9:
            return False
        n1, n2 = unit(tri_normal(V[a], V[b], V[c])), unit(tri_normal(V[b], V[a], V[d]))
        m1, m2 = tri_normal(V[a], V[d], V[c]), tri_normal(V[d], V[b], V[c])
        if norm(m1) < 1e-14 or norm(m2) < 1e-14:
            return False
        m1, m2 = unit(m1), unit(m2)
        avg = add(n1, n2)
        if dot(m1, avg) <= 0 or dot(m2, avg) <= 0 or dot(m1, m2) < dot(n1, n2) - 0.2:
            return False
        self.remove_face(f1)
        self.remove_face(f2)
        self.add_face((a, d, c))
        self.add_face((d, b, c))
        return True

    # -- passes -------------------------------------------------------------------------------
    def split_long(self, hi):
        count = 0
        todo = [(-norm(sub(self.V[a], self.V[b])), a, b) for a, b in self.edges()]
        todo.sort()
        for negl, a, b in todo:
            if -negl <= hi:
                break
            if self.faces_of_edge(a, b):
                self.split(a, b)
                count += 1
        return count

    def collapse_short(self, lo, hi):
        count = 0
        todo = [(norm(sub(self.V[a], self.V[b])), a, b) for a, b in self.edges()]
        todo.sort()
        for l, a, b in todo:
            if l >= lo:
                break
            if not (self.alive[a] and self.alive[b]) or not self.faces_of_edge(a, b):
                continue
            if norm(sub(self.V[a], self.V[b])) >= lo:
                continue
            if self.collapse(a, b, hi):
                count += 1
        return count

    def flip_pass(self):
        count = 0
        for a, b in self.edges():
            if len(self.faces_of_edge(a, b)) == 2 and self.flip(a, b):
                count += 1
        return count

    def relax(self, lam=0.5):
        """One Jacobi pass of tangential smoothing: each free vertex moves towards the area-
        weighted centroid of its ring within the tangent plane, each curve vertex towards the
        middle of its two neighbours on the curve; all go back onto the surface."""
        new = {}
        for v in range(len(self.V)):
            if not self.alive[v] or not self.vf[v] or len(self.tags[v]) >= 2:
                continue
            p = self.V[v]
            if not self.tags[v]:
                if self.is_boundary_vertex(v):
                    continue
                cx = cy = cz = wsum = 0.0
                for f in self.vf[v]:
                    q = [self.V[u] for u in self.F[f]]
                    w = norm(tri_normal(*q))
                    cx += w * (q[0][0] + q[1][0] + q[2][0]) / 3
                    cy += w * (q[0][1] + q[1][1] + q[2][1]) / 3
                    cz += w * (q[0][2] + q[1][2] + q[2][2]) / 3
                    wsum += w
                if wsum <= 0:
                    continue
                d = (cx / wsum - p[0], cy / wsum - p[1], cz / wsum - p[2])
                n = self.surface_normal(p)
                d = sub(d, mul(n, dot(d, n)))
            else:
                c = self.tags[v][0]
                ring = [u for u in self.neighbours(v) if self.is_feature(u, v) and c in self.tags[u]]
                if len(ring) != 2:
                    continue
                d = sub(lerp(self.V[ring[0]], self.V[ring[1]], 0.5), p)
            new[v] = add(p, mul(d, lam))
        for v in sorted(new):
            self.V[v] = self.constrain(new[v], self.tags[v])

    def remesh(self, length, rounds=5, relax_steps=2):
        lo, hi = 0.8 * length, 4.0 / 3.0 * length
        for _ in range(rounds):
            self.split_long(hi)
            self.collapse_short(lo, hi)
            self.flip_pass()
            for _ in range(relax_steps):
                self.relax()
        self.flip_pass()

    def compact(self):
        """The live mesh with vertices renumbered in order of first use by the faces, and the
        tags and seam edges carried over."""
        order, index = [], {}
        faces = []
        for t in self.F:
            if t is None:
                continue
            for v in t:
                if v not in index:
                    index[v] = len(order)
                    order.append(v)
            faces.append([index[v] for v in t])
        points = [self.V[v] for v in order]
        tags = [self.tags[v] for v in order]
        feat = sorted((min(index[a], index[b]), max(index[a], index[b])) for a, b in self.feat)
        return points, faces, tags, feat


def solve(A, b):
    """Solves the small dense system A x = b (Gaussian elimination, partial pivoting)."""
    n = len(b)
    M = [list(A[i]) + [b[i]] for i in range(n)]
    for c in range(n):
        piv = max(range(c, n), key=lambda r: abs(M[r][c]))
        M[c], M[piv] = M[piv], M[c]
        if abs(M[c][c]) < 1e-300:
            raise ValueError("singular system")
        for r in range(c + 1, n):
            f = M[r][c] / M[c][c]
            for k in range(c, n + 1):
                M[r][k] -= f * M[c][k]
    x = [0.0] * n
    for r in range(n - 1, -1, -1):
        x[r] = (M[r][n] - sum(M[r][k] * x[k] for k in range(r + 1, n))) / M[r][r]
    return x


# ---------------------------------------------------------------------------------------------
# Mesh checks.


def fmt(x):
    """A coordinate as written to the files (6 decimals, no negative zero), back as a float."""
    s = "%.6f" % x
    if s == "-0.000000":
        s = "0.000000"
    return float(s)


def round_points(points):
    return [(fmt(p[0]), fmt(p[1]), fmt(p[2])) for p in points]


def edge_faces(tris):
    """Directed edge (a, b) -> the face running it."""
    out = {}
    for f, (a, b, c) in enumerate(tris):
        for e in ((a, b), (b, c), (c, a)):
            if e in out:
                raise AssertionError(f"directed edge {e} is run by faces {out[e]} and {f}: non-manifold or inconsistently wound")
            out[e] = f
    return out


def components(n, tris):
    """Connected components of the faces (as lists of face indices)."""
    parent = list(range(n))

    def find(a):
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a

    for a, b, c in tris:
        ra, rb, rc = find(a), find(b), find(c)
        parent[rb] = ra
        parent[find(rc)] = ra
    groups = {}
    for f, t in enumerate(tris):
        groups.setdefault(find(t[0]), []).append(f)
    return sorted(groups.values(), key=lambda g: (-len(g), g[0]))


def check_mesh(points, tris, closed):
    """Asserts what the simulator's reader and its contact need: every face a proper triangle
    of area > 1e-10 m^2, every vertex used, no two vertices at the same written coordinates,
    each edge shared by two faces running it in opposite directions (consistent winding; one
    face along the boundary of an open mesh), and for a closed mesh one piece of genus 0
    (V - E + F = 2) enclosing a positive volume (wound counter-clockwise seen from outside)."""
    assert len(set(points)) == len(points), "two vertices at the same coordinates"
    used = set()
    for a, b, c in tris:
        assert len({a, b, c}) == 3, "a face repeats a vertex"
        area = norm(tri_normal(points[a], points[b], points[c])) / 2
        assert area > 1e-10, f"degenerate face {a} {b} {c}: area {area:g} m^2"
        used.update((a, b, c))
    assert len(used) == len(points), "a vertex no face uses"
    directed = edge_faces(tris)
    boundary = [e for e in directed if (e[1], e[0]) not in directed]
    if closed:
        assert not boundary, f"{len(boundary)} edges with one face: the mesh is not closed"
        edges = len(directed) // 2
        chi = len(points) - edges + len(tris)
        assert chi == 2, f"Euler characteristic {chi}, not a sphere"
        assert len(components(len(points), tris)) == 1, "the body is in several pieces"
        vol = sum(dot(points[a], cross(points[b], points[c])) for a, b, c in tris) / 6
        assert vol > 0, f"signed volume {vol}: wound inwards"
        return vol
    return len(boundary)


def angle_stats(points, tris):
    """(smallest angle, share of faces whose smallest angle is below 25 degrees), degrees."""
    mins = [min(tri_angles(points[a], points[b], points[c])) for a, b, c in tris]
    small = sum(1 for m in mins if m < math.radians(25.0))
    return math.degrees(min(mins)), small / len(mins)


def edge_stats(points, tris):
    lengths = []
    for a, b, c in tris:
        for u, w in ((a, b), (b, c), (c, a)):
            if u < w:
                lengths.append(norm(sub(points[u], points[w])))
    lengths.sort()
    mean = sum(lengths) / len(lengths)
    return lengths[0], mean, lengths[-1]


# ---------------------------------------------------------------------------------------------
# The mannequin's mesh.

BODY_BOX = ((-0.74, -0.03, -0.17), (0.74, 1.79, 0.23))


def build_body(length=0.017, grid=0.02):
    """The body's surface: marching tetrahedra at `grid` spacing, remeshed towards edges of
    `length`; then moved up so that the soles touch y = 0. Returns (field, points, tris),
    the field moved with the mesh."""
    bones, prims = skeleton(), primitives()
    field = Field(bones, prims)
    points, tris = march(field.value, BODY_BOX[0], BODY_BOX[1], grid)
    rm = Remesher(field, 0.0, points, tris)
    rm.remesh(length, rounds=4)
    points, tris, _, _ = rm.compact()
    shift = -min(p[1] for p in points)
    field = Field(bones, prims, y_shift=shift)
    points = round_points([(p[0], p[1] + shift, p[2]) for p in points])
    # The lowest point is now on y = 0 (up to rounding); the skeleton moves with it.
    return field, shift, points, tris


# ---------------------------------------------------------------------------------------------
# Skinning: linear blend skinning with weights from the bones' own fields.

ARM_BONES = ("upperarm", "forearm", "hand")


def skin_weights(field, points, tris, sigma=0.01, passes=8, keep=4):
    """Each vertex's bone weights: exp(-(d_b - d_min) / sigma) over the nearest bone, its
    parent and its children (d_b the bone's own field at the vertex), smoothed over the mesh
    by `passes` rounds of averaging with the neighbours, then the `keep` largest, normalised.
    Returns a list of [(bone, weight), ...] per vertex."""
    bones = field.bones
    children = [[c for c, b in enumerate(bones) if b[1] == i] for i in range(len(bones))]
    W = []
    for p in points:
        d = field.bone_values(p)
        near = min(range(len(d)), key=lambda b: d[b])
        allowed = [near] + children[near] + ([bones[near][1]] if bones[near][1] >= 0 else [])
        w = [0.0] * len(bones)
        for b in allowed:
            x = (d[b] - d[near]) / sigma
            if x < 8.0:
                w[b] = math.exp(-x)
        W.append(w)
    ring = [set() for _ in points]
    for a, b, c in tris:
        ring[a].update((b, c))
        ring[b].update((a, c))
        ring[c].update((a, b))
    ring = [sorted(r) for r in ring]
    nb = len(bones)
    for _ in range(passes):
        new = []
        for v, w in enumerate(W):
            s = [0.0] * nb
            for u in ring[v]:
                wu = W[u]
                for b in range(nb):
                    s[b] += wu[b]
            k = 1.0 / len(ring[v])
            new.append([0.5 * w[b] + 0.5 * k * s[b] for b in range(nb)])
        W = new
    out = []
    for w in W:
        top = sorted(((x, b) for b, x in enumerate(w) if x > 0.0), reverse=True)[:keep]
        total = sum(x for x, _ in top)
        out.append(sorted((b, x / total) for x, b in top if x / total > 1e-4))
    return out


def pose_transforms(bones, local, root_offset=(0.0, 0.0, 0.0)):
    """Global (rotation, moved joint) of every bone, from each bone's rotation about its own
    joint (`local`: name -> 3x3, in the rest pose's axes) and the root's offset, m."""
    out = []
    for name, parent, joint in bones:
        R = local.get(name, IDENTITY)
        if parent < 0:
            out.append((R, add(joint, root_offset)))
        else:
            Rp, jp = out[parent]
            moved = add(mat_vec(Rp, sub(joint, bones[parent][2])), jp)
            out.append((mat_mul(Rp, R), moved))
    return out


def skin(points, weights, bones, transforms):
    """The posed points: p + sum_b w_b (R_b (p - j_b) + j'_b - p)."""
    out = []
    for p, ws in zip(points, weights):
        dx = dy = dz = 0.0
        for b, w in ws:
            R, jm = transforms[b]
            j = bones[b][2]
            q = (p[0] - j[0], p[1] - j[1], p[2] - j[2])
            dx += w * (R[0][0] * q[0] + R[0][1] * q[1] + R[0][2] * q[2] + jm[0] - p[0])
            dy += w * (R[1][0] * q[0] + R[1][1] * q[1] + R[1][2] * q[2] + jm[1] - p[1])
            dz += w * (R[2][0] * q[0] + R[2][1] * q[1] + R[2][2] * q[2] + jm[2] - p[2])
        out.append((p[0] + dx, p[1] + dy, p[2] + dz))
    return out


X_AXIS, Y_AXIS, Z_AXIS = (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)


def flexion_axis(s):
    """The elbow's axis on side s: turning the forearm about it by a positive angle bends
    the elbow (the hand goes forward)."""
    return (-math.cos(ARM_ANGLE) * s, -math.sin(ARM_ANGLE), 0.0)


def ease(t):
    """0 to 1 over t in [0, 1], slow at both ends (half a cosine)."""
    t = min(1.0, max(0.0, t))
    return 0.5 - 0.5 * math.cos(math.pi * t)


def arms_raise_pose(t):
    """Both arms rise from the A-pose to straight over the head over 1.5 s (eased in and
    out), then hold: the collarbones lift 25 degrees, the upper arms turn 102 more about the
    shoulders (127 in all: from 45 degrees below the horizontal to 8 degrees off the vertical),
    the elbows straighten."""
    s = ease(t / 1.5)
    local = {}
    for side, sg in (("L", 1.0), ("R", -1.0)):
        local["clavicle." + side] = rot_axis(Z_AXIS, math.radians(25.0) * s * sg)
        local["upperarm." + side] = rot_axis(Z_AXIS, math.radians(102.0) * s * sg)
        local["forearm." + side] = rot_axis(flexion_axis(sg), -ELBOW_BEND * s)
    return local, (0.0, 0.0, 0.0)


WALK_PERIOD = 1.0  # s per cycle (two steps)
WALK_RAMP = 0.3  # s from the rest pose into the full swing


def walk_pose(t):
    """A walk in place: the hips swing the legs 25 degrees forward and back, the swinging leg's
    knee bends up to 55 degrees, the pelvis bobs 1.5 cm (lowest with the legs apart) and
    twists 5 degrees, the chest twists against it, the arms (lowered 10 degrees from the
    A-pose) swing 20 degrees against the legs with a little elbow bend. The swing grows from
    the rest pose over the first 0.3 s."""
    r = ease(t / WALK_RAMP)
    ph = 2.0 * math.pi * t / WALK_PERIOD
    local = {}
    sph = math.sin(ph)
    for side, sg, off in (("L", 1.0, 0.0), ("R", -1.0, math.pi)):
        a = ph + off
        local["thigh." + side] = rot_axis(X_AXIS, -math.radians(25.0) * math.sin(a) * r)
        knee = math.radians(55.0) * max(0.0, math.cos(a)) ** 2 + math.radians(4.0)
        local["shin." + side] = rot_axis(X_AXIS, knee * r)
        local["foot." + side] = rot_axis(X_AXIS, -math.radians(10.0) * max(0.0, math.cos(a)) * r)
        lower = rot_axis(Z_AXIS, -math.radians(10.0) * sg * r)
        swing = rot_axis(X_AXIS, math.radians(20.0) * math.sin(a) * r)
        local["upperarm." + side] = mat_mul(swing, lower)
        bend = math.radians(8.0) + math.radians(10.0) * max(0.0, -math.sin(a))
        local["forearm." + side] = rot_axis(flexion_axis(sg), bend * r)
    local["pelvis"] = rot_axis(Y_AXIS, -math.radians(5.0) * sph * r)
    local["chest"] = rot_axis(Y_AXIS, math.radians(8.0) * sph * r)
    local["neck"] = rot_axis(Y_AXIS, -math.radians(3.0) * sph * r)
    bob = -0.015 * sph * sph * r
    return local, (0.0, bob, 0.0)


MOTIONS = {
    # name: (pose function, duration in s)
    "arms-raise": (arms_raise_pose, 2.0),
    "walk": (walk_pose, 2.0 * WALK_PERIOD),
}


def arm_penetration(field, bones, transforms, posed, weights):
    """The deepest any arm point (one moved by its arm's bones only) lies inside the posed
    torso, head or legs (their primitives moved rigidly with their bones), m; 0 if none."""
    names = field.names
    arm = set(b for b, n in enumerate(names) if n.split(".")[0] in ARM_BONES)
    body = [pr for pr in field.prims if pr[2] > 0 and names[pr[1]].split(".")[0] not in ARM_BONES + ("clavicle",)]
    inv = []
    for R, jm in transforms:
        inv.append(((R[0][0], R[1][0], R[2][0]), (R[0][1], R[1][1], R[2][1]), (R[0][2], R[1][2], R[2][2])))
    deepest = 0.0
    for p, ws in zip(posed, weights):
        if sum(w for b, w in ws if b in arm) < 0.999:
            continue
        for pr in body:
            b = pr[1]
            jm = transforms[b][1]
            q = add(mat_vec(inv[b], sub(p, jm)), (bones[b][2][0], bones[b][2][1] + field.y_shift, bones[b][2][2]))
            v = field.prim_value(pr, q)[0]
            if v < -deepest:
                deepest = -v
    return deepest


def bake(field, points, weights, name, rate):
    """The motion's frames at `rate` per second (frame 0 is the rest pose): a list of point
    lists, and per frame the deepest arm penetration (m)."""
    pose, duration = MOTIONS[name]
    bones = [(n, par, (j[0], j[1] + field.y_shift, j[2])) for n, par, j in field.bones]
    frames, depth = [], []
    count = int(round(duration * rate)) + 1
    for k in range(count):
        local, root = pose(k / rate)
        tr = pose_transforms(bones, local, root)
        posed = points if k == 0 else skin(points, weights, bones, tr)
        frames.append(posed)
        depth.append(arm_penetration(field, bones, tr, posed, weights))
    return frames, depth


def speeds(frames, rate):
    """Per frame (from frame 1), the fastest point's speed from the previous frame, m/s."""
    out = []
    for a, b in zip(frames, frames[1:]):
        out.append(max(norm(sub(p, q)) for p, q in zip(a, b)) * rate)
    return out


def write_pc2(path, frames, rate):
    """A PC2 point cache: 'POINTCACHE2\\0', version 1, point count, start frame 0, sampling 1
    (one sample per frame), sample count; then x, y, z per point per sample, float32,
    little-endian."""
    n = len(frames[0])
    with open(path, "wb") as f:
        f.write(struct.pack("<12siiffi", b"POINTCACHE2\0", 1, n, 0.0, 1.0, len(frames)))
        for pts in frames:
            flat = [c for p in pts for c in p]
            f.write(struct.pack("<%df" % len(flat), *flat))


# ---------------------------------------------------------------------------------------------
# Output.


def write_obj(path, points, tris, title, uvs=None, face_uvs=None):
    """A Wavefront OBJ: `v` lines (6 decimals, metres), `vt` lines and `f a/ta b/tb c/tc`
    when texture coordinates are given, else `f a b c`."""
    with open(path, "w", newline="\n") as f:
        f.write(f"# {title}\n# generated by tools/make_body.py; metres, Y up, the body faces +Z\n")
        f.write(f"# {len(points)} vertices, {len(tris)} triangles, wound counter-clockwise seen from outside\n")
        for p in points:
            f.write("v {:.6f} {:.6f} {:.6f}\n".format(*p))
        if uvs is not None:
            for u in uvs:
                f.write("vt {:.6f} {:.6f}\n".format(*u))
            for (a, b, c), (ta, tb, tc) in zip(tris, face_uvs):
                f.write(f"f {a + 1}/{ta + 1} {b + 1}/{tb + 1} {c + 1}/{tc + 1}\n")
        else:
            for a, b, c in tris:
                f.write(f"f {a + 1} {b + 1} {c + 1}\n")


FRAME_RATE = 24  # frames per second of both motions
BODY_TRIANGLES = (10000, 20000)


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    args = sys.argv[1:]
    sequence = "--sequence" in args
    fine = "--fine" in args
    args = [a for a in args if a not in ("--sequence", "--fine")]
    tshirt_edge = None
    if "--tshirt-edge" in args:
        i = args.index("--tshirt-edge")
        tshirt_edge = float(args[i + 1])
        del args[i : i + 2]
    if len(args) > 1 or any(a.startswith("-") for a in args):
        sys.exit(__doc__)
    out = args[0] if args else os.path.join(here, "..", "scenes", "body")
    os.makedirs(out, exist_ok=True)
    report = {}

    field, shift, points, tris = build_body()
    vol = check_mesh(points, tris, closed=True)
    assert BODY_TRIANGLES[0] <= len(tris) <= BODY_TRIANGLES[1], f"{len(tris)} triangles"
    for a, b, c in tris:
        centre = mul(add(add(points[a], points[b]), points[c]), 1.0 / 3.0)
        assert dot(tri_normal(points[a], points[b], points[c]), field.value_grad(centre)[1]) > 0, "a face against the field"
    write_obj(os.path.join(out, "mannequin.obj"), points, tris, "wetcloth mannequin, 1.75 m, A-pose")
    angle, _ = angle_stats(points, tris)
    report["mannequin"] = (len(points), len(tris), vol, angle, max(p[1] for p in points))
    print(f"mannequin.obj: {len(points)} vertices, {len(tris)} triangles, {vol * 1000:.1f} L, smallest angle {angle:.1f} deg")

    weights = skin_weights(field, points, tris)
    for name in MOTIONS:
        frames, depth = bake(field, points, weights, name, FRAME_RATE)
        worst = max(depth)
        assert worst < 0.005, f"{name}: an arm goes {worst * 1000:.1f} mm into the body"
        write_pc2(os.path.join(out, name + ".pc2"), frames, FRAME_RATE)
        sp = speeds(frames, FRAME_RATE)
        report[name] = (len(frames), worst, sp)
        print(f"{name}.pc2: {len(frames)} frames at {FRAME_RATE}/s, fastest point {max(sp):.2f} m/s, arms at most {worst * 1000:.1f} mm into the body")
        if sequence:
            folder = os.path.join(out, name)
            os.makedirs(folder, exist_ok=True)
            for k, pts in enumerate(frames):
                write_obj(os.path.join(folder, f"frame_{k:04d}.obj"), round_points(pts), tris, f"{name}, frame {k}")
    return report


if __name__ == "__main__":
    main()
