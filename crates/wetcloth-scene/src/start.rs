//! A cloth must start clear of every collider (and within 1e4 m of its sticking plane, the
//! first plane, which the air under it is measured from): checked before a run, so that such a scene is refused at the collider's line
//! instead of running into absurd results.
//!
//! Contact removes a penetration in one step by moving the particle out (the normal force of
//! thesis eq. 3.4 as a projection), and position Verlet turns that move into a velocity:
//! a cloth that starts `depth` inside a collider leaves it at `depth / time_step`. A plane
//! 10 km above the cloth flung it 2000 km with 1.4e14 J, a flipped plane normal launched it at
//! 33 m/s, and inside a sphere or a box the run stopped with a misleading "try a smaller
//! time_step"; a plane point at 1e300 gave infinite energies with exit status 0.
//!
//! Particles are spheres of the cloth's particle radius, so "clear" means every particle's
//! centre at least that radius from every collider's surface, at the rest positions of the
//! flat starting grid. The deepest particle of a plane is a corner of the cloth (distance to
//! a plane is linear); of a sphere or a box, the grid point nearest the centre (distance grows
//! with the offset along each axis of the flat grid). So the check costs nothing, whatever
//! the resolution.

use wetcloth::collide::{Cuboid, Plane, Sphere};
use wetcloth::{Grid, Real, Shape, SimConfig, Vec3};

/// Penetration tolerated at the start, m: round-off of a cloth placed exactly on a surface
/// (a particle radius above it), far below anything contact would turn into motion.
const TOLERANCE: Real = 1e-9;

/// Farthest the cloth may start above its sticking plane (the first plane), m (the range of
/// `cloth.position`): beyond it the air under the cloth is not a bubble, and its volume
/// overflows.
pub const MAX_BUBBLE_HEIGHT: Real = 1e4;

/// The cloth's starting position of particle `(i, j)`, as `Grid::rest_positions` places it.
fn rest_position(grid: &Grid, centre: Vec3, i: usize, j: usize) -> Vec3 {
    let (w, d) = (
        grid.dx * (grid.nx - 1) as Real,
        grid.dz * (grid.nz - 1) as Real,
    );
    centre
        + Vec3::new(
            i as Real * grid.dx - 0.5 * w,
            0.0,
            j as Real * grid.dz - 0.5 * d,
        )
}

/// The grid index along one axis nearest to offset `x` from the first particle, and its
/// neighbours.
fn nearest(x: Real, spacing: Real, n: usize) -> impl Iterator<Item = usize> {
    let k = (x / spacing).round().clamp(0.0, (n - 1) as Real) as usize;
    k.saturating_sub(1)..=(k + 1).min(n - 1)
}

/// A cloth that starts inside a collider, or too far from its sticking plane.
#[derive(Clone, Debug, PartialEq)]
pub struct StartProblem {
    /// Index of the collider in the scene's `[[collider]]` list.
    pub collider: usize,
    /// The key to point at: `point`, `normal`, `center`, `radius` or `half_extents`.
    pub key: &'static str,
    /// What is wrong, in words.
    pub message: String,
}

/// Checks where the cloth of `config` starts against its colliders; `given(i, key)` says
/// whether the file writes `key` of collider `i` (to blame a written key over a default).
pub fn check(config: &SimConfig, given: impl Fn(usize, &str) -> bool) -> Result<(), StartProblem> {
    let cloth = &config.cloth;
    if let Some(mesh) = &cloth.mesh {
        return check_mesh(config, &mesh.placed(cloth.position));
    }
    let grid = Grid::new(cloth);
    let radius = cloth.particle_radius();
    let dt = config.simulation.time_step;
    let (nx, nz) = (grid.nx, grid.nz);
    let corners = [(0, 0), (nx - 1, 0), (0, nz - 1), (nx - 1, nz - 1)];
    let origin = rest_position(&grid, cloth.position, 0, 0);
    // The first plane: the sticking surface of the air force, and where the air under the
    // cloth is measured from (air_volume) even with the force off.
    let sticking = config.colliders.iter().position(|c| c.as_plane().is_some());

    for (index, collider) in config.colliders.iter().enumerate() {
        // Where a moving collider is at the start.
        let collider = &collider.at(0.0);
        let candidates: Vec<(usize, usize)> = match &collider.shape {
            Shape::Plane(_) => corners.to_vec(),
            // Any particle may be the deepest in a mesh: all of them.
            Shape::Mesh(_) => (0..nx).flat_map(|i| (0..nz).map(move |j| (i, j))).collect(),
            Shape::Sphere(Sphere { center, .. }) | Shape::Box(Cuboid { center, .. }) => {
                let off = *center - origin;
                nearest(off.x, grid.dx, nx)
                    .flat_map(|i| nearest(off.z, grid.dz, nz).map(move |j| (i, j)))
                    .collect()
            }
        };
        // The particle deepest inside (smallest signed distance of its centre).
        let (d, (i, j), p) = candidates
            .iter()
            .map(|&(i, j)| {
                let p = rest_position(&grid, cloth.position, i, j);
                (collider.distance(p).0, (i, j), p)
            })
            .min_by(|a, b| a.0.total_cmp(&b.0))
            .expect("a grid has corners");
        let depth = radius - d;
        let what = collider.shape_name();
        if !d.is_finite() || depth > TOLERANCE * (1.0 + p.abs().max_element()) {
            let far = if d.is_finite() {
                format!("{} inside its surface", length(depth))
            } else {
                "an unmeasurable distance inside it".to_string()
            };
            let mut message = format!(
                "the cloth starts inside this {what}: particle ({i}, {j}) at {} is {far} \
                 (counting the particles' collision radius of {}); a cloth must start clear of \
                 every collider, or contact throws it out at about {} in the first step; move \
                 the {what} or cloth.position",
                point(p),
                length(radius),
                speed(depth / dt),
            );
            let mut key = match collider.shape {
                Shape::Plane(_) => "point",
                Shape::Mesh(_) => "position",
                _ => "center",
            };
            if let Shape::Plane(Plane { point: q, normal }) = collider.shape {
                // Just behind a plane whose flipped normal would clear the cloth: a written
                // normal is the likely mistake (far behind, the point is).
                let flipped_clear = corners.iter().all(|&(i, j)| {
                    (rest_position(&grid, cloth.position, i, j) - q).dot(-normal) >= radius
                });
                let near = depth <= cloth.size[0].max(cloth.size[1]);
                if flipped_clear && given(index, "normal") && (near || !given(index, "point")) {
                    key = "normal";
                    message = format!(
                        "the cloth starts behind this plane, inside its solid: particle ({i}, \
                         {j}) at {} is {far} (counting the particles' collision radius of {}), \
                         and contact would throw it out at about {} in the first step; the \
                         normal points out of the solid, so the cloth's side needs normal = [{}]",
                        point(p),
                        length(radius),
                        speed(depth / dt),
                        point(-normal).trim_matches(['(', ')'])
                    );
                }
            }
            return Err(StartProblem {
                collider: index,
                key,
                message,
            });
        }
        if sticking == Some(index) {
            let Shape::Plane(_) = collider.shape else {
                unreachable!("the sticking surface is a plane")
            };
            let highest = corners
                .iter()
                .map(|&(i, j)| {
                    collider
                        .distance(rest_position(&grid, cloth.position, i, j))
                        .0
                })
                .fold(Real::NEG_INFINITY, Real::max);
            if highest.is_nan() || highest > MAX_BUBBLE_HEIGHT {
                return Err(StartProblem {
                    collider: index,
                    key: "point",
                    message: format!(
                        "the cloth starts {} above this plane, the first of the scene: the \
                         sticking surface of the air force, which the air under the cloth is \
                         measured from (air_volume, with the force on or off); that air is no \
                         bubble, and the model needs the cloth within {} of the plane; move \
                         the plane or cloth.position",
                        if highest.is_finite() {
                            length(highest)
                        } else {
                            "infinitely far".into()
                        },
                        length(MAX_BUBBLE_HEIGHT)
                    ),
                });
            }
        }
    }
    Ok(())
}

/// [`check`] for a mesh cloth: every particle against every collider, and the whole cloth
/// within reach of its sticking plane.
fn check_mesh(config: &SimConfig, rest: &[Vec3]) -> Result<(), StartProblem> {
    let radius = config.cloth.particle_radius();
    let dt = config.simulation.time_step;
    let sticking = config.colliders.iter().position(|c| c.as_plane().is_some());
    for (index, collider) in config.colliders.iter().enumerate() {
        let collider = &collider.at(0.0);
        let Some((d, k)) = rest
            .iter()
            .enumerate()
            .map(|(k, &p)| (collider.distance(p).0, k))
            .min_by(|a, b| a.0.total_cmp(&b.0))
        else {
            continue;
        };
        let p = rest[k];
        let depth = radius - d;
        let what = collider.shape_name();
        if !d.is_finite() || depth > TOLERANCE * (1.0 + p.abs().max_element()) {
            let far = if d.is_finite() {
                format!("{} inside its surface", length(depth))
            } else {
                "an unmeasurable distance inside it".to_string()
            };
            return Err(StartProblem {
                collider: index,
                key: match collider.shape {
                    Shape::Plane(_) => "point",
                    Shape::Mesh(_) => "position",
                    _ => "center",
                },
                message: format!(
                    "the cloth starts inside this {what}: vertex {k} (counting from 0) at {} is \
                     {far} (counting the particles' collision radius of {}); a cloth must start \
                     clear of every collider, or contact throws it out at about {} in the first \
                     step; move the {what} or cloth.position",
                    point(p),
                    length(radius),
                    speed(depth / dt),
                ),
            });
        }
        if sticking == Some(index) {
            let highest = rest
                .iter()
                .map(|&p| collider.distance(p).0)
                .fold(Real::NEG_INFINITY, Real::max);
            if highest.is_nan() || highest > MAX_BUBBLE_HEIGHT {
                return Err(StartProblem {
                    collider: index,
                    key: "point",
                    message: format!(
                        "the cloth starts {} above this plane, the first of the scene: the air \
                         model needs the cloth within {} of it; move the plane or cloth.position",
                        length(highest),
                        length(MAX_BUBBLE_HEIGHT)
                    ),
                });
            }
        }
    }
    Ok(())
}

/// A point in metres, shortest exact text: `(0.0, 0.002, 0.0)` (no `-0.0`).
fn point(p: Vec3) -> String {
    let p = p + Vec3::ZERO;
    format!("({:?}, {:?}, {:?})", p.x, p.y, p.z)
}

/// A length for people: `48.8 mm`, `10000 m`, `1e300 m`.
fn length(m: Real) -> String {
    let a = m.abs();
    if a < 1.0 {
        format!("{} mm", round3(m * 1e3))
    } else if a < 1e6 {
        format!("{} m", round3(m))
    } else {
        format!("{m:.3e} m")
    }
}

/// A speed for people: `9 m/s`, `1.2e11 m/s`.
fn speed(v: Real) -> String {
    if v.abs() < 1e6 {
        format!("{} m/s", round3(v))
    } else {
        format!("{v:.2e} m/s")
    }
}

/// 3 significant digits, trailing zeros dropped.
fn round3(v: Real) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let decimals = (2 - v.abs().log10().floor() as i32).max(0) as usize;
    let s = format!("{v:.decimals$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lengths_and_speeds_read_well() {
        assert_eq!(length(0.0488), "48.8 mm");
        assert_eq!(length(0.00075), "0.75 mm");
        assert_eq!(length(10_000.0), "10000 m");
        assert_eq!(length(1e300), "1.000e300 m");
        assert_eq!(speed(9.0), "9 m/s");
        assert_eq!(speed(1.2e11), "1.20e11 m/s");
    }

    /// The nearest grid point really is the deepest: a brute force over every particle
    /// agrees, for spheres and boxes anywhere around a small cloth.
    #[test]
    fn the_nearest_grid_point_is_the_deepest() {
        let mut cfg = SimConfig::default();
        cfg.cloth.resolution = [7, 5];
        cfg.cloth.size = [0.3, 0.2];
        let grid = Grid::new(&cfg.cloth);
        let radius = cfg.cloth.particle_radius();
        for k in 0..200 {
            let t = k as Real;
            let c = Vec3::new(
                0.2 * (t * 0.37).sin(),
                0.05 * (t * 0.11).cos(),
                0.15 * (t * 0.53).sin(),
            );
            for collider in [
                wetcloth::Collider::sphere(c, 0.02 + 0.001 * (k % 50) as Real, 0.5),
                wetcloth::Collider::cuboid(
                    c,
                    Vec3::new(0.03, 0.01 + 0.001 * (k % 30) as Real, 0.02),
                    0.5,
                ),
            ] {
                cfg.colliders = vec![collider.clone()];
                cfg.air.enabled = false;
                let check = |c: &SimConfig| check(c, |_, _| true);
                let brute = (0..7)
                    .flat_map(|i| (0..5).map(move |j| (i, j)))
                    .map(|(i, j)| {
                        collider
                            .distance(rest_position(&grid, cfg.cloth.position, i, j))
                            .0
                    })
                    .fold(Real::INFINITY, Real::min);
                let inside = radius - brute > TOLERANCE * 2.0;
                assert_eq!(check(&cfg).is_err(), inside, "{collider:?}: brute {brute}");
            }
        }
    }
}
