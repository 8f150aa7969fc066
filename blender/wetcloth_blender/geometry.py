"""Transforms in double precision (Blender's own matrices are 32-bit), and the axis conversion.

Blender is Z-up, wetcloth Y-up, both right-handed in metres: a Blender point (x, y, z) is the
wetcloth point (x, z, -y) (the conversion of Blender's OBJ and glTF exporters, so the cloth
keeps its front: Blender's -Y, the view from the front, is wetcloth's +Z).

Matrices are 4x4 row-major nested lists (``m[row][column]``), affine (last row 0 0 0 1); no
bpy or mathutils here, so the functions can be checked anywhere.
"""

import math


def to_sim(p):
    """A Blender (Z-up) point or direction in wetcloth's Y-up axes."""
    return (p[0], p[2], -p[1])


def from_sim(q):
    """A wetcloth (Y-up) point or direction in Blender's Z-up axes."""
    return (q[0], -q[2], q[1])


def matrix(m):
    """A Blender Matrix (or any 4x4 sequence of rows) as nested lists of Python floats."""
    return [[float(m[i][j]) for j in range(4)] for i in range(4)]


def apply(m, p):
    """The affine matrix ``m`` applied to the point ``p``."""
    return tuple(m[i][0] * p[0] + m[i][1] * p[1] + m[i][2] * p[2] + m[i][3] for i in range(3))


def apply_linear(m, d):
    """The 3x3 part of ``m`` applied to the direction ``d``."""
    return tuple(m[i][0] * d[0] + m[i][1] * d[1] + m[i][2] * d[2] for i in range(3))


def det3(m):
    return (
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    )


def inverse(m):
    """The inverse of an affine matrix; raises ValueError when it is singular."""
    d = det3(m)
    if not math.isfinite(d) or abs(d) < 1e-300:
        raise ValueError("the transform is singular (a scale of 0)")
    a = [
        [
            (m[1][1] * m[2][2] - m[1][2] * m[2][1]) / d,
            (m[0][2] * m[2][1] - m[0][1] * m[2][2]) / d,
            (m[0][1] * m[1][2] - m[0][2] * m[1][1]) / d,
        ],
        [
            (m[1][2] * m[2][0] - m[1][0] * m[2][2]) / d,
            (m[0][0] * m[2][2] - m[0][2] * m[2][0]) / d,
            (m[0][2] * m[1][0] - m[0][0] * m[1][2]) / d,
        ],
        [
            (m[1][0] * m[2][1] - m[1][1] * m[2][0]) / d,
            (m[0][1] * m[2][0] - m[0][0] * m[2][1]) / d,
            (m[0][0] * m[1][1] - m[0][1] * m[1][0]) / d,
        ],
    ]
    t = [m[0][3], m[1][3], m[2][3]]
    out = [row + [-(row[0] * t[0] + row[1] * t[1] + row[2] * t[2])] for row in a]
    return out + [[0.0, 0.0, 0.0, 1.0]]


def multiply(a, b):
    return [[sum(a[i][k] * b[k][j] for k in range(4)) for j in range(4)] for i in range(4)]


def rotation(m):
    """The rotation of an affine matrix without shear: its 3x3 columns normalised (3x3)."""
    cols = []
    for j in range(3):
        c = [m[0][j], m[1][j], m[2][j]]
        n = math.sqrt(c[0] ** 2 + c[1] ** 2 + c[2] ** 2)
        cols.append([x / n for x in c] if n > 0 else [float(i == j) for i in range(3)])
    return [[cols[j][i] for j in range(3)] for i in range(3)]


def scales(m):
    """The lengths of the 3x3 part's columns: the object's scale along its own axes."""
    return tuple(math.sqrt(m[0][j] ** 2 + m[1][j] ** 2 + m[2][j] ** 2) for j in range(3))


def mul3(a, b):
    return [[sum(a[i][k] * b[k][j] for k in range(3)) for j in range(3)] for i in range(3)]


def transpose3(a):
    return [[a[j][i] for j in range(3)] for i in range(3)]


# C, the conversion Blender -> wetcloth as a matrix: (x, y, z) -> (x, z, -y).
_C = [[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]]


def rotation_to_sim(r):
    """A rotation of Blender's axes as the same rotation in wetcloth's: C R C^T."""
    return mul3(mul3(_C, r), transpose3(_C))


def euler_xyz_degrees(r, near=None):
    """Angles (degrees) about x, then y, then z with ``r = Rz Ry Rx`` (wetcloth's and Blender's
    'XYZ' order). With ``near``, each angle is moved by whole turns to the nearest of the
    previous key's, so that keys interpolated linearly do not spin the long way round."""
    sy = -r[2][0]
    sy = max(-1.0, min(1.0, sy))
    cy = math.hypot(r[0][0], r[1][0])
    if cy > 1e-9:
        x = math.atan2(r[2][1], r[2][2])
        y = math.atan2(sy, cy)
        z = math.atan2(r[1][0], r[0][0])
    else:  # gimbal lock: y = +-90 degrees, put the whole turn about x
        x = math.atan2(-r[1][2], r[1][1])
        y = math.copysign(math.pi / 2, sy)
        z = 0.0
    out = [math.degrees(a) for a in (x, y, z)]
    if near is not None:
        out = [a + 360.0 * round((n - a) / 360.0) for a, n in zip(out, near)]
    # -0.0 and round-off around zero are written as zero.
    return tuple(0.0 if abs(a) < 1e-12 else a for a in out)


def is_identity3(r, tol=1e-12):
    return all(abs(r[i][j] - (1.0 if i == j else 0.0)) <= tol for i in range(3) for j in range(3))
