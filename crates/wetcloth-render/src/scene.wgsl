// wetcloth's scene shaders: background, table, cloth and solids, particle dots, shadow map.
//
// World space is metres, Y up. Every colour below is linear RGB until `finish`, which tone maps
// and, when the target is not an sRGB texture, encodes sRGB itself.

struct Globals {
    view_proj: mat4x4<f32>,
    light_view_proj: mat4x4<f32>, // world -> shadow-map clip space (orthographic, key light)
    eye: vec4<f32>,               // xyz: eye position
    key_dir: vec4<f32>,           // xyz: unit direction towards the key light
    cam_right: vec4<f32>,         // xyz: camera right, for billboards
    cam_up: vec4<f32>,            // xyz: camera up, for billboards
    ground_point: vec4<f32>,      // xyz: a point of the table; w: grid spacing, m
    ground_normal: vec4<f32>,     // xyz: unit table normal; w: radius where the table fades, m
    focus: vec4<f32>,             // xyz: scene centre on the table; w: particle dot radius, m
    shadow: vec4<f32>,            // x: shadow-map texel size, m; y: 1 = shadows on; z: map size, texels
    params: vec4<f32>,            // x: wetness 0..1; y: 1 = encode sRGB here; zw: viewport, px
}

struct Material {
    front: vec4<f32>, // rgb: front-side albedo; a: specular strength (dry)
    back: vec4<f32>,  // rgb: back-side albedo; a: sheen, the satin glow at grazing angles
    spec: vec4<f32>,  // x: specular exponent (dry); y: how much wetness changes it (0..1)
}

@group(0) @binding(0) var<uniform> g: Globals;
@group(0) @binding(1) var shadow_map: texture_depth_2d;
@group(0) @binding(2) var shadow_sampler: sampler_comparison;
@group(1) @binding(0) var<uniform> mat: Material;

// ---------------------------------------------------------------------------------------------
// Lighting: a sky/table hemisphere ambient, a warm key light with soft (wrapped) diffuse and a
// Blinn-Phong lobe, a cool fill from the opposite side, and a rim (sheen) at grazing angles.

const PI: f32 = 3.14159265;
const SKY: vec3<f32> = vec3<f32>(0.78, 0.84, 0.95);    // ambient from above (cool sky)
const BOUNCE: vec3<f32> = vec3<f32>(0.42, 0.38, 0.33); // ambient from below (warm table bounce)
const KEY: vec3<f32> = vec3<f32>(1.30, 1.23, 1.13);    // key light radiance (warm white)
const FILL: vec3<f32> = vec3<f32>(0.20, 0.24, 0.32);   // fill light radiance (cool, weak)

struct Surface {
    albedo: vec3<f32>,
    n: vec3<f32>,        // unit normal, facing the viewer's side of the surface
    spec: f32,           // specular strength
    exponent: f32,       // specular exponent
    coat: f32,           // strength of a sharp second lobe (a water film)
    sheen: f32,          // grazing-angle glow
}

fn shade(s: Surface, p: vec3<f32>, shadow: f32) -> vec3<f32> {
    let v = normalize(g.eye.xyz - p);
    let l = g.key_dir.xyz;
    let n = s.n;
    let ndl = dot(n, l);
    // Wrapped diffuse: light reaches a little past the terminator, as it does in soft cloth.
    let wrap = 0.1;
    let diffuse = max((ndl + wrap) / (1.0 + wrap), 0.0);
    let hemi = mix(BOUNCE, SKY, n.y * 0.5 + 0.5);
    let fill_dir = normalize(vec3<f32>(-l.x, 0.35, -l.z));
    let fill = max(dot(n, fill_dir), 0.0);
    var c = s.albedo * (0.62 * hemi + KEY * diffuse * shadow + FILL * fill);

    // Energy-normalised Blinn-Phong with Schlick's Fresnel (F0 = 4%, cloth and water alike).
    let h = normalize(l + v);
    let ndh = max(dot(n, h), 0.0);
    let fresnel = 0.04 + 0.96 * pow(1.0 - max(dot(h, v), 0.0), 5.0);
    let lit = step(0.0, ndl) * smoothstep(0.0, 0.15, ndl) * shadow;
    let lobe = s.spec * pow(ndh, s.exponent) * (s.exponent + 8.0) / (8.0 * PI);
    let coat = s.coat * pow(ndh, 400.0) * (408.0 / (8.0 * PI)) * fresnel * 6.0;
    c += KEY * lit * (lobe * mix(vec3<f32>(1.0), s.albedo * 1.6, 0.4) + vec3<f32>(coat));

    // Rim / sheen: satin glows where its surface turns away from the eye; the sky lights it.
    let rim = pow(1.0 - max(dot(n, v), 0.0), 3.0);
    c += s.sheen * rim * SKY * mix(vec3<f32>(1.0), s.albedo, 0.5);
    return c;
}

// Percentage-closer filtered key-light visibility at `p` (1 lit, 0 shadowed). The sample point
// is pushed along the normal (on the side facing the light) by a couple of shadow texels, so
// surfaces do not shadow themselves.
fn key_visibility(p: vec3<f32>, n: vec3<f32>) -> f32 {
    if (g.shadow.y < 0.5) {
        return 1.0;
    }
    let l = g.key_dir.xyz;
    let nl = select(-n, n, dot(n, l) >= 0.0);
    let q = g.light_view_proj * vec4<f32>(p + nl * g.shadow.x * 1.5, 1.0);
    let uv = q.xy * vec2<f32>(0.5, -0.5) + vec2<f32>(0.5, 0.5);
    if (any(uv < vec2<f32>(0.0)) || any(uv > vec2<f32>(1.0)) || q.z > 1.0) {
        return 1.0;
    }
    // A 3x3 tent of comparisons 2.5 texels apart, each bilinearly filtered by the comparison
    // sampler (2x2 texels): a soft penumbra for 9 taps.
    let texel = 1.0 / g.shadow.z;
    var sum = 0.0;
    var weight = 0.0;
    for (var j = -1; j <= 1; j++) {
        for (var i = -1; i <= 1; i++) {
            let w = (2.0 - abs(f32(i))) * (2.0 - abs(f32(j)));
            let o = vec2<f32>(f32(i), f32(j)) * texel * 2.5;
            sum += w * textureSampleCompareLevel(shadow_map, shadow_sampler, uv + o, q.z - 0.0015);
            weight += w;
        }
    }
    return sum / weight;
}

// The backdrop: a vertical gradient, cool grey at the top to a light warm grey at the bottom.
// `ndc_y` is the height in the viewport, 1 at the top to -1 at the bottom (not the framebuffer
// row, which is offset when the viewer paints into part of its window).
fn backdrop(ndc_y: f32) -> vec3<f32> {
    let t = clamp(0.5 - 0.5 * ndc_y, 0.0, 1.0);
    return mix(vec3<f32>(0.30, 0.34, 0.40), vec3<f32>(0.62, 0.61, 0.59), smoothstep(0.0, 1.0, t));
}

// Tone mapping (Narkowicz's fit of the ACES curve), then sRGB encoding when the target format
// does not do it in hardware (egui's swap chain is usually a plain *Unorm format).
fn finish(c: vec3<f32>) -> vec4<f32> {
    let x = c * 0.7; // exposure
    var m = clamp((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14), vec3<f32>(0.0), vec3<f32>(1.0));
    if (g.params.y > 0.5) {
        let lo = m * 12.92;
        let hi = 1.055 * pow(m, vec3<f32>(1.0 / 2.4)) - 0.055;
        m = select(hi, lo, m <= vec3<f32>(0.0031308));
    }
    return vec4<f32>(m, 1.0);
}

// ---------------------------------------------------------------------------------------------
// Background: one triangle covering the viewport, at the far plane.

struct BgOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) ndc_y: f32,
}

@vertex
fn vs_background(@builtin(vertex_index) i: u32) -> BgOut {
    let uv = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    var o: BgOut;
    o.clip = vec4<f32>(uv * 2.0 - 1.0, 1.0, 1.0);
    o.ndc_y = o.clip.y;
    return o;
}

@fragment
fn fs_background(in: BgOut) -> @location(0) vec4<f32> {
    return finish(backdrop(in.ndc_y));
}

// ---------------------------------------------------------------------------------------------
// Meshes (cloth and solids): position and normal per vertex.

struct MeshIn {
    @location(0) pos: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) tint: vec4<f32>, // rgb: linear colour; a: weight over the material's albedo
}

struct MeshOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) clip_yw: vec2<f32>, // clip-space y and w, for the backdrop behind the table
    @location(3) tint: vec4<f32>,
}

@vertex
fn vs_mesh(in: MeshIn) -> MeshOut {
    var o: MeshOut;
    o.clip = g.view_proj * vec4<f32>(in.pos, 1.0);
    o.world = in.pos;
    o.normal = in.normal;
    o.clip_yw = o.clip.yw;
    o.tint = in.tint;
    return o;
}

// Cloth and solids. Both faces are drawn: the back face uses the back albedo and the flipped
// normal. Wetness darkens the albedo (water fills the weave, so less light scatters back out),
// tightens the satin's broad highlight and adds a sharp highlight of the water film.
@fragment
fn fs_mesh(in: MeshOut, @builtin(front_facing) front: bool) -> @location(0) vec4<f32> {
    var n = normalize(in.normal);
    if (!front) {
        n = -n;
    }
    // An interpolated normal may still face away from the eye near silhouettes; bend it back.
    let v = normalize(g.eye.xyz - in.world);
    n = normalize(n + v * max(-dot(n, v), 0.0) * 1.05);

    let wet = clamp(g.params.x, 0.0, 1.0) * mat.spec.y;
    var albedo = select(mat.back.rgb, mat.front.rgb, front);
    albedo = mix(albedo, in.tint.rgb, clamp(in.tint.a, 0.0, 1.0));
    albedo = pow(albedo, vec3<f32>(1.0 + 0.3 * wet)) * (1.0 - 0.3 * wet);
    var s: Surface;
    s.albedo = albedo;
    s.n = n;
    s.spec = mix(mat.front.a, mat.front.a * 0.6, wet) * select(0.5, 1.0, front);
    s.exponent = mix(mat.spec.x, mat.spec.x * 3.0, wet);
    s.coat = wet * select(0.5, 1.0, front);
    s.sheen = mat.back.a * mix(1.0, 0.6, wet) * select(0.6, 1.0, front);
    return finish(shade(s, in.world, key_visibility(in.world, n)));
}

// ---------------------------------------------------------------------------------------------
// The table: a large quad, a faint grid (minor lines every `ground_point.w`, major every fifth),
// fading into the backdrop far from the scene so its edge is never seen.

fn grid_line(coord: vec2<f32>) -> f32 {
    let fw = max(fwidth(coord), vec2<f32>(1e-6));
    let d = abs(fract(coord - 0.5) - 0.5) / fw;
    let line = 1.0 - min(min(d.x, d.y), 1.0);
    // Lines thinner than a pixel would alias into moire: fade them out with distance.
    return line * (1.0 - smoothstep(0.15, 0.6, max(fw.x, fw.y)));
}

@fragment
fn fs_ground(in: MeshOut) -> @location(0) vec4<f32> {
    let n = g.ground_normal.xyz;
    let helper = select(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(0.0, 0.0, 1.0), abs(n.x) > 0.9);
    let t1 = normalize(cross(n, helper));
    let t2 = cross(n, t1);
    let d = in.world - g.ground_point.xyz;
    let uv = vec2<f32>(dot(d, t1), dot(d, t2)) / g.ground_point.w;
    let minor = grid_line(uv);
    let major = grid_line(uv / 5.0);
    var s: Surface;
    s.albedo = mat.front.rgb * (1.0 - 0.06 * minor - 0.10 * major);
    s.n = n;
    s.spec = mat.front.a;
    s.exponent = mat.spec.x;
    s.coat = 0.0;
    s.sheen = 0.0;
    let lit = shade(s, in.world, key_visibility(in.world, n));
    let r = length(in.world - g.focus.xyz);
    let fade = smoothstep(0.45 * g.ground_normal.w, g.ground_normal.w, r);
    return finish(mix(lit, backdrop(in.clip_yw.x / in.clip_yw.y), fade));
}

// ---------------------------------------------------------------------------------------------
// Particle dots: camera-facing quads shaded as small spheres. `kind` 0 is a particle, 1 the
// picked particle (the cursor), 2 a pinned particle.

struct DotIn {
    @builtin(vertex_index) corner: u32,
    @location(0) center: vec3<f32>,
    @location(1) kind: f32,
}

struct DotOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) uv: vec2<f32>,
    @location(1) kind: f32,
    @location(2) world: vec3<f32>,
}

@vertex
fn vs_dot(in: DotIn) -> DotOut {
    var corners = array<vec2<f32>, 6>(
        vec2<f32>(-1.0, -1.0), vec2<f32>(1.0, -1.0), vec2<f32>(1.0, 1.0),
        vec2<f32>(-1.0, -1.0), vec2<f32>(1.0, 1.0), vec2<f32>(-1.0, 1.0),
    );
    let c = corners[in.corner];
    let size = g.focus.w * select(select(1.0, 3.2, in.kind > 0.5), 1.9, in.kind > 1.5);
    // Pull the quad towards the eye by its size so that the cloth does not cut the dot in half.
    let to_eye = normalize(g.eye.xyz - in.center);
    let p = in.center + (g.cam_right.xyz * c.x + g.cam_up.xyz * c.y) * size + to_eye * size;
    var o: DotOut;
    o.clip = g.view_proj * vec4<f32>(p, 1.0);
    o.uv = c;
    o.kind = in.kind;
    o.world = in.center;
    return o;
}

@fragment
fn fs_dot(in: DotOut) -> @location(0) vec4<f32> {
    let r2 = dot(in.uv, in.uv);
    if (r2 > 1.0) {
        discard;
    }
    let v = normalize(g.eye.xyz - in.world);
    let n = normalize(g.cam_right.xyz * in.uv.x + g.cam_up.xyz * in.uv.y + v * sqrt(1.0 - r2));
    var albedo = vec3<f32>(0.10, 0.22, 0.42); // particles: deep blue, clear on the pale cloth
    if (in.kind > 1.5) {
        albedo = vec3<f32>(0.60, 0.04, 0.03); // pinned: red
    } else if (in.kind > 0.5) {
        albedo = vec3<f32>(0.95, 0.55, 0.02); // cursor: amber
    }
    var s: Surface;
    s.albedo = albedo;
    s.n = n;
    s.spec = 0.5;
    s.exponent = 60.0;
    s.coat = 0.0;
    s.sheen = 0.0;
    var c = shade(s, in.world, 1.0);
    // A dark outline keeps the dot readable against any background.
    c = mix(c, vec3<f32>(0.02), smoothstep(0.72, 0.9, r2));
    // The cursor is a ring: its centre is see-through to show what it holds.
    if (in.kind > 0.5 && in.kind < 1.5 && r2 < 0.3) {
        discard;
    }
    return finish(c);
}

// ---------------------------------------------------------------------------------------------
// Shadow map: depth only, seen from the key light.

@vertex
fn vs_shadow(in: MeshIn) -> @builtin(position) vec4<f32> {
    return g.light_view_proj * vec4<f32>(in.pos, 1.0);
}
