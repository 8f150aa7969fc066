#!/usr/bin/env python3
"""Generates scenes/body/: a stylised mannequin to dress in wet cloth, its motions as point
caches, and garments fitted to it, procedurally, with the standard library only.

    python3 tools/make_body.py [--sequence] [--fine] [--tshirt-edge METRES] [OUT_DIR]
    (default OUT_DIR: scenes/body/ beside tools/)

Units and conventions: metres, Y up, the body faces +Z (its left arm towards +x), its soles on
y = 0, 1.75 m tall. Every face is wound counter-clockwise seen from outside (a garment's from
the side away from the body: the simulator keeps the air on the side its normals point away
from, so the air trapped between cloth and body is under the cloth). Coordinates are written
with 6 decimals and every check runs on the written values; the output is deterministic (the
same bytes on every run).

Writes:
- mannequin.obj: one closed, 2-manifold triangle mesh (12 870 triangles) in an A-pose, arms
  45 degrees out from the body, clear of the torso below the armpits.
- arms-raise.pc2, walk.pc2: point caches of the mannequin (vertex for vertex, in its order;
  file coordinates = metres, Y up), FRAME_RATE = 24 frames per second, frame 0 the rest pose.
  arms-raise: both arms up from the A-pose to straight over the head in 1.5 s (eased in and
  out), held 0.5 s (49 frames). walk: two cycles of a walk in place, 2 s (49 frames).
  PC2: b"POINTCACHE2\\0", int32 version 1, int32 point count, float32 start frame 0, float32
  sampling 1 (a sample per frame), int32 sample count, then float32 x, y, z per point per
  sample, all little-endian. A scene gives the rate as the collider's `frame_rate`.
- tshirt.obj (short sleeves, hips to neck, about 4 500 vertices at --tshirt-edge, default
  TSHIRT_EDGE = 1.35 cm), towel.obj (a 1.0 x 0.5 m bath towel over the shoulders, 2 592
  vertices), skirt.obj (hips to knees, 1 920 vertices): open welded meshes with texture
  coordinates (`f v/vt ...`), every vertex at least GAP = 1 cm from the body.
- with --sequence, each motion also as OBJ frames arms-raise/frame_0000.obj ... and
  walk/frame_0000.obj ... (the mannequin's faces in every frame; for tests, not committed);
- with --fine, also tshirt-fine.obj (edges of FINE_EDGE = 0.9 cm, about 10 000 vertices).

The body. A field over space, negative inside: ellipsoids and capsules of varying radius,
each attached to a bone of a skeleton (pelvis, spine, chest, neck, head, collarbones, upper
arms, forearms, mitten hands, thighs, shins, feet), blended in order by a quadratic smooth
minimum (and a smooth subtraction for the groove down the spine). The torso has a chest,
shoulder blades and buttocks that stand out of the hollow of the lower back, so a wet shirt
has hollows to bridge. Polygonised by marching tetrahedra on a 2 cm grid (six tetrahedra per
cube around its main diagonal, so neighbouring cubes agree and the surface is closed and
2-manifold; no grid value is exactly zero), vertices welded by grid edge, then remeshed on the
level set towards 1.7 cm edges: long edges split, short ones collapsed (where that keeps the
mesh manifold and no face flips), edges flipped where that raises the smaller angle, vertices
smoothed in the tangent plane and put back on the surface by Newton steps along the field's
gradient. Checked before writing: every edge shared by exactly two faces running it in
opposite directions, one piece of genus 0, positive signed volume, every face's area above
1e-10 m^2 and its normal along the field's gradient, the triangle count within 10 000-20 000.

The motions. Linear blend skinning: a vertex's weights are exp(-(d_b - d_min) / 1 cm) over
the bone nearest to it, that bone's parent and children (d_b each bone's own field there),
smoothed over the mesh by eight rounds of averaging with the neighbours, the four largest
kept, normalised; so elbows, shoulders and hips bend smoothly. Each frame poses the skeleton
(rotations about the joints) and skins the rest mesh. Checked per frame: no point moved by
its arm alone lies more than 5 mm inside the torso, head or legs as posed (their shapes moved
with their bones); the largest point speed per frame is printed.

The garments. The T-shirt is cut out of the level set field = GAP + EASE (1.5 cm): marching
tetrahedra at the target edge, remeshed as the body, then cut along the hem (y = 0.86 m), the
neckline (an elliptic cylinder about the neck) and each sleeve's end (a plane across the arm
16 cm from the shoulder, so the sleeves follow the A-pose): vertices near a cut move onto it,
the edges crossing it are split there, the far side is deleted, and the piece at the chest is
kept. The remeshing then goes on with the cut edges' vertices held on their curves. A seam
surface (about where the shirt is seen edge-on from the front, and through the middle of the
armpits) is cut in the same way without deleting: it parts the front panel from the back one
along the sides, under the arms and over the shoulders and sleeves. The texture coordinates
are the two panels' flat patterns: each flattened as rigidly as possible from its view from
the front (or behind), laid side by side and scaled into [0, 1]^2 by one factor; u runs up the
body (the grain: the simulator's warp is along dX/du). The towel is a regular grid (squares
split along alternate diagonals) whose top edge lies across the back of the neck and the
shoulders, laid down the back and draped by rounds of restoring the grid's lengths and
pushing vertices out of the level set; u along its length, v across, over [0, 1]^2. The skirt
is rings of vertices, every other one turned half a step (near-equilateral triangles), each
ring as wide as the body's outline from the waistband down to it plus a 6 degree flare.
Checked before writing: open, 2-manifold, consistently wound, no degenerate face, every
vertex outside the body and at least GAP from the mannequin's mesh (exact point-triangle
distances), the faces turned away from the body, no texture triangle flipped; the smallest
angle, the share of faces below 25 degrees and the least gap are printed.
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

    def cut(self, cid, func, length, where=None, delete=True, snap=0.3):
        """Cuts the surface along the curve func = 0: vertices within snap * length of it are
        moved onto it, the edges still crossing it are split where they cross, so that the
        curve runs along edges. With delete, the faces on its negative side go and the new
        boundary's vertices are tied to the curve; without, the edges along it become seam
        edges (a feature the remeshing keeps). `where(p)` limits the cut to part of space."""
        big = 1e9
        vals = {}
        for v in range(len(self.V)):
            if self.alive[v] and self.vf[v]:
                vals[v] = func(self.V[v])[0] if where is None or where(self.V[v]) else big
        for v in sorted(vals, key=lambda v: (abs(vals[v]), v)):
            x = vals[v]
            if x == big or abs(x) >= snap * length or len(self.tags[v]) >= 2:
                continue
            tag = tuple(sorted(self.tags[v] + (cid,)))
            p = self.constrain(self.V[v], tag)
            moved = {v: p}
            if all(dot(self.normal(f), self.normal(f, moved)) > 0 for f in self.vf[v]):
                self.V[v] = p
                self.tags[v] = tag
                vals[v] = 0.0
        for a, b in self.edges():
            va, vb = vals[a], vals[b]
            if va * vb >= 0.0 or not self.faces_of_edge(a, b):
                continue
            assert big not in (va, vb), f"cut {cid} leaves the region it is limited to"
            tag = tuple(sorted(self.split_tag(a, b) + (cid,)))
            p = self.constrain(lerp(self.V[a], self.V[b], va / (va - vb)), tag)
            m = self.split(a, b, p, tag)
            vals[m] = 0.0
        side = {}
        for f, t in enumerate(self.F):
            if t is None:
                continue
            s = [vals[v] for v in t]
            if max(s) > 0.0:
                side[f] = 1
            elif min(s) < 0.0:
                side[f] = -1
            else:
                c = mul(add(add(self.V[t[0]], self.V[t[1]]), self.V[t[2]]), 1.0 / 3.0)
                side[f] = 1 if func(c)[0] >= 0.0 else -1
        if delete:
            for f in sorted(side):
                if side[f] < 0:
                    self.remove_face(f)
        else:
            for a, b in self.edges():
                fs = sorted(self.faces_of_edge(a, b))
                if len(fs) == 2 and side[fs[0]] != side[fs[1]]:
                    self.feat.add((a, b))
        for v in range(len(self.V)):
            if not self.vf[v]:
                self.alive[v] = False
            if cid in self.tags[v]:
                on = any(self.is_feature(v, u) for u in self.neighbours(v)
                         if (delete and self.is_boundary_edge(v, u)) or (not delete and (min(u, v), max(u, v)) in self.feat))
                if not on or not self.alive[v]:
                    self.tags[v] = tuple(c for c in self.tags[v] if c != cid)
        return side

    def keep_component(self, point):
        """Deletes every piece of the surface but the one nearest to `point`."""
        live = [f for f, t in enumerate(self.F) if t is not None]
        parent = {}

        def find(a):
            while parent.setdefault(a, a) != a:
                parent[a] = parent[parent[a]]
                a = parent[a]
            return a

        for f in live:
            a, b, c = self.F[f]
            ra = find(a)
            parent[find(b)] = ra
            parent[find(c)] = ra
        near = min(live, key=lambda f: (norm(sub(self.V[self.F[f][0]], point)), f))
        root = find(self.F[near][0])
        for f in live:
            if find(self.F[f][0]) != root:
                self.remove_face(f)
        for v in range(len(self.V)):
            if not self.vf[v]:
                self.alive[v] = False

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
# Garments.

GAP = 0.01  # m: the least distance from a garment's vertex to the body
EASE = 0.005  # m: how much looser than the gap the T-shirt is made
TSHIRT_EDGE = 0.0135  # m
FINE_EDGE = 0.009  # m: tshirt-fine.obj (--fine), about 10 000 vertices
HEM_Y = 0.86  # m: the T-shirt's hem, over the hips
SLEEVE = 0.16  # m: from the shoulder joint along the arm to the sleeve's end


def plane(point, normal):
    normal = unit(normal)

    def f(p):
        return dot(sub(p, point), normal), normal

    return f


def neckline(p):
    """Zero on the crew neck's opening: an elliptic cylinder about the neck, 17 cm across and
    17 cm deep; positive outside it."""
    ax, az, zc = 0.085, 0.085, 0.005
    x, z = p[0] / ax, (p[2] - zc) / az
    r = math.sqrt(x * x + z * z)
    if r < 1e-9:
        return -ax, (1.0, 0.0, 0.0)
    g = (x / (r * ax) * ax, 0.0, z / (r * az) * ax)
    return (r - 1.0) * ax, g


def side_seam(y_shift):
    """Zero on the surface z = z_s(x, y) that parts the T-shirt's front from its back: about
    where the shirt is seen edge-on from the front (over the shoulders 2 cm behind the middle,
    along the sides 0.5 cm in front of it, along the arms 1.5 cm behind it) but straight
    through the middle of the armpit, where the silhouette wanders."""

    def zs(x, y):
        y -= y_shift
        top = smoothstep((y - 1.36) / 0.1)
        body = -0.02 * top + 0.005 * (1.0 - top)
        arm = smoothstep((abs(x) - 0.19) / 0.05)
        return body * (1.0 - arm) - 0.015 * arm

    def f(p, h=1e-4):
        z0 = zs(p[0], p[1])
        gx = (zs(p[0] + h, p[1]) - zs(p[0] - h, p[1])) / (2 * h)
        gy = (zs(p[0], p[1] + h) - zs(p[0], p[1] - h)) / (2 * h)
        return p[2] - z0, (-gx, -gy, 1.0)

    return f


def tshirt(field, length, gap):
    """The T-shirt: the level set field = gap + EASE between the hem and the neck, with short
    sleeves, cut out of the surface and remeshed at `length`; the edges along side_seam's
    surface are the seams between the front and the back panel."""
    iso = gap + EASE
    lo = (-0.46, HEM_Y - 0.05 + field.y_shift, -0.2)
    hi = (0.46, 1.62 + field.y_shift, 0.22)
    points, tris = march(lambda p: field.value(p) - iso, lo, hi, length)
    curves = {"hem": plane((0.0, HEM_Y + field.y_shift, 0.0), Y_AXIS), "neck": neckline, "seam": side_seam(field.y_shift)}
    wheres = {}
    for side, s in (("L", 1.0), ("R", -1.0)):
        shoulder, elbow, _, _ = arm_points(s)
        shoulder = (shoulder[0], shoulder[1] + field.y_shift, shoulder[2])
        u = unit(sub(elbow, arm_points(s)[0]))
        curves["sleeve." + side] = plane(add(shoulder, mul(u, SLEEVE)), mul(u, -1.0))

        def near_arm(p, shoulder=shoulder, u=u):
            d = sub(p, shoulder)
            s_ = dot(d, u)
            return s_ > 0.05 and norm(sub(d, mul(u, s_))) < 0.1

        wheres["sleeve." + side] = near_arm
    rm = Remesher(field, iso, points, tris, curves=curves, seams=("seam",))
    rm.remesh(length, rounds=2)
    for cid in ("hem", "neck", "sleeve.L", "sleeve.R"):
        rm.cut(cid, curves[cid], length, where=wheres.get(cid))
    rm.keep_component((0.0, 1.25 + field.y_shift, 0.2))
    rm.remesh(length, rounds=3)
    rm.cut("seam", curves["seam"], length, delete=False)
    rm.remesh(length, rounds=2)
    points, tris, tags, seams = rm.compact()
    return points, tris, tags, seams

def flatten(points, tris, start, iterations):
    """A flat pattern of a piece of surface (a disc): starting from `start` (vertex -> (u, v),
    no triangle flipped by much), each round fits every triangle's true shape onto its current
    place by a rotation and a shift (never a reflection) and moves each vertex to the mean of
    its triangles' fits (as-rigid-as-possible, Jacobi). Returns vertex -> (u, v), m."""
    shapes = []
    for a, b, c in tris:
        e1, e2 = sub(points[b], points[a]), sub(points[c], points[a])
        x = unit(e1)
        y = unit(cross(cross(e1, e2), e1))
        q = [(0.0, 0.0), (norm(e1), 0.0), (dot(e2, x), dot(e2, y))]
        mx, my = (q[1][0] + q[2][0]) / 3, (q[1][1] + q[2][1]) / 3
        shapes.append([(qx - mx, qy - my) for qx, qy in q])
    uv = dict(start)
    count = {}
    for t in tris:
        for v in t:
            count[v] = count.get(v, 0) + 1
    for _ in range(iterations):
        acc = {v: [0.0, 0.0] for v in uv}
        for t, q in zip(tris, shapes):
            c = [uv[v] for v in t]
            cx = (c[0][0] + c[1][0] + c[2][0]) / 3
            cy = (c[0][1] + c[1][1] + c[2][1]) / 3
            s = cr = 0.0
            for (qx, qy), (ux, uy) in zip(q, c):
                ux -= cx
                uy -= cy
                s += qx * ux + qy * uy
                cr += qx * uy - qy * ux
            h = math.hypot(s, cr)
            co, si = (s / h, cr / h) if h > 0 else (1.0, 0.0)
            for v, (qx, qy) in zip(t, q):
                a = acc[v]
                a[0] += cx + co * qx - si * qy
                a[1] += cy + si * qx + co * qy
        uv = {v: (a[0] / count[v], a[1] / count[v]) for v, a in acc.items()}
    return uv


def untangle(tris, uv, rounds=200):
    """Moves the vertices around flipped texture triangles (and their neighbours) to the
    middle of their neighbours until none is flipped; the pattern's border stays unless it
    is part of the fold."""
    ring, edges = {}, {}
    for a, b, c in tris:
        for u, w in ((a, b), (b, c), (c, a)):
            ring.setdefault(u, set()).add(w)
            ring.setdefault(w, set()).add(u)
            k = (min(u, w), max(u, w))
            edges[k] = edges.get(k, 0) + 1
    border = set(v for e, n in edges.items() if n == 1 for v in e)
    for _ in range(rounds):
        bad = [t for t in tris if uv_area(*[uv[v] for v in t]) <= 0]
        if not bad:
            return uv
        move = set()
        for t in bad:
            for v in t:
                move.add(v)
                move.update(ring[v])
        if _ < rounds // 2:
            move -= border
        new = {}
        for v in sorted(move):
            n = sorted(ring[v])
            new[v] = (sum(uv[u][0] for u in n) / len(n), sum(uv[u][1] for u in n) / len(n))
        uv.update(new)
    return uv


def panels_of(tris, seams):
    """The pieces the seam edges cut a mesh into: lists of face indices, largest first."""
    owner = {}
    for f, (a, b, c) in enumerate(tris):
        for u, w in ((a, b), (b, c), (c, a)):
            owner.setdefault((min(u, w), max(u, w)), []).append(f)
    parent = list(range(len(tris)))

    def find(a):
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a

    cut = set(seams)
    for e, fs in owner.items():
        if len(fs) == 2 and e not in cut:
            parent[find(fs[1])] = find(fs[0])
    groups = {}
    for f in range(len(tris)):
        groups.setdefault(find(f), []).append(f)
    return sorted(groups.values(), key=lambda g: (-len(g), g[0]))


def uv_area(a, b, c):
    return ((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])) / 2


def pattern_uvs(points, tris, panels, iterations=80, margin=0.02):
    """Texture coordinates from flat patterns: `panels` is a list of (face indices, initial
    (u, v) of a point, a function); each panel is flattened (its seams' vertices get one
    texture coordinate per panel), the panels are laid side by side along v and the whole
    scaled by one factor into [0, 1]^2, so u and v stay proportional to lengths on the
    cloth. Returns (uvs, face_uvs, scale (texture units per metre))."""
    placed = []
    for faces, init in panels:
        sub_tris = [tris[f] for f in faces]
        verts = sorted(set(v for t in sub_tris for v in t))
        uv = flatten(points, sub_tris, {v: init(points[v]) for v in verts}, iterations)
        for _ in range(8):
            uv = untangle(sub_tris, flatten(points, sub_tris, untangle(sub_tris, uv), iterations // 4))
            if all(uv_area(*[uv[v] for v in t]) > 0 for t in sub_tris):
                break
        for t in sub_tris:
            assert uv_area(*[uv[v] for v in t]) > 0, "a flipped triangle in a flat pattern"
        placed.append((faces, uv))
    offset = 0.0
    boxes = []
    for faces, uv in placed:
        us = [p[0] for p in uv.values()]
        vs = [p[1] for p in uv.values()]
        boxes.append((min(us), max(us), min(vs), max(vs), offset))
        offset += max(vs) - min(vs) + margin
    width = offset - margin
    height = max(b[1] - b[0] for b in boxes)
    scale = (1.0 - 2 * margin) / max(width, height)
    uvs, face_uvs = [], [None] * len(tris)
    for (faces, uv), (u0, u1, v0, v1, off) in zip(placed, boxes):
        index = {}
        for v in sorted(uv):
            index[v] = len(uvs)
            uvs.append((fmt(margin + (uv[v][0] - u0) * scale), fmt(margin + (uv[v][1] - v0 + off) * scale)))
        for f in faces:
            face_uvs[f] = tuple(index[v] for v in tris[f])
    for t, ft in zip(tris, face_uvs):
        assert uv_area(*[uvs[i] for i in ft]) > 0, "a texture triangle wound against its face"
    return uvs, face_uvs, scale


def point_triangle(p, a, b, c):
    """The closest point to p on triangle a b c."""
    ab, ac, ap = sub(b, a), sub(c, a), sub(p, a)
    d1, d2 = dot(ab, ap), dot(ac, ap)
    if d1 <= 0 and d2 <= 0:
        return a
    bp = sub(p, b)
    d3, d4 = dot(ab, bp), dot(ac, bp)
    if d3 >= 0 and d4 <= d3:
        return b
    vc = d1 * d4 - d3 * d2
    if vc <= 0 and d1 >= 0 and d3 <= 0:
        return add(a, mul(ab, d1 / (d1 - d3)))
    cp = sub(p, c)
    d5, d6 = dot(ab, cp), dot(ac, cp)
    if d6 >= 0 and d5 <= d6:
        return c
    vb = d5 * d2 - d1 * d6
    if vb <= 0 and d2 >= 0 and d6 <= 0:
        return add(a, mul(ac, d2 / (d2 - d6)))
    va = d3 * d6 - d5 * d4
    if va <= 0 and (d4 - d3) >= 0 and (d5 - d6) >= 0:
        return add(b, mul(sub(c, b), (d4 - d3) / ((d4 - d3) + (d5 - d6))))
    den = 1.0 / (va + vb + vc)
    return add(a, add(mul(ab, vb * den), mul(ac, vc * den)))


class MeshDistance:
    """Distances from points to a triangle mesh, through a grid of buckets."""

    def __init__(self, points, tris, cell=0.03):
        self.P, self.T, self.cell = points, tris, cell
        self.buckets = {}
        for f, (a, b, c) in enumerate(tris):
            lo = [min(points[a][i], points[b][i], points[c][i]) for i in range(3)]
            hi = [max(points[a][i], points[b][i], points[c][i]) for i in range(3)]
            for i in range(math.floor(lo[0] / cell), math.floor(hi[0] / cell) + 1):
                for j in range(math.floor(lo[1] / cell), math.floor(hi[1] / cell) + 1):
                    for k in range(math.floor(lo[2] / cell), math.floor(hi[2] / cell) + 1):
                        self.buckets.setdefault((i, j, k), []).append(f)

    def distance(self, p, reach=0.05):
        """The distance from p to the mesh, or `reach` if it is farther than that."""
        best = reach
        c = self.cell
        seen = set()
        r = int(math.ceil(reach / c))
        ci, cj, ck = math.floor(p[0] / c), math.floor(p[1] / c), math.floor(p[2] / c)
        for i in range(ci - r, ci + r + 1):
            for j in range(cj - r, cj + r + 1):
                for k in range(ck - r, ck + r + 1):
                    for f in self.buckets.get((i, j, k), ()):
                        if f in seen:
                            continue
                        seen.add(f)
                        a, b, cc = self.T[f]
                        d = norm(sub(p, point_triangle(p, self.P[a], self.P[b], self.P[cc])))
                        if d < best:
                            best = d
        return best


def check_garment(name, points, tris, uvs, face_uvs, field, body, gap, outward_share=0.98):
    """Asserts a garment is an open manifold mesh wound outwards (each face's normal away from
    the body), every vertex at least `gap` from the body mesh and outside it; returns its
    report: (vertices, triangles, smallest angle, share below 25 degrees, least gap, edges)."""
    boundary = check_mesh(points, tris, closed=False)
    assert boundary > 0, f"{name} has no opening"
    least = 1.0
    for p in points:
        assert field.value(p) > 0.0, f"{name}: a vertex inside the body"
        least = min(least, body.distance(p))
    assert least >= gap * (1 - 1e-6), f"{name}: a vertex {least * 1000:.2f} mm from the body (< {gap * 1000:.1f} mm)"
    outward = 0
    for a, b, c in tris:
        centre = mul(add(add(points[a], points[b]), points[c]), 1.0 / 3.0)
        if dot(tri_normal(points[a], points[b], points[c]), field.value_grad(centre)[1]) > 0:
            outward += 1
    assert outward >= outward_share * len(tris), f"{name}: only {outward} of {len(tris)} faces face away from the body"
    angle, small = angle_stats(points, tris)
    return (len(points), len(tris), angle, small, least, edge_stats(points, tris), outward)

SKIRT_TOP = 0.97  # m: the skirt's waistband, around the hips
SKIRT_HEM = 0.50  # m: its hem, at the knees
SKIRT_AROUND = 64  # vertices around


def outer_radius(field, iso, y, theta, start, centre_z=-0.01):
    """The outermost radius, from the vertical axis through (0, y, centre_z) in the direction
    theta (0: +z, 90 degrees: +x), where the field is at most iso; 0 if it never is."""
    d = (math.sin(theta), 0.0, math.cos(theta))

    def at(r):
        return field.value((d[0] * r, y, centre_z + d[2] * r)) - iso

    r = start
    while at(r) <= 0.0:
        r += 0.05
    step = 0.01
    while r > 0.0 and at(r - step) > 0.0:
        r -= step
    if r - step <= 0.0:
        return 0.0
    lo, hi = r - step, r
    for _ in range(12):
        mid = (lo + hi) / 2
        if at(mid) > 0.0:
            hi = mid
        else:
            lo = mid
    return hi


def skirt(field, gap, around=SKIRT_AROUND, flare=math.radians(6.0), ease=0.006):
    """A skirt: rings of `around` vertices from the hips down to the knees, every other ring
    turned half a step, so that the triangles are near equilateral; each ring's height step is
    sqrt(3)/2 of its mean edge. A ring's radius in each direction is the largest of the body's
    outline (at gap + ease) from the waistband down to it, plus a flare of 6 degrees, smoothed
    around; so the skirt hangs from the hips over the buttocks and past both legs as a tube."""
    iso = gap + ease
    top, hem = SKIRT_TOP + field.y_shift, SKIRT_HEM + field.y_shift
    samples = 2 * around
    thetas = [2.0 * math.pi * i / samples for i in range(samples)]
    reach = [0.0] * samples
    rings, ys = [], []
    y = top
    prev = [0.3] * samples
    while True:
        env = [outer_radius(field, iso, y, th, max(0.05, prev[i] - 0.04)) for i, th in enumerate(thetas)]
        prev = [max(e, 0.1) for e in env]
        reach = [max(r, e) for r, e in zip(reach, env)]
        r = [reach[i] + (top - y) * math.tan(flare) for i in range(samples)]
        for _ in range(3):
            r = [(r[i - 1] + 2.0 * r[i] + r[(i + 1) % samples]) / 4.0 for i in range(samples)]
        r = [max(a, b + 0.001) for a, b in zip(r, env)]
        rings.append(r)
        ys.append(y)
        circumference = sum(math.hypot(r[i] - r[i - 1], r[i] * 2 * math.pi / samples) for i in range(samples))
        y -= math.sqrt(3.0) / 2.0 * circumference / around
        if y < hem - 0.25 * (ys[-1] - y):
            break
    # Stretch the rings' heights so that the last is on the hem.
    n = len(ys)
    ys = [top + (yy - top) * (top - hem) / (top - ys[-1]) for yy in ys]
    points, uvs_raw = [], []
    for k in range(n):
        for i in range(around):
            j = 2 * i + (k % 2)
            th = thetas[j]
            r = rings[k][j]
            points.append((r * math.sin(th), ys[k], -0.01 + r * math.cos(th)))
    tris = []
    for k in range(n - 1):
        a = lambda i: k * around + i % around
        b = lambda i: (k + 1) * around + i % around
        for i in range(around):
            if k % 2 == 0:
                tris.append((a(i), b(i), a(i + 1)))
                tris.append((a(i + 1), b(i), b(i + 1)))
            else:
                tris.append((b(i), b(i + 1), a(i)))
                tris.append((a(i), b(i + 1), a(i + 1)))
    points = round_points(points)
    # Texture: u up the skirt (the grain), v around it, from the back (where it wraps, the
    # seam's vertices have a second coordinate past 1); one scale for both, m.
    length = top - hem
    girth = max(sum(norm(sub(points[k * around + i], points[k * around + (i + 1) % around])) for i in range(around)) for k in range(n))
    span = max(length, girth)
    uvs, face_uvs, index = [], [], {}

    def vt(v, wrap):
        key = (v, wrap)
        if key not in index:
            k, i = divmod(v, around)
            th = thetas[2 * i + (k % 2)]
            turn = ((math.pi - th) % (2.0 * math.pi)) / (2.0 * math.pi) + (1.0 if wrap else 0.0)
            index[key] = len(uvs)
            uvs.append((fmt((ys[k] - hem) / span), fmt(turn * girth / span / (1.0 + 1.0 / around))))
        return index[key]

    for t in tris:
        turns = [((math.pi - thetas[2 * (v % around) + ((v // around) % 2)]) % (2.0 * math.pi)) for v in t]
        wrap = max(turns) - min(turns) > math.pi
        face_uvs.append(tuple(vt(v, wrap and tv < math.pi) for v, tv in zip(t, turns)))
    return points, tris, uvs, face_uvs


TOWEL_SIZE = (1.0, 0.5)  # m: length (across the shoulders) and width (down the back)
TOWEL_GRID = (72, 36)  # vertices along each


def towel(field, gap, ease=0.006, iterations=40, drop=0.0):
    """A bath towel over the shoulders like a cape: a 1.0 x 0.5 m sheet (a regular grid,
    each square split along alternate diagonals) whose top edge lies across the back of the
    neck and the shoulders (where rays from above and behind towards a line through the chest
    meet the body's level set at gap + ease); the rest of the sheet
    is laid straight down the back from it, then drapes: rounds of a small step down, the
    grid's edges (and the vertices two apart along each grid line) put back to their
    lengths and the vertices pushed out of the level set (a drape without inertia)."""
    iso = gap + ease
    nx, nb = TOWEL_GRID
    L, W = TOWEL_SIZE
    y0, z0 = 1.28 + field.y_shift, 0.0

    def hit(x, psi):
        d = (0.0, -math.cos(psi), math.sin(psi))
        o = (x, y0 - 0.6 * d[1], z0 - 0.6 * d[2])
        t = 0.0
        while t < 1.2:
            if field.value(add(o, mul(d, t + 0.005))) - iso < 0.0:
                lo, hi = t, t + 0.005
                for _ in range(20):
                    mid = (lo + hi) / 2
                    if field.value(add(o, mul(d, mid))) - iso < 0.0:
                        hi = mid
                    else:
                        lo = mid
                return add(o, mul(d, lo))
            t += 0.005
        return None

    # The top edge: one vertex every grid step across, where a ray from above and behind
    # (30 degrees from the vertical) meets the body; over the neck and the shoulders (|x| <=
    # 0.2 m) it is held; beyond, where the rays meet the arms or miss, it is free to move
    # (level with the last hit where they miss).
    psi = math.radians(30.0)
    hx = L / (nx - 1)
    top, held = [], []
    for i in range(nx):
        x = -L / 2 + i * hx
        top.append(hit(x, psi))
        held.append(top[-1] is not None and abs(x) <= 0.2)
    assert sum(held) > nx // 3, "the towel's top edge misses the body"
    first, last = held.index(True), nx - 1 - held[::-1].index(True)
    for i in range(nx):
        if top[i] is None:
            ref = top[first] if i < first else top[last]
            top[i] = (-L / 2 + i * hx, ref[1], ref[2])
    # The sheet starts laid down the body from that edge, each column in its plane x = const:
    # every next vertex one row's width from the last, on the level set where it can
    # be (the first such point on that circle coming round from behind), else straight
    # down; then it drapes.
    hb = W / (nb - 1)
    cols = []
    for i in range(nx):
        down, back = (0.0, -1.0, 0.0), (0.0, 0.0, -1.0)
        col = [top[i]]
        for j in range(1, nb):
            p = col[-1]

            def at(beta):
                return add(p, add(mul(down, hb * math.cos(beta)), mul(back, hb * math.sin(beta))))

            q = at(0.0)
            beta, step = math.pi / 2, math.pi / 36
            if field.value(at(beta)) >= iso:
                while beta > -math.pi / 2 + 1e-9:
                    if field.value(at(beta - step)) < iso:
                        lo, hi = beta - step, beta
                        for _ in range(16):
                            m = (lo + hi) / 2
                            if field.value(at(m)) < iso:
                                lo = m
                            else:
                                hi = m
                        q = at(hi) if hi > 0.0 or field.value(at(0.0)) < iso else at(0.0)
                        break
                    beta -= step
            col.append(q)
        cols.append(col)
    P = [cols[i][j] for j in range(nb) for i in range(nx)]
    edges = []
    tris = []
    for j in range(nb - 1):
        for i in range(nx - 1):
            a = j * nx + i
            b, c, d = a + 1, a + nx + 1, a + nx
            if (i + j) % 2 == 0:
                tris += [(a, b, c), (a, c, d)]
            else:
                tris += [(a, b, d), (b, c, d)]
    for a, b, c in tris:
        for u, w in ((a, b), (b, c), (c, a)):
            if u < w:
                edges.append((u, w))
    rest = {}
    for j in range(nb):
        for i in range(nx):
            rest[j * nx + i] = (i * hx, j * hb)
    cons = []
    for u, w in sorted(set(edges)):
        ru, rw = rest[u], rest[w]
        cons.append((u, w, math.hypot(ru[0] - rw[0], ru[1] - rw[1])))
    # Bending: the vertices two apart along each grid line keep their distance.
    for j in range(nb):
        for i in range(nx):
            v = j * nx + i
            if i + 2 < nx:
                cons.append((v, v + 2, 2 * hx))
            if j + 2 < nb:
                cons.append((v, v + 2 * nx, 2 * hb))
    pinned = set(i for i in range(nx) if held[i])
    for it in range(iterations):
        P = [p if v in pinned else (p[0], p[1] - drop, p[2]) for v, p in enumerate(P)]
        for _ in range(4):
            acc = [[0.0, 0.0, 0.0, 0] for _ in P]
            for u, w, l in cons:
                d = sub(P[w], P[u])
                n = norm(d)
                if n < 1e-12:
                    continue
                c = mul(d, 0.5 * (n - l) / n)
                au, aw = acc[u], acc[w]
                au[0] += c[0]; au[1] += c[1]; au[2] += c[2]; au[3] += 1
                aw[0] -= c[0]; aw[1] -= c[1]; aw[2] -= c[2]; aw[3] += 1
            P = [p if v in pinned or not a[3] else (p[0] + 1.5 * a[0] / a[3], p[1] + 1.5 * a[1] / a[3], p[2] + 1.5 * a[2] / a[3])
                 for v, (p, a) in enumerate(zip(P, acc))]
        out = []
        for v, p in enumerate(P):
            if v not in pinned:
                f, g = field.value_grad(p)
                if f < iso:
                    gg = dot(g, g)
                    p = sub(p, mul(g, (f - iso - 0.0005) / gg))
            out.append(p)
        P = out
    # Last, every vertex out of the level set for certain.
    P = [p if field.value(p) >= iso else field.project(p, iso + 0.0005, 8) for p in P]
    P = round_points(P)
    uvs = [(fmt(rest[v][0] / L), fmt(1.0 - rest[v][1] / W)) for v in range(len(P))]
    # Wind the faces outwards (away from the body), the texture with them.
    out = 0
    for a, b, c in tris:
        centre = mul(add(add(P[a], P[b]), P[c]), 1.0 / 3.0)
        if dot(tri_normal(P[a], P[b], P[c]), field.value_grad(centre)[1]) > 0:
            out += 1
    if out < len(tris) / 2:
        tris = [(a, c, b) for a, b, c in tris]
    if uv_area(*[uvs[v] for v in tris[0]]) < 0:
        uvs = [(u, fmt(1.0 - v)) for u, v in uvs]
    return P, tris, uvs, [tuple(t) for t in tris]

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

    body = MeshDistance(points, tris)
    garments = []
    edge = tshirt_edge or TSHIRT_EDGE
    shirts = [("tshirt.obj", edge)]
    if fine:
        shirts.append(("tshirt-fine.obj", FINE_EDGE))
    for fname, length in shirts:
        gp, gt, _, seams = tshirt(field, length, GAP)
        gp = round_points(gp)
        panels = []
        for faces in panels_of(gt, seams):
            front = sum(gp[gt[f][0]][2] for f in faces) > 0
            panels.append((faces, (lambda p: (p[1], -p[0])) if front else (lambda p: (p[1], p[0]))))
        assert len(panels) == 2, f"the T-shirt's seams part it into {len(panels)} pieces"
        uvs, fuv, _ = pattern_uvs(gp, gt, panels)
        garments.append((fname, f"T-shirt, edges about {length * 100:.2f} cm", gp, gt, uvs, fuv, 0.98))
    gp, gt, uvs, fuv = towel(field, GAP)
    garments.append(("towel.obj", "bath towel over the shoulders, 1.0 x 0.5 m", gp, gt, uvs, fuv, 0.9))
    gp, gt, uvs, fuv = skirt(field, GAP)
    garments.append(("skirt.obj", "skirt from the hips to the knees", gp, gt, uvs, fuv, 0.98))
    for fname, title, gp, gt, uvs, fuv, share in garments:
        r = check_garment(fname, gp, gt, uvs, fuv, field, body, GAP, share)
        write_obj(os.path.join(out, fname), gp, gt, "wetcloth " + title, uvs, fuv)
        report[fname] = r
        print(f"{fname}: {r[0]} vertices, {r[1]} triangles, smallest angle {r[2]:.1f} deg "
              f"({r[3] * 100:.2f} % of faces below 25), edges {r[5][0] * 100:.2f}-{r[5][2] * 100:.2f} cm "
              f"(mean {r[5][1] * 100:.2f}), at least {r[4] * 1000:.1f} mm from the body, "
              f"{r[6] / r[1] * 100:.1f} % of faces facing away from it")
    return report


if __name__ == "__main__":
    main()
