//! `[[cloth.paint]]` on the built-in grid paints the same particles whichever model runs it: the
//! springs' grid and the membrane's mesh of the grid's triangles (numbered alike) take a
//! region's `center` in the cloth's rest coordinates, x and z from its centre. And a region
//! given in the other cloth's terms is refused.

use std::sync::Arc;
use wetcloth::{
    ClothMeshSource, ClothModel, PaintShape, Real, SimConfig, Simulation, Vec3, WetPaint,
};

/// A 30 x 20 cm grid of 21 x 17 particles placed off the scene's origin, half wet, painted with
/// an off-centre dry disc and an off-centre soaked box that overlaps it (the box on top).
fn painted(model: ClothModel) -> SimConfig {
    let mut cfg = SimConfig::thesis_demo();
    cfg.grabs.clear();
    cfg.cloth.self_collision = false;
    cfg.cloth.size = [0.3, 0.2];
    cfg.cloth.resolution = [21, 17];
    cfg.cloth.position = Vec3::new(0.05, 0.01, -0.02);
    cfg.cloth.model = model;
    cfg.cloth.wetness = 0.5;
    cfg.cloth.paint = vec![
        WetPaint {
            center: [0.061, -0.032],
            shape: PaintShape::Disc(0.041),
            wetness: 0.0,
            point: None,
        },
        WetPaint {
            center: [0.092, -0.052],
            shape: PaintShape::Box([0.024, 0.017]),
            wetness: 1.0,
            point: None,
        },
    ];
    cfg
}

/// The wetness the regions of [`painted`] give particle `(i, j)`, from the grid's rest layout
/// (spacing `size / (resolution - 1)`, centred on the cloth's centre), and how far that particle
/// lies from the nearest edge of a region, m.
fn expected(cfg: &SimConfig, i: usize, j: usize) -> (Real, Real) {
    let [w, d] = cfg.cloth.size;
    let [nx, nz] = cfg.cloth.resolution;
    let x = i as Real * w / (nx - 1) as Real - 0.5 * w;
    let z = j as Real * d / (nz - 1) as Real - 0.5 * d;
    let mut wet = cfg.cloth.wetness;
    let mut margin = Real::INFINITY;
    for p in &cfg.cloth.paint {
        let (dx, dz) = (x - p.center[0], z - p.center[1]);
        let (inside, edge) = match p.shape {
            PaintShape::Disc(r) => {
                let rho = (dx * dx + dz * dz).sqrt();
                (rho <= r, (rho - r).abs())
            }
            PaintShape::Box([hx, hz]) => {
                let inside = dx.abs() <= hx && dz.abs() <= hz;
                let edge = if inside {
                    (hx - dx.abs()).min(hz - dz.abs())
                } else {
                    (dx.abs() - hx).max(dz.abs() - hz)
                };
                (inside, edge)
            }
            PaintShape::Cuboid(_) => unreachable!("the grid's regions are discs and boxes"),
        };
        if inside {
            wet = p.wetness;
        }
        margin = margin.min(edge);
    }
    (wet, margin)
}

/// The springs' grid and the membrane grid wet the same particles, each as the regions' rest
/// coordinates say: the dry disc and the soaked box where they are, not about the scene's
/// origin or the cloth's centre.
#[test]
fn the_springs_grid_and_the_membrane_grid_paint_the_same_particles() {
    let springs = Simulation::new(painted(ClothModel::Springs)).unwrap();
    let membrane = Simulation::new(painted(ClothModel::Membrane)).unwrap();
    let cfg = painted(ClothModel::Springs);
    let [nx, nz] = cfg.cloth.resolution;
    assert_eq!(springs.particle_count(), nx * nz);
    assert_eq!(membrane.particle_count(), nx * nz);
    let (mut dry, mut soaked) = (0, 0);
    for j in 0..nz {
        for i in 0..nx {
            let k = j * nx + i;
            let (want, margin) = expected(&cfg, i, j);
            // No particle on a region's edge, where rounding could put it either side: the
            // regions are set off the grid's lines by a millimetre or more.
            assert!(margin > 1e-4, "particle ({i}, {j}) {margin} m from an edge");
            let (s, m) = (springs.model().wetness[k], membrane.model().wetness[k]);
            assert_eq!(s, want, "springs: particle ({i}, {j})");
            assert_eq!(m, want, "membrane: particle ({i}, {j})");
            dry += usize::from(want == 0.0);
            soaked += usize::from(want == 1.0);
        }
    }
    // The disc holds about pi r^2 / (dx dz) = 28 particles less the box's corner over it, the
    // box about (2 hx / dx) (2 hz / dz) = 9: enough that a region moved by one spacing would show.
    assert!(dry >= 15, "{dry} dry particles");
    assert!(soaked >= 6, "{soaked} soaked particles");
}

/// A one-triangle mesh cloth.
fn triangle() -> ClothMeshSource {
    ClothMeshSource {
        file: "triangle.obj".into(),
        vertices: Arc::new(vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(0.1, 0.0, 0.0),
            Vec3::new(0.0, 0.0, 0.1),
        ]),
        faces: Arc::new(vec![vec![0, 2, 1]]),
        uvs: Arc::new(Vec::new()),
        face_uvs: Arc::new(Vec::new()),
        rotation: Vec3::ZERO,
        scale: 1.0,
        flip_normals: false,
    }
}

/// A region in the other cloth's terms is refused, naming the key: a scene point on the grid
/// (which paints in its rest coordinates) and a mesh's region with only the grid's `[x, z]`.
#[test]
fn a_region_in_the_other_cloths_terms_is_refused() {
    let error = |cfg: SimConfig| match Simulation::new(cfg) {
        Ok(_) => panic!("accepted"),
        Err(e) => e,
    };
    let mut grid = painted(ClothModel::Membrane);
    grid.cloth.paint[1].point = Some(Vec3::new(0.01, 0.0, 0.02));
    let e = error(grid);
    assert_eq!(e.key(), "cloth.paint[1].center");
    assert!(e.to_string().contains("2 components"), "{e}");

    let mut mesh = painted(ClothModel::Springs);
    mesh.cloth.mesh = Some(triangle());
    mesh.cloth.paint.truncate(1);
    let e = error(mesh);
    assert_eq!(e.key(), "cloth.paint[0].center");
    let text = e.to_string();
    assert!(
        text.contains("3 components") && text.contains("[0.061, -0.032]"),
        "{text}"
    );
}
