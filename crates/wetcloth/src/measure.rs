//! What a step measures of its new state, in one pass over the cells: the gap volume under
//! them (eq. 3.10, for the air model) and the blow-up measures (for the blow-up checks, `checks.rs`).
//!
//! The two are measured together because they read the same corners: the fused Verlet pass
//! measures each block of rows right after moving it, while the positions are in cache, and
//! only re-measures rows that a later phase moved. Reductions run in lanes combined in a fixed
//! order, and rows are summed in row order, so the result does not depend on threads.

use crate::air::gap::cell_volume6;
use crate::collide::StickingPlane;
use crate::math::{Real, RowRef, Soa, Vec3, row};
use crate::model::{Grid, Layout};
use rayon::prelude::*;

/// Lanes of the reductions: independent partial sums and maxima the compiler keeps in vector
/// registers (a single running sum would be one long dependency chain). The lanes are combined
/// in a fixed order, so the result does not depend on threads either.
pub(crate) const LANES: usize = 8;

/// What [`cells`] measures of the cells between one row and the next.
#[derive(Clone, Copy, Debug, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub(crate) struct CellMeasures {
    /// Eq. 3.10 over the cells, m^3 (0 without a sticking plane).
    pub volume: Real,
    /// Largest (length / rest length)^2 of the row's structural springs (along x, and towards
    /// the next row).
    pub stretch2: Real,
    /// NaN or infinite if any position of the row is.
    pub finite_probe: Real,
}

/// The measures of the cells between row `a` and the next row `b` (`None` for the last row:
/// its springs along x and its finiteness only). Heights are taken above `plane` minus
/// `offset` (m, the particle radius); without a plane the volume is 0, and the xz plane through
/// the origin still serves the finiteness probe.
///
/// A NaN or infinite coordinate makes the volume NaN (every particle belongs to a cell), and
/// every structural spring is an edge of a cell: `b - a` (along x), `d - a` and `c - b` (along
/// z); only the last row's springs along x are measured apart.
pub(crate) fn cells(
    grid: &Grid,
    a: RowRef<'_>,
    b: Option<RowRef<'_>>,
    plane: Option<StickingPlane>,
    offset: Real,
    cell_volumes: Option<&mut [Real]>,
) -> CellMeasures {
    let nx = grid.nx;
    let m = nx - 1;
    let (irx, irz) = (1.0 / (grid.dx * grid.dx), 1.0 / (grid.dz * grid.dz));
    let Some(b) = b else {
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
        return CellMeasures {
            volume: 0.0,
            stretch2: worst,
            finite_probe: probe + (a.x[m] + a.y[m] + a.z[m]) * 0.0,
        };
    };
    let (origin, up) = plane.map_or((Vec3::ZERO, Vec3::Y), |p| (p.point, p.up));
    let h0 = up.dot(origin) + offset;

    // Cell i has corners a = (i, j), b = (i+1, j), c = (i+1, j+1), d = (i, j+1). Cells are
    // processed in chunks of `CHUNK`: a branch-free loop over equal-length slices writes each
    // cell's volume and stretch to small buffers (it vectorises), then lane-wise sums and
    // maxima reduce them.
    const CHUNK: usize = 64;
    let [ux, uy, uz] = [up.x, up.y, up.z];
    let mut cell_volumes = cell_volumes;
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
            vb[k] = cell_volume6(
                [ux, uy, uz],
                [ha, hb, hc, hd],
                [ebx, eby, ebz],
                [ecx, ecy, ecz],
                [edx, edy, edz],
            );
            let sx = (ebx * ebx + eby * eby + ebz * ebz) * irx;
            let sd = (edx * edx + edy * edy + edz * edz) * irz;
            let se = (eex * eex + eey * eey + eez * eez) * irz;
            let sz = if sd > se { sd } else { se };
            sb[k] = if sx > sz { sx } else { sz };
        }
        if let Some(out) = cell_volumes.as_deref_mut() {
            for (o, v) in out[start..start + n].iter_mut().zip(vb.iter()) {
                *o = v / 6.0;
            }
        }
        for (vc, sc) in vb.chunks(LANES).zip(sb.chunks(LANES)) {
            for l in 0..vc.len() {
                vol[l] += vc[l];
                worst[l] = if sc[l] > worst[l] { sc[l] } else { worst[l] };
            }
        }
    }
    let volume = vol.into_iter().sum::<Real>() / 6.0;
    CellMeasures {
        volume: if plane.is_some() { volume } else { 0.0 },
        stretch2: worst.into_iter().fold(0.0, Real::max),
        finite_probe: volume * 0.0,
    }
}

/// [`cells`] between row `j` of `x` and the next.
pub(crate) fn row_cells(
    grid: &Grid,
    x: &Soa,
    j: usize,
    plane: Option<StickingPlane>,
    offset: Real,
    cell_volumes: Option<&mut [Real]>,
) -> CellMeasures {
    let next = (j + 1 < grid.nz).then(|| row(x, grid.nx, j + 1));
    cells(grid, row(x, grid.nx, j), next, plane, offset, cell_volumes)
}

/// Triangles (or springs, or particles) per task of the mesh's measures on the pool.
const MESH_TASK: usize = 4096;

/// The measures of a mesh cloth at `x`: eq. 3.10 over its triangles (summed in triangle
/// order), the largest `(length / rest length)^2` of a spring along an edge, and the
/// finiteness probe; each triangle's own gap volume into `volumes` (one per triangle), each
/// particle's height above the plane into `heights` (m, one per particle). On the
/// pool if `parallel`: each triangle's volume is its own, the sum runs in triangle order after
/// them and the largest stretch and the probe do not depend on the order they are taken in, so
/// the result has the same bits on any number of threads.
pub(crate) fn mesh_cells(
    layout: Layout<'_>,
    x: &Soa,
    plane: Option<StickingPlane>,
    offset: Real,
    volumes: &mut [Real],
    heights: &mut [Real],
    parallel: bool,
) -> CellMeasures {
    let Layout::Mesh(mesh, springs) = layout else {
        return CellMeasures::default();
    };
    let mut volume = 0.0;
    if let Some(p) = plane {
        // Each particle's height once, then each triangle's prism (eq. 3.10).
        let up = p.up;
        let h0 = up.dot(p.point) + offset;
        let height = |k0: usize, out: &mut [Real]| {
            let (xs, ys, zs) = (&x.x[k0..], &x.y[k0..], &x.z[k0..]);
            for (i, h) in out.iter_mut().enumerate() {
                *h = up.x * xs[i] + up.y * ys[i] + up.z * zs[i] - h0;
            }
        };
        let heights = &mut heights[..x.len()];
        crate::exec::by_chunks(heights, MESH_TASK, parallel, height);
        let heights = &*heights;
        let prism = |t0: usize, out: &mut [Real]| {
            for (o, &[a, b, c]) in out.iter_mut().zip(&mesh.triangles[t0..]) {
                let (a, b, c) = (a as usize, b as usize, c as usize);
                let (pa, pb, pc) = (x.get(a), x.get(b), x.get(c));
                *o =
                    0.5 * up.dot((pb - pa).cross(pc - pa)) * (heights[a] + heights[b] + heights[c])
                        / 3.0;
            }
        };
        crate::exec::by_chunks(volumes, MESH_TASK, parallel, prism);
        for &v in volumes.iter() {
            volume += v;
        }
    }
    let (stretch2, probe) = if parallel {
        rayon::join(
            || springs.max_stretch2_parallel(x, MESH_TASK),
            || finite_probe(x, true),
        )
    } else {
        (springs.max_stretch2(x), finite_probe(x, false))
    };
    CellMeasures {
        volume,
        stretch2,
        finite_probe: probe + volume * 0.0,
    }
}

/// 0 if every coordinate of `x` is finite, NaN if one is not; on the pool if `parallel`.
fn finite_probe(x: &Soa, parallel: bool) -> Real {
    let probe = |v: &[Real]| {
        let mut lanes = [0.0; LANES];
        let mut chunks = v.chunks_exact(LANES);
        for c in &mut chunks {
            for (l, &v) in lanes.iter_mut().zip(c) {
                *l += v * 0.0;
            }
        }
        chunks.remainder().iter().map(|&v| v * 0.0).sum::<Real>() + lanes.iter().sum::<Real>()
    };
    let of = |v: &[Real]| {
        if parallel {
            v.par_chunks(MESH_TASK).map(probe).sum::<Real>()
        } else {
            probe(v)
        }
    };
    // Finite coordinates add zeros; one NaN or infinity makes the sum NaN.
    let p = of(&x.x) + of(&x.y) + of(&x.z);
    if p.is_nan() { Real::NAN } else { 0.0 }
}

/// The measures of every row of cells of a state: row `j` holds the cells between rows `j`
/// and `j + 1`; and, when kept, each cell's own gap volume.
#[derive(Clone, Debug, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub(crate) struct Measures {
    pub rows: Vec<CellMeasures>,
    /// Gap volume of each cell (eq. 3.10 over its two triangles), m^3, cell `(i, j)` at
    /// `j * (nx - 1) + i` (one row per grid row, the last unused, so blocks of rows split it
    /// evenly); written only if `keep_cells`.
    pub cells: Vec<Real>,
    /// Whether the measures keep each cell's volume (the pockets model needs them).
    pub keep_cells: bool,
    /// A mesh cloth's triangles' gap volumes when the cells' are not kept (m^3), then its
    /// particles' heights (m): scratch.
    #[cfg_attr(feature = "serde", serde(skip))]
    pub scratch: Vec<Real>,
}

/// The sums of [`Measures`].
#[derive(Clone, Copy, Debug)]
pub(crate) struct Totals {
    /// Gap volume, m^3.
    pub volume: Real,
    /// Largest (length / rest length)^2 of a structural spring.
    pub stretch2: Real,
    /// Whether every position is finite.
    pub finite: bool,
}

impl Measures {
    /// Room for the measures of `layout`: the grid's rows, or a mesh's one (all its triangles,
    /// each a cell), keeping each cell's volume if `keep_cells`.
    pub fn for_layout(layout: Layout<'_>, keep_cells: bool) -> Self {
        match layout {
            Layout::Grid(grid) => Self::for_grid(grid, keep_cells),
            Layout::Mesh(mesh, _) => Self {
                rows: vec![CellMeasures::default(); 1],
                cells: vec![0.0; mesh.triangles.len()],
                keep_cells,
                scratch: Vec::new(),
            },
        }
    }

    /// Re-measures everything of a mesh cloth (one row) from `x`.
    pub fn remeasure_mesh(
        &mut self,
        layout: Layout<'_>,
        x: &Soa,
        plane: Option<StickingPlane>,
        offset: Real,
        parallel: bool,
    ) {
        // Each triangle's volume (into `cells` only when kept: a checkpoint stores them), and
        // each particle's height.
        let triangles = if self.keep_cells { 0 } else { self.cells.len() };
        self.scratch.resize(triangles + x.len(), 0.0);
        let (volumes, heights) = self.scratch.split_at_mut(triangles);
        let volumes = if self.keep_cells {
            &mut self.cells[..]
        } else {
            volumes
        };
        self.rows[0] = mesh_cells(layout, x, plane, offset, volumes, heights, parallel);
    }

    /// Re-measures every row of `layout` from `x` ([`Measures::remeasure_all`] on the grid).
    pub fn remeasure_layout(
        &mut self,
        layout: Layout<'_>,
        x: &Soa,
        plane: Option<StickingPlane>,
        offset: Real,
        parallel: Option<usize>,
    ) {
        match layout {
            Layout::Grid(grid) => self.remeasure_all(grid, x, plane, offset, parallel),
            Layout::Mesh(..) => self.remeasure_mesh(layout, x, plane, offset, parallel.is_some()),
        }
    }

    /// Room for the rows of `grid`, keeping each cell's volume if `keep_cells`.
    pub fn for_grid(grid: &Grid, keep_cells: bool) -> Self {
        Self {
            rows: vec![CellMeasures::default(); grid.nz],
            cells: vec![0.0; (grid.nx - 1) * grid.nz],
            keep_cells,
            scratch: Vec::new(),
        }
    }

    /// Re-measures the cells of row `j` from `x`.
    pub fn remeasure_row(
        &mut self,
        grid: &Grid,
        x: &Soa,
        j: usize,
        plane: Option<StickingPlane>,
        offset: Real,
    ) {
        let m = grid.nx - 1;
        let cells =
            (self.keep_cells && j + 1 < grid.nz).then(|| &mut self.cells[j * m..(j + 1) * m]);
        self.rows[j] = row_cells(grid, x, j, plane, offset, cells);
    }

    /// Re-measures every row from `x`, `rows_per_task` rows to a task on the pool if
    /// `parallel`.
    pub fn remeasure_all(
        &mut self,
        grid: &Grid,
        x: &Soa,
        plane: Option<StickingPlane>,
        offset: Real,
        parallel: Option<usize>,
    ) {
        if self.keep_cells {
            // With each cell's volume: row by row on this thread (pockets only).
            for j in 0..grid.nz {
                self.remeasure_row(grid, x, j, plane, offset);
            }
            return;
        }
        let measure = |(j, out): (usize, &mut CellMeasures)| {
            *out = row_cells(grid, x, j, plane, offset, None);
        };
        match parallel {
            Some(rows) => self
                .rows
                .par_iter_mut()
                .enumerate()
                .with_min_len(rows)
                .for_each(measure),
            None => self.rows.iter_mut().enumerate().for_each(measure),
        }
    }

    /// The rows summed in row order.
    pub fn totals(&self) -> Totals {
        let mut stretch2: Real = 0.0;
        let mut finite = true;
        for r in &self.rows {
            if !r.finite_probe.is_finite() || r.stretch2.is_nan() {
                finite = false;
            }
            stretch2 = stretch2.max(r.stretch2);
        }
        Totals {
            volume: self.rows.iter().map(|r| r.volume).sum(),
            stretch2,
            finite,
        }
    }

    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        self.rows.capacity() * std::mem::size_of::<CellMeasures>()
            + (self.cells.capacity() + self.scratch.capacity()) * std::mem::size_of::<Real>()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::ClothParams;

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
        let plane = StickingPlane {
            point: Vec3::new(0.0, -0.01, 0.0),
            up,
        };
        let reference = crate::air::volume(&grid, &p, plane, 0.001);
        let fast: Real = (0..grid.nz)
            .map(|j| row_cells(&grid, &p, j, Some(plane), 0.001, None).volume)
            .sum();
        assert!(
            (fast - reference).abs() < 1e-14 * reference.abs(),
            "{fast} vs {reference}"
        );
    }

    /// A NaN anywhere and an over-stretched spring are seen.
    #[test]
    fn non_finite_positions_and_stretch_are_measured() {
        let grid = Grid::new(&ClothParams {
            resolution: [5, 4],
            ..Default::default()
        });
        let mut p = grid.rest_positions(Vec3::ZERO);
        let mut m = Measures::for_grid(&grid, false);
        m.remeasure_all(&grid, &p, None, 0.0, None);
        let t = m.totals();
        assert!(t.finite && (t.stretch2 - 1.0).abs() < 1e-12);
        p.x[grid.index(4, 3)] += 2.0 * grid.dx; // the last row's last spring: 3 rest lengths
        m.remeasure_all(&grid, &p, None, 0.0, None);
        assert!((m.totals().stretch2 - 9.0).abs() < 1e-9);
        p.y[grid.index(2, 3)] = Real::NAN;
        m.remeasure_all(&grid, &p, None, 0.0, None);
        assert!(!m.totals().finite);
    }

    /// A mesh cloth's measures on the pool (more triangles than one task takes) have the bits
    /// of the same measures on one thread and of the sums written out here in triangle order:
    /// the gap volume (eq. 3.10), the largest stretch and the finiteness; a NaN shows in both.
    #[test]
    fn mesh_measures_on_the_pool_have_the_bits_of_one_thread() {
        use crate::forces::mesh_spring::MeshSprings;
        use crate::model::ClothMesh;
        let grid = Grid::new(&ClothParams {
            resolution: [80, 70],
            ..Default::default()
        });
        let rest = grid.rest_positions(Vec3::ZERO).to_vec3();
        let mesh = ClothMesh::new(rest, grid.triangles()).unwrap();
        assert!(mesh.triangles.len() > 2 * MESH_TASK);
        let springs = MeshSprings::new(&mesh, 500.0, 125.0);
        let layout = Layout::Mesh(&mesh, &springs);
        let mut p = grid.rest_positions(Vec3::new(0.0, 0.004, 0.0));
        for k in 0..p.len() {
            let s = k as Real;
            p.x[k] += 0.0004 * (1.3 * s).sin();
            p.y[k] += 0.003 * (0.07 * s).cos();
            p.z[k] += 0.0003 * (2.1 * s).sin();
        }
        let plane = StickingPlane {
            point: Vec3::ZERO,
            up: Vec3::new(0.05, 1.0, -0.1).normalize(),
        };
        let measure = |p: &Soa, threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| {
                let mut m = Measures::for_layout(layout, false);
                m.remeasure_mesh(layout, p, Some(plane), 0.001, threads > 1);
                m.rows[0]
            })
        };
        let (one, two) = (measure(&p, 1), measure(&p, 2));
        assert_eq!(one.volume.to_bits(), two.volume.to_bits());
        assert_eq!(one.stretch2.to_bits(), two.stretch2.to_bits());
        assert_eq!(one.finite_probe.to_bits(), 0.0f64.to_bits());
        assert_eq!(two.finite_probe.to_bits(), 0.0f64.to_bits());
        // Eq. 3.10 summed here in triangle order, and the largest stretch of an edge.
        let h = |k: usize| plane.up.dot(p.get(k) - plane.point) - 0.001;
        let mut volume = 0.0;
        for &[a, b, c] in &mesh.triangles {
            let (a, b, c) = (a as usize, b as usize, c as usize);
            let (pa, pb, pc) = (p.get(a), p.get(b), p.get(c));
            volume += 0.5 * plane.up.dot((pb - pa).cross(pc - pa)) * (h(a) + h(b) + h(c)) / 3.0;
        }
        assert!(
            (one.volume - volume).abs() <= 1e-12 * volume.abs(),
            "{} vs {volume}",
            one.volume
        );
        let stretch = (0..springs.edge_count)
            .map(|s| {
                let [a, b] = springs.ends[s];
                let l = (p.get(b as usize) - p.get(a as usize)).length() / springs.rest[s];
                l * l
            })
            .fold(0.0, Real::max);
        assert!(
            (one.stretch2 - stretch).abs() < 1e-12,
            "{} vs {stretch}",
            one.stretch2
        );
        assert!(stretch > 1.0 + 1e-6, "the test stretches some edge");
        // A NaN in the last task's particles.
        let last = p.len() - 3;
        p.z[last] = Real::NAN;
        for threads in [1, 2] {
            let m = measure(&p, threads);
            assert!(m.volume.is_nan() && m.stretch2.is_nan() && m.finite_probe.is_nan());
        }
    }
}
