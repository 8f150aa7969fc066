//! The row kernels of the step: the hot loops, written over structure-of-arrays slices so the
//! compiler vectorises them across the particles of a row (no branches in the inner loops, one
//! square root and one division per spring or normal, bounds checks lifted by slicing first).
//!
//! Every particle's result is a fixed sequence of operations on its neighbours' positions, so
//! the output is bit-identical however the rows are split between threads.

use crate::cloth::Grid;
use crate::collider::Collider;
use crate::contact;
use crate::forces::{RowMut, RowRef, spring_forces};
use crate::math::{Real, Soa, Vec3};

/// A plane collider prepared for the vectorised contact loop.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PlaneContact {
    pub normal: Vec3,
    /// `normal . point + radius`: a particle centre is in contact below this.
    pub offset: Real,
    pub friction: Real,
}

/// Constants of one step, shared by the row kernels.
pub(crate) struct StepConsts<'a> {
    pub grid: &'a Grid,
    /// Plane colliders (vectorised path).
    pub planes: &'a [PlaneContact],
    /// Every other collider (scalar path).
    pub others: &'a [Collider],
    pub mass: Real,
    pub gravity: Vec3,
    /// `damping * m / dt`: the damping force is `-damp * (x - x_prev)`.
    pub damp: Real,
    pub structural: Real,
    pub shear: Real,
    /// `(P_b - P_a) S`, N: the pressure force is this times the unit normal.
    pub pressure_area: Real,
    pub radius: Real,
    /// Rest lengths of the structural springs along x and z and of the shear springs, m.
    pub rest_x: Real,
    pub rest_z: Real,
    pub rest_diag: Real,
    /// `dt^2 / m` (halved on the first step: the Taylor start).
    pub h: Real,
    /// Positions the self-collision lists were built at, if any: the pass then also returns
    /// how far the particles have moved from them (see [`step_rows`]).
    pub reference: Option<&'a Soa>,
    /// The sticking plane (point, up) for the volume of the checks (see [`step_rows`]).
    pub sticking: Option<(Vec3, Vec3)>,
}

/// Row `r` of `p` as read-only slices.
#[inline]
pub(crate) fn row(p: &Soa, nx: usize, r: usize) -> RowRef<'_> {
    RowRef {
        x: &p.x[r * nx..(r + 1) * nx],
        y: &p.y[r * nx..(r + 1) * nx],
        z: &p.z[r * nx..(r + 1) * nx],
    }
}

/// Spring forces of one row, each spring computed once: for the springs that start at row `j`
/// (towards +x, +z, +x+z, and from (i+1, j) towards (i, j+1)), the force on the spring's start;
/// the end feels the opposite. Three components per spring kind.
#[derive(Clone, Debug, Default)]
pub(crate) struct RowSprings {
    /// Structural, (i, j) -> (i+1, j), entries 0..nx-1.
    right: [Vec<Real>; 3],
    /// Structural, (i, j) -> (i, j+1).
    down: [Vec<Real>; 3],
    /// Shear, (i, j) -> (i+1, j+1), entries 0..nx-1.
    diag: [Vec<Real>; 3],
    /// Shear, (i+1, j) -> (i, j+1), entries 0..nx-1.
    anti: [Vec<Real>; 3],
}

impl RowSprings {
    fn new(nx: usize) -> Self {
        let v = || [vec![0.0; nx], vec![0.0; nx], vec![0.0; nx]];
        Self {
            right: v(),
            down: v(),
            diag: v(),
            anti: v(),
        }
    }

    fn out(v: &mut [Vec<Real>; 3]) -> RowMut<'_> {
        let [x, y, z] = v;
        RowMut { x, y, z }
    }

    /// Computes the springs of row `j` (the `right` ones always, the others if a next row
    /// exists).
    fn compute(&mut self, c: &StepConsts<'_>, x: &Soa, j: usize, with_right: bool) {
        let (nx, nz) = (c.grid.nx, c.grid.nz);
        let here = row(x, nx, j);
        let m = nx - 1;
        if with_right {
            spring_forces(
                &mut Self::out(&mut self.right),
                here.slice(0, m),
                here.slice(1, m),
                c.structural,
                c.rest_x,
            );
        }
        if j + 1 < nz {
            let next = row(x, nx, j + 1);
            spring_forces(
                &mut Self::out(&mut self.down),
                here,
                next,
                c.structural,
                c.rest_z,
            );
            spring_forces(
                &mut Self::out(&mut self.diag),
                here.slice(0, m),
                next.slice(1, m),
                c.shear,
                c.rest_diag,
            );
            spring_forces(
                &mut Self::out(&mut self.anti),
                here.slice(1, m),
                next.slice(0, m),
                c.shear,
                c.rest_diag,
            );
        }
    }
}

/// Scratch for [`step_rows`]: the springs of the current and the previous row.
#[derive(Clone, Debug, Default)]
pub(crate) struct StepScratch {
    current: RowSprings,
    previous: RowSprings,
}

impl StepScratch {
    /// Scratch for rows of `nx` particles.
    pub fn new(nx: usize) -> Self {
        Self {
            current: RowSprings::new(nx),
            previous: RowSprings::new(nx),
        }
    }

    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        let row = |r: &RowSprings| {
            [&r.right, &r.down, &r.diag, &r.anti]
                .iter()
                .flat_map(|a| a.iter())
                .map(|v| v.capacity() * std::mem::size_of::<Real>())
                .sum::<usize>()
        };
        row(&self.current) + row(&self.previous)
    }

    /// True if sized for rows of `nx` particles.
    pub fn fits(&self, nx: usize) -> bool {
        self.current.right[0].len() == nx
    }
}

/// Phases 2-3 of the step for the block of rows starting at `j0` (as many rows as `prev`
/// holds): forces, position Verlet, contacts. Reads the current positions of the block and one
/// row around it; `prev` holds the block's previous positions on entry and its new ones on
/// exit (Verlet needs nothing else); `force` receives the forces (N).
///
/// Each spring is evaluated once: a row's springs towards the next row are kept for the next
/// row, and a block that does not start at row 0 first evaluates the row above it again. Every
/// particle adds its terms in the same fixed order whatever the blocks are, so the result does
/// not depend on how the rows are split between threads.
///
/// While the new positions are at hand it also measures them, instead of in passes of their
/// own: `checks[k]` receives [`check_cells`] of rows `j0 + k` and `j0 + k + 1` for the cells
/// inside the block (the last entry, whose next row belongs to the next block, is left for the
/// caller, except on the grid's last row), and the return value is the largest squared
/// distance (m^2) of a new position from `c.reference` (0 without one): the self-collision
/// lists' skin test.
#[allow(clippy::too_many_arguments)] // the row slices of one block, each its own borrow
pub(crate) fn step_rows(
    c: &StepConsts<'_>,
    j0: usize,
    x: &Soa,
    prev: &mut RowMut<'_>,
    force: &mut RowMut<'_>,
    contact: &mut [bool],
    checks: &mut [RowCheck],
    scratch: &mut StepScratch,
) -> Real {
    let mut moved: Real = 0.0;
    let nx = c.grid.nx;
    let rows = prev.x.len() / nx;
    if j0 > 0 {
        scratch.previous.compute(c, x, j0 - 1, false);
    }
    for j in j0..j0 + rows {
        scratch.current.compute(c, x, j, true);
        let r = (j - j0) * nx..(j - j0 + 1) * nx;
        let mut p = RowMut {
            x: &mut prev.x[r.clone()],
            y: &mut prev.y[r.clone()],
            z: &mut prev.z[r.clone()],
        };
        let mut f = RowMut {
            x: &mut force.x[r.clone()],
            y: &mut force.y[r.clone()],
            z: &mut force.z[r.clone()],
        };
        step_row(c, j, x, &mut p, &mut f, &mut contact[r], scratch);
        if let Some(reference) = c.reference {
            moved = moved.max(max_distance2(p.as_ref(), row(reference, nx, j)));
        }
        std::mem::swap(&mut scratch.current, &mut scratch.previous);
        // The cells between the previous row and this one, both new now.
        let (g, r0) = (c.grid, c.radius);
        let new_row = |k: usize| RowRef {
            x: &prev.x[k * nx..(k + 1) * nx],
            y: &prev.y[k * nx..(k + 1) * nx],
            z: &prev.z[k * nx..(k + 1) * nx],
        };
        let k = j - j0;
        if k > 0 {
            checks[k - 1] = check_cells(g, new_row(k - 1), Some(new_row(k)), c.sticking, r0);
        }
        if j + 1 == g.nz {
            checks[k] = check_cells(g, new_row(k), None, c.sticking, r0);
        }
    }
    moved
}

/// Largest squared distance between `a[i]` and `b[i]`, m^2, with lane-wise maxima (it
/// vectorises).
fn max_distance2(a: RowRef<'_>, b: RowRef<'_>) -> Real {
    let n = a.x.len();
    let (bx, by, bz) = (&b.x[..n], &b.y[..n], &b.z[..n]);
    let mut lanes = [0.0 as Real; LANES];
    let full = n - n % LANES;
    for base in (0..full).step_by(LANES) {
        for (l, m) in lanes.iter_mut().enumerate() {
            let i = base + l;
            let (dx, dy, dz) = (a.x[i] - bx[i], a.y[i] - by[i], a.z[i] - bz[i]);
            let d = dx * dx + dy * dy + dz * dz;
            *m = if d > *m { d } else { *m };
        }
    }
    for i in full..n {
        let (dx, dy, dz) = (a.x[i] - bx[i], a.y[i] - by[i], a.z[i] - bz[i]);
        lanes[0] = lanes[0].max(dx * dx + dy * dy + dz * dz);
    }
    lanes.into_iter().fold(0.0, Real::max)
}

/// One row of [`step_rows`], with the row's springs in `scratch.current` and the previous
/// row's in `scratch.previous`.
fn step_row(
    c: &StepConsts<'_>,
    j: usize,
    x: &Soa,
    prev: &mut RowMut<'_>,
    force: &mut RowMut<'_>,
    contact: &mut [bool],
    scratch: &StepScratch,
) {
    let grid = c.grid;
    let (nx, nz) = (grid.nx, grid.nz);
    let here = row(x, nx, j);
    let weight = c.gravity * c.mass;

    // Gravity (eq. 3.3) and velocity damping.
    {
        let (fx, fy, fz) = (&mut force.x[..nx], &mut force.y[..nx], &mut force.z[..nx]);
        let (px, py, pz) = (&prev.x[..nx], &prev.y[..nx], &prev.z[..nx]);
        for i in 0..nx {
            fx[i] = weight.x - c.damp * (here.x[i] - px[i]);
            fy[i] = weight.y - c.damp * (here.y[i] - py[i]);
            fz[i] = weight.z - c.damp * (here.z[i] - pz[i]);
        }
    }

    // Springs (eq. 3.6): as the start of this row's springs, then as the end of the springs of
    // this row (to the left) and of the previous row. Interior particles (the common case) sum
    // all eight in one loop; border rows and columns add the terms they have one by one.
    let (cur, prv) = (&scratch.current, &scratch.previous);
    if j > 0 && j + 1 < nz && nx > 2 {
        add_interior_springs(force, cur, prv);
        for i in [0, nx - 1] {
            add_springs_at(force, cur, prv, i, nx, true, true);
        }
    } else {
        for i in 0..nx {
            add_springs_at(force, cur, prv, i, nx, j + 1 < nz, j > 0);
        }
    }

    // Pressure force (eq. 3.7): (P_b - P_a) S N with N the normal of `Grid::normal`, the cross
    // product of the central differences along z and x (one-sided at the border).
    if c.pressure_area != 0.0 {
        let below = row(x, nx, j.saturating_sub(1));
        let above = row(x, nx, (j + 1).min(nz - 1));
        add_pressure(force, here, below, above, c.pressure_area);
    }

    // Position Verlet (eq. 3.1), written as x + (x - x_prev) + F h: the step is added to x, not
    // to 2x, which halves the round-off for slow particles.
    {
        let (fx, fy, fz) = (&force.x[..nx], &force.y[..nx], &force.z[..nx]);
        let (px, py, pz) = (&mut prev.x[..nx], &mut prev.y[..nx], &mut prev.z[..nx]);
        for i in 0..nx {
            px[i] = here.x[i] + (here.x[i] - px[i]) + fx[i] * c.h;
            py[i] = here.y[i] + (here.y[i] - py[i]) + fy[i] * c.h;
            pz[i] = here.z[i] + (here.z[i] - pz[i]) + fz[i] * c.h;
        }
    }

    // Contacts: normal force and Coulomb friction (eq. 3.4-3.5), see `contact`.
    contact[..nx].fill(false);
    for plane in c.planes {
        plane_contacts(plane, here, prev, &mut contact[..nx]);
    }
    if !c.others.is_empty() {
        for i in 0..nx {
            let now = Vec3::new(here.x[i], here.y[i], here.z[i]);
            let next = Vec3::new(prev.x[i], prev.y[i], prev.z[i]);
            let (next, hit) = contact::resolve(c.others, now, next, c.radius);
            (prev.x[i], prev.y[i], prev.z[i]) = (next.x, next.y, next.z);
            contact[i] |= hit;
        }
    }
}

/// Adds the eight spring forces of every interior particle `1..nx-1` of a row in one pass
/// (see [`step_row`] for the terms; `cur` and `prv` hold this and the previous row's springs).
fn add_interior_springs(f: &mut RowMut<'_>, cur: &RowSprings, prv: &RowSprings) {
    let n = f.x.len() - 2;
    for c in 0..3 {
        let out = match c {
            0 => &mut f.x[1..=n],
            1 => &mut f.y[1..=n],
            _ => &mut f.z[1..=n],
        };
        // Particle i = k + 1: start of right[i], down[i], diag[i], anti[i-1]; end of
        // right[i-1], prev down[i], prev diag[i-1], prev anti[i].
        let (r0, r1) = (&cur.right[c][1..=n], &cur.right[c][..n]);
        let (d, e, w) = (&cur.down[c][1..=n], &cur.diag[c][1..=n], &cur.anti[c][..n]);
        let (pd, pe, pw) = (&prv.down[c][1..=n], &prv.diag[c][..n], &prv.anti[c][1..=n]);
        for k in 0..n {
            out[k] += ((r0[k] - r1[k]) + (d[k] + e[k] + w[k])) - (pd[k] + pe[k] + pw[k]);
        }
    }
}

/// Adds the spring forces of particle `i` of a row, one term at a time: the springs to the
/// next row if `next`, from the previous row if `previous`, and those along the row.
fn add_springs_at(
    f: &mut RowMut<'_>,
    cur: &RowSprings,
    prv: &RowSprings,
    i: usize,
    nx: usize,
    next: bool,
    previous: bool,
) {
    let mut acc = [0.0 as Real; 3];
    for (c, a) in acc.iter_mut().enumerate() {
        if i + 1 < nx {
            *a += cur.right[c][i];
        }
        if i > 0 {
            *a -= cur.right[c][i - 1];
        }
        if next {
            *a += cur.down[c][i];
            if i + 1 < nx {
                *a += cur.diag[c][i];
            }
            if i > 0 {
                *a += cur.anti[c][i - 1];
            }
        }
        if previous {
            *a -= prv.down[c][i];
            if i > 0 {
                *a -= prv.diag[c][i - 1];
            }
            if i + 1 < nx {
                *a -= prv.anti[c][i];
            }
        }
    }
    f.x[i] += acc[0];
    f.y[i] += acc[1];
    f.z[i] += acc[2];
}

/// Adds `pressure_area * N` to every particle of a row, `N` the unit normal from the central
/// differences (rows `below` and `above` are the neighbouring rows, or the row itself at the
/// border).
fn add_pressure(
    force: &mut RowMut<'_>,
    here: RowRef<'_>,
    below: RowRef<'_>,
    above: RowRef<'_>,
    pressure_area: Real,
) {
    let nx = here.x.len();
    let normal = |tx: Vec3, tz: Vec3| {
        let n = tz.cross(tx);
        let len = n.length().max(1e-300);
        n * (pressure_area / len)
    };
    let tz_at = |i: usize| {
        Vec3::new(
            above.x[i] - below.x[i],
            above.y[i] - below.y[i],
            above.z[i] - below.z[i],
        )
    };
    let at = |r: RowRef<'_>, i: usize| Vec3::new(r.x[i], r.y[i], r.z[i]);
    // Border columns: one-sided differences.
    for (i, l, r) in [(0, 0, 1), (nx - 1, nx - 2, nx - 1)] {
        let f = normal(at(here, r) - at(here, l), tz_at(i));
        force.x[i] += f.x;
        force.y[i] += f.y;
        force.z[i] += f.z;
    }
    // Interior: written component-wise over equal-length slices so it vectorises.
    let m = nx - 2;
    let (lx, ly, lz) = (&here.x[..m], &here.y[..m], &here.z[..m]);
    let (rx, ry, rz) = (&here.x[2..], &here.y[2..], &here.z[2..]);
    let (bx, by, bz) = (&below.x[1..=m], &below.y[1..=m], &below.z[1..=m]);
    let (ax, ay, az) = (&above.x[1..=m], &above.y[1..=m], &above.z[1..=m]);
    let (fx, fy, fz) = (
        &mut force.x[1..=m],
        &mut force.y[1..=m],
        &mut force.z[1..=m],
    );
    for k in 0..m {
        let (tx, ty, tw) = (rx[k] - lx[k], ry[k] - ly[k], rz[k] - lz[k]);
        let (sx, sy, sw) = (ax[k] - bx[k], ay[k] - by[k], az[k] - bz[k]);
        // n = tz x tx
        let nxv = sy * tw - sw * ty;
        let nyv = sw * tx - sx * tw;
        let nzv = sx * ty - sy * tx;
        let len = (nxv * nxv + nyv * nyv + nzv * nzv).sqrt().max(1e-300);
        let s = pressure_area / len;
        fx[k] += nxv * s;
        fy[k] += nyv * s;
        fz[k] += nzv * s;
    }
}

/// Contact with one plane for a row, branch-free so it vectorises: the same response as
/// [`contact::resolve`] (projection by the depth, then friction removing at most `mu depth` of
/// the tangential step), computed for every particle with the depth clamped to 0 for those
/// that do not touch.
fn plane_contacts(p: &PlaneContact, here: RowRef<'_>, next: &mut RowMut<'_>, contact: &mut [bool]) {
    let n = here.x.len();
    let (nx, ny, nz) = (p.normal.x, p.normal.y, p.normal.z);
    let (qx, qy, qz) = (&mut next.x[..n], &mut next.y[..n], &mut next.z[..n]);
    for i in 0..n {
        let dist = nx * qx[i] + ny * qy[i] + nz * qz[i] - p.offset;
        let depth = if dist < 0.0 { -dist } else { 0.0 };
        let (mut x, mut y, mut z) = (qx[i] + nx * depth, qy[i] + ny * depth, qz[i] + nz * depth);
        let (dx, dy, dz) = (x - here.x[i], y - here.y[i], z - here.z[i]);
        let dn = dx * nx + dy * ny + dz * nz;
        let (tx, ty, tz) = (dx - nx * dn, dy - ny * dn, dz - nz * dn);
        let slide = (tx * tx + ty * ty + tz * tz).sqrt();
        let grip = p.friction * depth;
        // Share of the tangential step that friction removes: all of it if it can (static),
        // else `grip / slide` (kinetic). Zero when not touching (grip = 0).
        let stop = if slide > grip { grip / slide } else { 1.0 };
        x -= tx * stop;
        y -= ty * stop;
        z -= tz * stop;
        (qx[i], qy[i], qz[i]) = (x, y, z);
        contact[i] |= depth > 0.0;
    }
}

/// What [`check_row`] measures of one row.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct RowCheck {
    /// Eq. 3.10 over the cells between this row and the next, m^3.
    pub volume: Real,
    /// Largest (length / rest length)^2 of the row's structural springs (right and down).
    pub stretch2: Real,
    /// NaN or infinite if any position of the row is.
    pub finite_probe: Real,
}

/// Lanes of the reductions in [`check_row`]: independent partial sums and maxima the compiler
/// keeps in vector registers (a single running sum would be one long dependency chain). The
/// lanes are combined in a fixed order, so the result does not depend on threads either.
const LANES: usize = 8;

/// Phase 6 for row `j`: its share of the bubble volume (eq. 3.10; `plane` = (point, up),
/// heights minus `offset`; the xz plane through the origin when there is no sticking plane, so
/// the non-finite probe still works) and the blow-up measures, in one pass over the cells
/// between row `j` and the next.
///
/// A NaN or infinite coordinate makes the volume NaN (every particle belongs to a cell), and
/// every structural spring is an edge of a cell: `b - a` (along x), `d - a` and `c - b` (along
/// z); only the last row's springs along x are measured apart.
pub(crate) fn check_row(
    grid: &Grid,
    x: &Soa,
    j: usize,
    plane: Option<(Vec3, Vec3)>,
    offset: Real,
) -> RowCheck {
    let next = (j + 1 < grid.nz).then(|| row(x, grid.nx, j + 1));
    check_cells(grid, row(x, grid.nx, j), next, plane, offset)
}

/// [`check_row`] for the cells between row `a` and the next row `b` (`None` for the last row).
pub(crate) fn check_cells(
    grid: &Grid,
    a: RowRef<'_>,
    b: Option<RowRef<'_>>,
    plane: Option<(Vec3, Vec3)>,
    offset: Real,
) -> RowCheck {
    let nx = grid.nx;
    let m = nx - 1;
    let (irx, irz) = (1.0 / (grid.dx * grid.dx), 1.0 / (grid.dz * grid.dz));
    let Some(b) = b else {
        // Last row: no cells; its springs along x and its finiteness.
        let mut worst: Real = 0.0;
        let mut probe: Real = 0.0;
        for i in 0..m {
            let (dx, dy, dz) = (
                a.x[i + 1] - a.x[i],
                a.y[i + 1] - a.y[i],
                a.z[i + 1] - a.z[i],
            );
            worst = worst.max((dx * dx + dy * dy + dz * dz) * irx);
            probe += (a.x[i] + a.y[i] + a.z[i]) * 0.0;
        }
        return RowCheck {
            volume: 0.0,
            stretch2: worst,
            finite_probe: probe + (a.x[m] + a.y[m] + a.z[m]) * 0.0,
        };
    };
    let (origin, up) = plane.unwrap_or((Vec3::ZERO, Vec3::Y));
    let h0 = up.dot(origin) + offset;

    // Cell i has corners a = (i, j), b = (i+1, j), c = (i+1, j+1), d = (i, j+1), split as in
    // `Grid::triangles` into (a, c, b) and (a, d, c): eq. 3.10 gives the signed prism volumes
    // U.((c-a) x (b-a))/2 * (ha+hc+hb)/3 + U.((d-a) x (c-a))/2 * (ha+hd+hc)/3.
    // Cells are processed in chunks of `CHUNK`: a branch-free loop over equal-length slices
    // writes each cell's volume and stretch to small buffers (it vectorises), then lane-wise
    // sums and maxima reduce them.
    const CHUNK: usize = 64;
    let [ux, uy, uz] = [up.x, up.y, up.z];
    let mut vol = [0.0 as Real; LANES];
    let mut worst = [0.0 as Real; LANES];
    let (mut vbuf, mut sbuf) = ([0.0 as Real; CHUNK], [0.0 as Real; CHUNK]);
    for start in (0..m).step_by(CHUNK) {
        let n = CHUNK.min(m - start);
        let r = start..start + n;
        let r1 = start + 1..start + 1 + n;
        let (ax, ay, az) = (&a.x[r.clone()], &a.y[r.clone()], &a.z[r.clone()]);
        let (bx, by, bz) = (&a.x[r1.clone()], &a.y[r1.clone()], &a.z[r1.clone()]);
        let (cx, cy, cz) = (&b.x[r1.clone()], &b.y[r1.clone()], &b.z[r1]);
        let (dx, dy, dz) = (&b.x[r.clone()], &b.y[r.clone()], &b.z[r]);
        let (vb, sb) = (&mut vbuf[..n], &mut sbuf[..n]);
        for k in 0..n {
            let ha = ux * ax[k] + uy * ay[k] + uz * az[k] - h0;
            let hb = ux * bx[k] + uy * by[k] + uz * bz[k] - h0;
            let hc = ux * cx[k] + uy * cy[k] + uz * cz[k] - h0;
            let hd = ux * dx[k] + uy * dy[k] + uz * dz[k] - h0;
            // Edges from a (to b, c, d), and from b to c.
            let (ebx, eby, ebz) = (bx[k] - ax[k], by[k] - ay[k], bz[k] - az[k]);
            let (ecx, ecy, ecz) = (cx[k] - ax[k], cy[k] - ay[k], cz[k] - az[k]);
            let (edx, edy, edz) = (dx[k] - ax[k], dy[k] - ay[k], dz[k] - az[k]);
            let (eex, eey, eez) = (cx[k] - bx[k], cy[k] - by[k], cz[k] - bz[k]);
            // U . (c x b) and U . (d x c).
            let acb = ux * (ecy * ebz - ecz * eby)
                + uy * (ecz * ebx - ecx * ebz)
                + uz * (ecx * eby - ecy * ebx);
            let adc = ux * (edy * ecz - edz * ecy)
                + uy * (edz * ecx - edx * ecz)
                + uz * (edx * ecy - edy * ecx);
            vb[k] = acb * (ha + hc + hb) + adc * (ha + hd + hc);
            let sx = (ebx * ebx + eby * eby + ebz * ebz) * irx;
            let sd = (edx * edx + edy * edy + edz * edz) * irz;
            let se = (eex * eex + eey * eey + eez * eez) * irz;
            let sz = if sd > se { sd } else { se };
            sb[k] = if sx > sz { sx } else { sz };
        }
        for (vc, sc) in vb.chunks(LANES).zip(sb.chunks(LANES)) {
            for l in 0..vc.len() {
                vol[l] += vc[l];
                worst[l] = if sc[l] > worst[l] { sc[l] } else { worst[l] };
            }
        }
    }
    let volume = vol.into_iter().sum::<Real>() / 6.0;
    RowCheck {
        volume: if plane.is_some() { volume } else { 0.0 },
        stretch2: worst.into_iter().fold(0.0, Real::max),
        finite_probe: volume * 0.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::ClothParams;

    /// The vectorised pressure force is `pressure_area` times the normal `Grid::normal`
    /// defines, border rows and columns included, on a crumpled cloth.
    #[test]
    fn row_pressure_matches_the_grid_normal() {
        let grid = Grid::new(&ClothParams {
            resolution: [7, 5],
            ..Default::default()
        });
        let mut p = grid.rest_positions(Vec3::ZERO);
        for k in 0..grid.len() {
            let s = k as Real;
            p.y[k] += 0.01 * (0.9 * s).sin();
            p.x[k] += 0.002 * (1.7 * s).cos();
        }
        let nx = grid.nx;
        for j in 0..grid.nz {
            let (mut fx, mut fy, mut fz) = (vec![0.0; nx], vec![0.0; nx], vec![0.0; nx]);
            let mut f = RowMut {
                x: &mut fx,
                y: &mut fy,
                z: &mut fz,
            };
            let below = row(&p, nx, j.saturating_sub(1));
            let above = row(&p, nx, (j + 1).min(grid.nz - 1));
            add_pressure(&mut f, row(&p, nx, j), below, above, -3.5);
            for i in 0..nx {
                let expect = grid.normal(&p, grid.index(i, j)) * -3.5;
                let got = Vec3::new(fx[i], fy[i], fz[i]);
                assert!(
                    (got - expect).length() < 1e-12,
                    "({i}, {j}): {got} vs {expect}"
                );
            }
        }
    }

    /// The vectorised eq. 3.10 agrees with the reference `air::volume` on a crumpled cloth.
    #[test]
    fn row_volume_matches_the_reference() {
        let grid = Grid::new(&ClothParams {
            resolution: [9, 7],
            ..Default::default()
        });
        let mut p = grid.rest_positions(Vec3::new(0.1, 0.02, 0.0));
        for k in 0..grid.len() {
            let s = k as Real;
            p.x[k] += 0.003 * (1.3 * s).sin();
            p.y[k] += 0.01 * (0.7 * s).cos();
            p.z[k] += 0.002 * (2.1 * s).sin();
        }
        let up = Vec3::new(0.1, 1.0, -0.2).normalize();
        let plane = (Vec3::new(0.0, -0.01, 0.0), up);
        let reference = crate::air::volume(&grid, &p, plane, 0.001);
        let fast: Real = (0..grid.nz)
            .map(|j| check_row(&grid, &p, j, Some(plane), 0.001).volume)
            .sum();
        assert!(
            (fast - reference).abs() < 1e-14 * reference.abs(),
            "{fast} vs {reference}"
        );
    }
}
