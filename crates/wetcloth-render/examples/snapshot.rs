//! Renders the demo geometry (a satin square with a tent in the middle) to PNG files, dry and
//! wet, with and without particle dots: `cargo run --release --example snapshot -- OUT_DIR`.

use wetcloth_render::{Camera, MeshView, Offscreen, SceneView, collider_scene, tented_grid};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = std::path::PathBuf::from(
        std::env::args()
            .nth(1)
            .unwrap_or_else(|| "snapshots".into()),
    );
    std::fs::create_dir_all(&out)?;
    let (w, h) = (1280, 720);
    let mut off = Offscreen::new(w, h)?;
    println!("adapter: {}", off.adapter_info());
    let (positions, indices) = tented_grid(50, 0.3, 0.002, 0.07);
    let mesh = MeshView {
        positions: &positions,
        normals: &[],
        indices: &indices,
    };
    let camera = Camera::framing([-0.15, 0.0, -0.15], [0.15, 0.07, 0.15]);
    let ball = wetcloth::Collider::sphere(wetcloth::Vec3::new(0.25, 0.04, -0.1), 0.04, 0.6);
    let (_, solids) = collider_scene(&[ball]);
    for (name, wetness, dots) in [
        ("dry", 0.0, false),
        ("wet", 1.0, false),
        ("half", 0.5, false),
        ("dots", 1.0, true),
    ] {
        let mut scene = SceneView::new(mesh, camera);
        scene.wetness = wetness;
        if dots {
            scene.particles = Some(&positions);
            scene.particle_radius = 0.0012;
            scene.highlight = Some(25 * 50 + 25);
            scene.pinned = &[0, 49];
            scene.solids = &solids;
        }
        let t = std::time::Instant::now();
        let img = off.render(&scene)?;
        println!("{name}: {:.1} ms", t.elapsed().as_secs_f64() * 1e3);
        img.save(out.join(format!("{name}.png")))?;
    }
    Ok(())
}
