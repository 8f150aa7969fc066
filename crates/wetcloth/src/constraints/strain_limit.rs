//! Strain limiting after Provot (1995), "Deformation constraints in a mass-spring model to
//! describe rigid cloth behavior" (the thesis' reference \[2\]).
//!
//! After the step, every structural or shear spring longer than `(1 + limit)` times its rest
//! length is shortened back to that length by moving its two ends towards each other (a
//! grabbed end does not move; the other takes the whole correction). The corrections are
//! computed Jacobi-style from the same positions and then applied, so each pass is independent
//! of order and thread count; a few passes settle chains of over-stretched springs.

use crate::math::{Real, Soa, Vec3};
use crate::model::{Grid, STENCIL};

/// Applies `iterations` Jacobi passes of the strain limiter with relative limit `limit` to `p`.
/// `scratch` must hold as many vectors as `p`. Returns the number of springs corrected in the
/// first pass.
pub fn limit_strain(
    grid: &Grid,
    p: &mut Soa,
    scratch: &mut Soa,
    fixed: &[bool],
    limit: Real,
    iterations: usize,
) -> usize {
    let mut first = 0;
    let rest: [Real; 8] = STENCIL.map(|n| grid.rest_length(n) * (1.0 + limit));
    for it in 0..iterations {
        let pr = &*p;
        let corrected = crate::exec::jacobi(scratch, |k| {
            let mut corr = Vec3::ZERO;
            let mut count = 0;
            if !fixed[k] {
                let (i, j) = ((k % grid.nx) as isize, (k / grid.nx) as isize);
                let pk = pr.get(k);
                for (n, &max_len) in STENCIL.iter().zip(&rest) {
                    let (a, b) = (i + n.di, j + n.dj);
                    if a < 0 || b < 0 || a >= grid.nx as isize || b >= grid.nz as isize {
                        continue;
                    }
                    let o = grid.index(a as usize, b as usize);
                    let d = pr.get(o) - pk;
                    let len = d.length();
                    if len > max_len {
                        count += 1;
                        let share = if fixed[o] { 1.0 } else { 0.5 };
                        corr += d * (share * (len - max_len) / len);
                    }
                }
            }
            (corr, count)
        });
        if it == 0 {
            first = corrected;
        }
        if corrected == 0 {
            break;
        }
        crate::exec::add_assign(p, scratch);
    }
    first
}
