//! The renderer draws the scene where it is: images rendered offscreen are checked pixel by
//! pixel at points projected with the same camera.
//!
//! These tests need a graphics adapter; on a machine without a GPU, Mesa's software Vulkan
//! driver (`mesa-vulkan-drivers libvulkan1`) provides one. Without any they fail, saying so.

use std::path::PathBuf;

use wetcloth_render::{Camera, MeshView, Offscreen, SceneView, tented_grid};

const W: u32 = 160;
const H: u32 = 120;

fn offscreen() -> Offscreen {
    match Offscreen::new(W, H) {
        Ok(o) => o,
        Err(e) => panic!(
            "cannot render offscreen: {e}\nThe renderer tests need a graphics adapter; install \
             Mesa's lavapipe (apt-get install mesa-vulkan-drivers libvulkan1)."
        ),
    }
}

/// Where test images are kept for a look: `target/tmp/wetcloth-render/`.
fn save(img: &image::RgbaImage, name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("wetcloth-render");
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(name);
    img.save(&path).unwrap();
    path
}

fn pixel(img: &image::RgbaImage, p: [f32; 2]) -> [i32; 3] {
    let (x, y) = (p[0].floor() as u32, p[1].floor() as u32);
    assert!(
        x < img.width() && y < img.height(),
        "{p:?} is off the image"
    );
    let c = img.get_pixel(x, y).0;
    [c[0] as i32, c[1] as i32, c[2] as i32]
}

fn luma(c: [i32; 3]) -> i32 {
    (2126 * c[0] + 7152 * c[1] + 722 * c[2]) / 10000
}

/// The satin is a pale rose: clearly more red than green and blue.
fn is_cloth(c: [i32; 3]) -> bool {
    c[0] > c[1] + 12 && c[0] > c[2] + 6
}

/// The table is a neutral grey.
fn is_table(c: [i32; 3]) -> bool {
    (c[0] - c[1]).abs() <= 10 && (c[1] - c[2]).abs() <= 10 && (60..230).contains(&c[1])
}

struct Setup {
    positions: Vec<[f32; 3]>,
    indices: Vec<u32>,
    camera: Camera,
}

const N: usize = 21;

fn setup(lift: f32) -> Setup {
    let (positions, indices) = tented_grid(N, 0.3, 0.003, lift);
    // Frame a larger box than the cloth so that the table shows around it.
    let camera = Camera::framing([-0.25, 0.0, -0.25], [0.25, 0.06, 0.25]);
    Setup {
        positions,
        indices,
        camera,
    }
}

impl Setup {
    fn scene(&self) -> SceneView<'_> {
        SceneView::new(
            MeshView {
                positions: &self.positions,
                normals: &[],
                indices: &self.indices,
            },
            self.camera,
        )
    }

    fn at(&self, i: usize, j: usize) -> [f32; 2] {
        self.camera
            .project(self.positions[j * N + i], [W, H])
            .unwrap()
    }
}

#[test]
fn cloth_table_and_backdrop_are_where_they_should_be() {
    let mut off = offscreen();
    let s = setup(0.0);
    let img = off.render(&s.scene()).unwrap();
    save(&img, "flat.png");

    // The cloth's colour at points of the cloth (its centre and near its corners).
    for (i, j) in [(10, 10), (3, 3), (17, 3), (3, 17), (17, 17)] {
        let c = pixel(&img, s.at(i, j));
        assert!(is_cloth(c), "cloth vertex ({i}, {j}) drawn as {c:?}");
    }
    // The table's colour beside the cloth (points of the plane outside it, in the frame).
    let mut seen = 0;
    for p in [
        [-0.22, 0.0, 0.0],
        [0.22, 0.0, 0.0],
        [0.0, 0.0, -0.22],
        [0.0, 0.0, 0.22],
    ] {
        let q = s.camera.project(p, [W, H]).unwrap();
        if (0.0..W as f32).contains(&q[0]) && (0.0..H as f32).contains(&q[1]) {
            let c = pixel(&img, q);
            assert!(is_table(c), "table at {p:?} drawn as {c:?}");
            seen += 1;
        }
    }
    assert!(seen >= 2, "the framing shows too little table");

    // Without the table, the backdrop: a vertical gradient (the same colour all along a row),
    // cool grey-blue at the top, and neither cloth nor table where the table was.
    let mut scene = s.scene();
    scene.ground = None;
    let img2 = off.render(&scene).unwrap();
    save(&img2, "no_table.png");
    let top = pixel(&img2, [2.0, 2.0]);
    assert!(top[2] > top[0] + 10, "backdrop at the top drawn as {top:?}");
    for p in [[0.22, 0.0, 0.0], [-0.22, 0.0, 0.0]] {
        let q = s.camera.project(p, [W, H]).unwrap();
        let c = pixel(&img2, q);
        let row = pixel(&img2, [1.0, q[1]]);
        assert!(
            (0..3).all(|k| (c[k] - row[k]).abs() <= 3) && !is_cloth(c),
            "backdrop at {q:?} drawn as {c:?}, its row's edge as {row:?}"
        );
        assert!(
            pixel(&img, q) != c,
            "the table and the backdrop look alike at {q:?}"
        );
    }
    assert!(is_cloth(pixel(&img2, s.at(10, 10))));
}

#[test]
fn a_lifted_centre_is_shaded_by_the_slope_and_a_flat_cloth_is_not() {
    let mut off = offscreen();
    // (7, 13) lies on the slope facing the key light (-x, +z); (13, 7) on the slope facing
    // away from it. Both face the camera.
    let flat = setup(0.0);
    let img = off.render(&flat.scene()).unwrap();
    let d_flat = luma(pixel(&img, flat.at(7, 13))) - luma(pixel(&img, flat.at(13, 7)));

    let tent = setup(0.06);
    let img = off.render(&tent.scene()).unwrap();
    save(&img, "tent.png");
    let lit = pixel(&img, tent.at(7, 13));
    let away = pixel(&img, tent.at(13, 7));
    assert!(is_cloth(lit) && is_cloth(away), "{lit:?} {away:?}");
    let d_tent = luma(lit) - luma(away);
    assert!(d_flat.abs() < 6, "a flat cloth shades evenly: {d_flat}");
    assert!(
        d_tent > 15 && d_tent > 3 * d_flat.abs(),
        "the lit slope must be brighter than the far one: {d_tent} (flat: {d_flat})"
    );
}

#[test]
fn wet_cloth_is_darker_than_dry_cloth() {
    let mut off = offscreen();
    let s = setup(0.0);
    let mut scene = s.scene();
    scene.wetness = 0.0;
    let dry = off.render(&scene).unwrap();
    scene.wetness = 1.0;
    let wet = off.render(&scene).unwrap();
    save(&dry, "dry.png");
    save(&wet, "wet.png");
    for (i, j) in [(5, 5), (10, 10), (15, 12)] {
        let (d, w) = (pixel(&dry, s.at(i, j)), pixel(&wet, s.at(i, j)));
        assert!(luma(w) + 15 < luma(d), "({i}, {j}): dry {d:?}, wet {w:?}");
        assert!(is_cloth(w));
    }
}

#[test]
fn pins_and_the_cursor_are_drawn_on_their_particles() {
    let mut off = offscreen();
    let s = setup(0.03);
    let mut scene = s.scene();
    let pinned = [0, N * N - 1];
    scene.pinned = &pinned;
    scene.highlight = Some(N * 10 + 10);
    scene.particle_radius = 0.004;
    let img = off.render(&scene).unwrap();
    save(&img, "pins.png");
    for k in pinned {
        let c = pixel(&img, s.camera.project(s.positions[k], [W, H]).unwrap());
        assert!(c[0] > 2 * c[1].max(c[2]) + 10, "pin {k} drawn as {c:?}");
    }
    // The cursor is a ring (3.2 dot radii across, open inside 0.55 of that): amber on it,
    // the cloth through its middle.
    let f = glam::Vec3::from(s.camera.forward());
    let right = f.cross(glam::Vec3::Y).normalize();
    let centre = glam::Vec3::from(s.positions[N * 10 + 10]);
    let on_ring = |sign: f32| {
        let p = centre + right * sign * 0.8 * 3.2 * scene.particle_radius;
        pixel(&img, s.camera.project(p.to_array(), [W, H]).unwrap())
    };
    let (ring, ring2) = (on_ring(1.0), on_ring(-1.0));
    let amber = |c: [i32; 3]| c[0] > c[2] + 60 && c[1] > c[2] + 20;
    let middle = pixel(&img, s.camera.project(centre.to_array(), [W, H]).unwrap());
    assert!(
        is_cloth(middle) && !amber(middle),
        "cursor middle drawn as {middle:?}"
    );
    assert!(
        amber(ring) && amber(ring2),
        "cursor ring drawn as {ring:?} / {ring2:?}"
    );
}

#[test]
fn a_pass_without_depth_still_draws_the_cloth_over_the_table() {
    // The viewer may paint into a pass with no depth buffer: the renderer then sorts the
    // triangles back to front. The picture must match the depth-buffered one.
    let s = setup(0.06);
    let with = offscreen().render(&s.scene()).unwrap();
    let mut off = Offscreen::with_depth(W, H, false).expect("no graphics adapter");
    let without = off.render(&s.scene()).unwrap();
    save(&without, "tent_without_depth.png");
    for (i, j) in [(10, 10), (7, 13), (13, 7), (3, 17)] {
        let c = pixel(&without, s.at(i, j));
        assert!(is_cloth(c), "cloth vertex ({i}, {j}) drawn as {c:?}");
    }
    let differ = with
        .pixels()
        .zip(without.pixels())
        .filter(|(a, b)| (0..3).any(|k| (a.0[k] as i32 - b.0[k] as i32).abs() > 24))
        .count();
    assert!(
        differ < (W * H / 50) as usize,
        "{differ} pixels differ between the passes with and without depth"
    );
}

#[test]
fn the_cloth_material_can_be_changed() {
    use wetcloth_render::Material;
    let mut off = offscreen();
    let blue = Material {
        front: [0.05, 0.1, 0.6],
        back: [0.05, 0.1, 0.6],
        ..Material::satin()
    };
    off.set_materials(Some(&blue), None, None);
    let s = setup(0.0);
    let img = off.render(&s.scene()).unwrap();
    let c = pixel(&img, s.at(10, 10));
    assert!(c[2] > c[0] + 30, "blue cloth drawn as {c:?}");
    let t = pixel(&img, s.camera.project([0.22, 0.0, 0.0], [W, H]).unwrap());
    assert!(is_table(t), "the table keeps its colour: {t:?}");
}
