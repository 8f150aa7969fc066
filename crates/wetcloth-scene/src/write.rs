//! Writing a configuration back as a scene file with every key explicit.

use std::fmt::Write;
use wetcloth::collide::{Cuboid, Plane, Sphere};
use wetcloth::{ClothModel, GrabPick, PaintShape, Real, Shape, SimConfig, Vec3};

/// A float in TOML: Rust's `{:?}` is the shortest text that parses back to the same `f64` and
/// always has a `.` or an exponent, so TOML reads it as a float.
fn f(x: Real) -> String {
    format!("{x:?}")
}

fn v3(v: Vec3) -> String {
    format!("[{}, {}, {}]", f(v.x), f(v.y), f(v.z))
}

/// A TOML basic string.
fn quote(s: &str) -> String {
    let mut out = String::with_capacity(s.len() + 2);
    out.push('"');
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            c if (c as u32) < 0x20 || c == '\u{7f}' => {
                let _ = write!(out, "\\u{:04X}", c as u32);
            }
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

/// Writes `config` as a scene file named `name`, every key explicit (defaults included), with
/// each key's unit in a comment. Parsing the text back ([`crate::parse`]) gives the same name and
/// an identical configuration, bit for bit: floats are written in their shortest round-trip form.
pub fn to_toml(name: &str, config: &SimConfig) -> String {
    let mut o = String::new();
    let s = &config.simulation;
    let c = &config.cloth;
    let a = &config.air;
    // Writing to a String cannot fail.
    let _ = writeln!(o, "# wetcloth scene, fully resolved: every key explicit.");
    let _ = writeln!(o, "name = {}", quote(name));
    if config.colliders.is_empty() {
        // Without this, a scene with no `[[collider]]` gets the default ground.
        let _ = writeln!(o, "collider = []");
    }
    let _ = writeln!(o);
    let _ = writeln!(o, "[simulation]");
    let _ = writeln!(o, "duration = {}  # s", f(s.duration));
    let _ = writeln!(o, "time_step = {}  # s", f(s.time_step));
    let _ = writeln!(o, "integrator = {}", quote(s.integrator.name()));
    let _ = writeln!(o, "implicit_budget = {}", quote(s.implicit_budget.name()));
    let _ = writeln!(o, "frame_rate = {}  # 1/s", f(s.frame_rate));
    let _ = writeln!(o, "gravity = {}  # m/s^2", v3(s.gravity));
    let _ = writeln!(o);
    let _ = writeln!(o, "[cloth]");
    match &c.mesh {
        None => {
            let _ = writeln!(o, "size = [{}, {}]  # m", f(c.size[0]), f(c.size[1]));
            let _ = writeln!(
                o,
                "resolution = [{}, {}]  # particles",
                c.resolution[0], c.resolution[1]
            );
        }
        Some(m) => {
            let _ = writeln!(o, "mesh = {}", quote(&m.file));
            let _ = writeln!(o, "rotation = {}  # degrees", v3(m.rotation));
            let _ = writeln!(o, "scale = {}  # file units to m", f(m.scale));
            let _ = writeln!(o, "flip_normals = {}", m.flip_normals);
        }
    }
    let _ = writeln!(o, "position = {}  # m", v3(c.position));
    if let Some(name) = &c.material {
        let _ = writeln!(
            o,
            "material = {}  # the values below are its, at the wetness",
            quote(name)
        );
    }
    if c.model != ClothModel::Springs {
        let _ = writeln!(o, "model = {}", quote(c.model.name()));
    }
    match c.density {
        Some(d) => {
            let _ = writeln!(o, "density = {}  # kg/m^2", f(d));
        }
        None => {
            let _ = writeln!(o, "mass = {}  # kg", f(c.mass));
        }
    }
    let _ = writeln!(
        o,
        "structural_stiffness = {}  # N/m",
        f(c.structural_stiffness)
    );
    let _ = writeln!(o, "shear_stiffness = {}  # N/m", f(c.shear_stiffness));
    let _ = writeln!(o, "damping = {}  # 1/s", f(c.damping));
    let _ = writeln!(o, "thickness = {}  # m", f(c.thickness));
    let _ = writeln!(o, "collision_margin = {}  # m", f(c.collision_margin));
    let _ = writeln!(o, "self_collision = {}", c.self_collision);
    let _ = writeln!(o, "strain_limit = {}  # ratio, 0 = off", f(c.strain_limit));
    let _ = writeln!(o, "strain_limit_iterations = {}", c.strain_limit_iterations);
    let _ = writeln!(o, "wetness = {}  # 0 dry .. 1 soaked", f(c.wetness));
    let _ = writeln!(o, "water_mass = {}  # kg/m^2", f(c.water_mass));
    let _ = writeln!(o, "dry_friction_factor = {}", f(c.dry_friction_factor));
    let _ = writeln!(o, "wet_adhesion = {}  # Pa", f(c.wet_adhesion));
    if c.shrink != 0.0 {
        let _ = writeln!(o, "shrink = {}  # fraction of the rest size", f(c.shrink));
    }
    if c.model == ClothModel::Membrane {
        let m = &c.membrane;
        let _ = writeln!(o);
        let _ = writeln!(o, "[cloth.membrane]");
        let _ = writeln!(o, "warp = {}  # N/m", f(m.warp));
        let _ = writeln!(o, "weft = {}  # N/m", f(m.weft));
        let _ = writeln!(o, "shear = {}  # N/m", f(m.shear));
        let _ = writeln!(o, "poisson = {}", f(m.poisson));
        let b = &c.bending;
        let _ = writeln!(o);
        let _ = writeln!(o, "[cloth.bending]");
        let _ = writeln!(o, "stiffness = {}  # N m", f(b.stiffness));
        let _ = writeln!(o, "warp = {}  # factor", f(b.warp));
        let _ = writeln!(o, "weft = {}  # factor", f(b.weft));
        let _ = writeln!(o, "rest = {}", quote(b.rest.name()));
    }
    for p in &c.paint {
        let _ = writeln!(o);
        let _ = writeln!(o, "[[cloth.paint]]");
        let _ = writeln!(o, "{}", center_line(p.point, p.center));
        match p.shape {
            PaintShape::Disc(r) => {
                let _ = writeln!(o, "radius = {}  # m", f(r));
            }
            PaintShape::Box(h) => {
                let _ = writeln!(o, "half_size = [{}, {}]  # m", f(h[0]), f(h[1]));
            }
            PaintShape::Cuboid(h) => {
                let _ = writeln!(
                    o,
                    "half_size = [{}, {}, {}]  # m",
                    f(h[0]),
                    f(h[1]),
                    f(h[2])
                );
            }
        }
        let _ = writeln!(o, "wetness = {}", f(p.wetness));
    }
    for s in &c.seams {
        let list = |l: &[u32]| {
            let items: Vec<String> = l.iter().map(u32::to_string).collect();
            format!("[{}]", items.join(", "))
        };
        let _ = writeln!(o);
        let _ = writeln!(o, "[[cloth.seam]]");
        let _ = writeln!(o, "a = {}", list(&s.a));
        let _ = writeln!(o, "b = {}", list(&s.b));
        let _ = writeln!(o, "stiffness = {}  # N/m per pair", f(s.stiffness));
        let _ = writeln!(o, "max_force = {}  # N per pair", f(s.max_force));
    }
    let _ = writeln!(o);
    let _ = writeln!(o, "[air]");
    let _ = writeln!(o, "enabled = {}", a.enabled);
    let _ = writeln!(
        o,
        "atmospheric_pressure = {}  # Pa",
        f(a.atmospheric_pressure)
    );
    let _ = writeln!(o, "trapped_air = {}  # m^3", f(a.trapped_air));
    let _ = writeln!(o, "leak_conductance = {}  # m^2/s", f(a.leak_conductance));
    let _ = writeln!(o, "pressure_solve = {}", quote(a.pressure_solve.name()));
    let _ = writeln!(o, "pressure_force = {}", quote(a.pressure_force.name()));
    let _ = writeln!(o, "model = {}", quote(a.model.name()));
    let _ = writeln!(o, "seal_distance = {}  # m", f(a.seal_distance));
    let _ = writeln!(o, "seal_hysteresis = {}", f(a.seal_hysteresis));
    let _ = writeln!(o, "seal_wetness = {}", f(a.seal_wetness));
    let _ = writeln!(o, "permeability = {}  # m/(s Pa)", f(a.permeability));
    let _ = writeln!(
        o,
        "dry_permeability = {}  # m/(s Pa)",
        f(a.dry_permeability)
    );
    for p in &a.pockets {
        let _ = writeln!(o);
        let _ = writeln!(o, "[[air.pocket]]");
        let _ = writeln!(o, "{}", center_line(p.point, p.center));
        let _ = writeln!(o, "radius = {}  # m", f(p.radius));
        let _ = writeln!(o, "amount = {}  # m^3 at atmospheric pressure", f(p.amount));
    }
    for col in &config.colliders {
        let _ = writeln!(o);
        let _ = writeln!(o, "[[collider]]");
        match &col.shape {
            Shape::Plane(Plane { point, normal }) => {
                let _ = writeln!(o, "shape = \"plane\"");
                let _ = writeln!(o, "point = {}  # m", v3(*point));
                let _ = writeln!(o, "normal = {}", v3(*normal));
            }
            Shape::Sphere(Sphere { center, radius }) => {
                let _ = writeln!(o, "shape = \"sphere\"");
                let _ = writeln!(o, "center = {}  # m", v3(*center));
                let _ = writeln!(o, "radius = {}  # m", f(*radius));
            }
            Shape::Box(Cuboid {
                center,
                half_extents,
            }) => {
                let _ = writeln!(o, "shape = \"box\"");
                let _ = writeln!(o, "center = {}  # m", v3(*center));
                let _ = writeln!(o, "half_extents = {}  # m", v3(*half_extents));
            }
            Shape::Mesh(m) => {
                let _ = writeln!(o, "shape = \"mesh\"");
                let _ = writeln!(o, "file = {}  # relative to the scene file", quote(&m.file));
                let _ = writeln!(o, "position = {}  # m", v3(m.position));
                let _ = writeln!(o, "rotation = {}  # degrees about x, y, z", v3(m.rotation));
                let _ = writeln!(o, "scale = {}", f(m.scale));
                if let Some(mo) = m.motion() {
                    let (key, path) = match &mo.source {
                        wetcloth::collide::PointSource::Sequence(p) => ("sequence", p),
                        wetcloth::collide::PointSource::Cache(p) => ("cache", p),
                    };
                    let _ = writeln!(o, "{key} = {}", quote(path));
                    let _ = writeln!(o, "frame_rate = {}  # 1/s", f(mo.frame_rate));
                    let _ = writeln!(o, "start = {}  # s", f(mo.start));
                }
            }
        }
        let _ = writeln!(o, "friction = {}", f(col.friction));
        let _ = writeln!(o, "sticky = {}", col.sticky);
        if !col.keys.is_empty() {
            let _ = writeln!(o, "keys = [  # time in s, offset in m, rotation in degrees");
            for k in &col.keys {
                let _ = writeln!(
                    o,
                    "    {{ time = {}, offset = {}, rotation = {} }},",
                    f(k.time),
                    v3(k.offset),
                    v3(k.rotation)
                );
            }
            let _ = writeln!(o, "]");
        }
    }
    for g in &config.grabs {
        let _ = writeln!(o);
        let _ = writeln!(o, "[[grab]]");
        match &g.pick {
            None => {
                let _ = writeln!(
                    o,
                    "particle = [{}, {}]  # column, row",
                    g.particle[0], g.particle[1]
                );
            }
            Some(GrabPick::Vertex(k)) => {
                let _ = writeln!(o, "vertex = {k}");
            }
            Some(GrabPick::Near(p)) => {
                let _ = writeln!(o, "near = {}  # m", v3(*p));
            }
            Some(GrabPick::Ball { center, radius }) => {
                let _ = writeln!(
                    o,
                    "within = {{ center = {}, radius = {} }}  # m",
                    v3(*center),
                    f(*radius)
                );
            }
            Some(GrabPick::Box { center, half_size }) => {
                let _ = writeln!(
                    o,
                    "within = {{ center = {}, half_size = {} }}  # m",
                    v3(*center),
                    v3(*half_size)
                );
            }
        }
        let _ = writeln!(o, "keys = [  # time in s, offset in m");
        for k in &g.keys {
            let _ = writeln!(
                o,
                "    {{ time = {}, offset = {} }},",
                f(k.time),
                v3(k.offset)
            );
        }
        let _ = writeln!(o, "]");
    }
    for a in &config.attachments {
        let _ = writeln!(o);
        let _ = writeln!(o, "[[attach]]");
        let _ = writeln!(o, "collider = {}  # 0-based", a.collider);
        if let Some(k) = a.stiffness {
            let _ = writeln!(o, "stiffness = {}  # N/m per particle", f(k));
        }
        let _ = match &a.pick {
            GrabPick::Vertex(k) => writeln!(o, "vertex = {k}"),
            GrabPick::Near(p) => writeln!(o, "near = {}  # m", v3(*p)),
            GrabPick::Ball { center, radius } => writeln!(
                o,
                "within = {{ center = {}, radius = {} }}  # m",
                v3(*center),
                f(*radius)
            ),
            GrabPick::Box { center, half_size } => writeln!(
                o,
                "within = {{ center = {}, half_size = {} }}  # m",
                v3(*center),
                v3(*half_size)
            ),
        };
    }
    o
}

/// A paint region's or a seed's `center` line: 3 components on a mesh (`point`), the grid's 2.
fn center_line(point: Option<Vec3>, center: [Real; 2]) -> String {
    match point {
        Some(c) => format!("center = {}  # m, scene at t = 0", v3(c)),
        None => format!(
            "center = [{}, {}]  # m, rest (x, z)",
            f(center[0]),
            f(center[1])
        ),
    }
}
