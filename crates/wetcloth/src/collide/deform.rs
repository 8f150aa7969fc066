//! Deforming mesh colliders: a mesh whose points move (scene `sequence = "body/frame_####.obj"`
//! or `cache = "body.pc2"`), a body raising its arms or walking.
//!
//! **The motion.** A [`PointMotion`] holds every frame's points in the file's own coordinates
//! (one entry per vertex of the rest mesh), frame `i` at scene time `start + i / frame_rate`;
//! between frames the points move linearly, before frame 0 the first frame holds and after the
//! last frame the last holds. `scale`, `rotation`, `position` and the collider's `keys` apply on
//! top, as to a still mesh's vertices: the deformation is taken in the mesh's own (scaled) frame
//! and the rigid placement maps that frame to the world.
//!
//! **A pose** ([`Pose`]) is the mesh at one time: its points and the boxes of a bounding-volume
//! hierarchy *refitted* to them. The hierarchy's tree is built once, over the rest pose's
//! triangle centroids (median splits, four triangles a leaf); each pose only recomputes its
//! boxes, bottom-up, in `O(triangles)`. A step needs the poses at its start and end, kept in a
//! small cache so that the end of one step is the start of the next.
//!
//! **Contact over a step, in the surface's frame.** A rigid collider answers a particle moving
//! from `x0` to `x1` in its own moving frame (`contact.rs`): the start of the move is carried by
//! the collider's motion, so the move that is tested against the surface is the one *relative to
//! it*, and a surface sweeping over a still particle is caught like a particle moving through a
//! still surface. A deforming mesh has no one frame, so each particle takes the frame of the
//! triangle nearest its start: writing the start as `a + s e1 + t e2 + h n` over that triangle
//! at the step's start (corner `a`, edges `e1`, `e2`, unit normal `n`), the carried start is the
//! same combination over the triangle at the step's end. For a rigid motion this is exactly the
//! rigid frame's carry (every triangle moves with the body), so a mesh moved by its points along
//! a rigid motion answers as the same mesh moved by keys; on a deforming body it follows the
//! skin nearest the particle. The carried start and the particle's end are then tested against
//! the end pose as a still mesh's move is (the closest point, and a ray along the move for a
//! crossing, so a limb moving faster than a particle's radius per step does not pass through the
//! cloth). A particle farther from the surface at the step's start than its radius, its move and
//! the largest move of any point of the mesh over the step together cannot touch it during the
//! step and is not carried. The contact point's own move over the step (its barycentric
//! combination of the triangle's point moves) is the surface's velocity for friction and for the
//! work the collider does.
//!
//! **Inside.** A closed mesh's inside is decided by the angle-weighted pseudo-normal (Bærentzen
//! and Aanæs 2005) of the closest feature, computed for that feature only: the face's normal, an
//! edge's two faces', a vertex's faces weighted by their angles there.

use crate::math::{Real, Vec3};
use std::collections::HashMap;
use std::sync::{Arc, Mutex};

/// Where a deforming mesh's point motion comes from, for descriptions and the resolved scene.
#[derive(Clone, Debug, PartialEq)]
pub enum PointSource {
    /// An OBJ file per frame: the pattern with its run of `#` standing for the frame number
    /// (scene `sequence`; the scene reader gives the absolute path).
    Sequence(String),
    /// A PC2 or MDD point cache applied to the rest mesh (scene `cache`; absolute path).
    Cache(String),
}

/// The motion of a mesh collider's points: one position per vertex of the rest mesh per frame,
/// in the file's own units and coordinates.
#[derive(Clone, Debug, PartialEq)]
pub struct PointMotion {
    /// Where the frames were read from.
    pub source: PointSource,
    /// Frames per second of the motion itself, 1/s (scene `frame_rate`, required; range
    /// [1e-3, 1e5]). A cache's own header timing is ignored.
    pub frame_rate: Real,
    /// Scene time of frame 0, s (scene `start`, default 0; range [-1e6, 1e6]).
    pub start: Real,
    /// The frames' points, file coordinates; every frame has the rest mesh's vertex count.
    pub frames: Arc<Vec<Vec<Vec3>>>,
}

impl PointMotion {
    /// The frame interval holding time `t` (s): frames `i` and `i + 1` and the weight of
    /// `i + 1` in [0, 1) (held at the ends).
    pub fn segment(&self, t: Real) -> (usize, usize, Real) {
        let last = self.frames.len().saturating_sub(1);
        let u = (t - self.start) * self.frame_rate;
        if u.is_nan() || u <= 0.0 || last == 0 {
            return (0, 0, 0.0);
        }
        if u >= last as Real {
            return (last, last, 0.0);
        }
        let i = u.floor() as usize;
        (i, i + 1, u - i as Real)
    }
}

/// An axis-aligned box, `[min, max]`.
type Aabb = [Vec3; 2];

/// A node of the hierarchy: a leaf over `count > 0` triangles of the order from `first`, or an
/// inner node whose left child is the next node and whose right child is node `first`.
#[derive(Clone, Copy, Debug)]
struct Node {
    first: u32,
    count: u32,
}

/// The mesh at one time: its points (the mesh's own frame, scaled to metres) and the refitted
/// boxes of the hierarchy's nodes.
#[derive(Debug)]
pub struct Pose {
    /// The time of the pose, s.
    pub time: Real,
    /// The points, one per merged vertex.
    pub points: Vec<Vec3>,
    boxes: Vec<Aabb>,
}

/// The deformation of a mesh collider: its topology (vertices merged, triangles wound outwards
/// on a closed mesh), the hierarchy's tree, every frame's points, and the recent poses.
pub struct Deform {
    /// The motion as given (for descriptions and the outputs).
    pub motion: PointMotion,
    /// FNV-1a digest of the motion's frames (their count, then every coordinate's bits), to
    /// name their copy in a run folder.
    pub points_digest: u64,
    /// Each file vertex's merged vertex.
    remap: Vec<u32>,
    /// Each frame's merged points, scaled to metres.
    frames: Vec<Vec<Vec3>>,
    tris: Vec<[u32; 3]>,
    closed: bool,
    nodes: Vec<Node>,
    order: Vec<u32>,
    /// The triangles around each merged vertex (CSR: `vert_tris[vert_start[v]..vert_start[v+1]]`).
    vert_start: Vec<u32>,
    vert_tris: Vec<u32>,
    /// The (at most two) triangles of each undirected edge.
    edge_tris: HashMap<(u32, u32), [u32; 2]>,
    cache: Mutex<Vec<Arc<Pose>>>,
}

impl std::fmt::Debug for Deform {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Deform")
            .field("source", &self.motion.source)
            .field("frames", &self.frames.len())
            .field("triangles", &self.tris.len())
            .field("closed", &self.closed)
            .finish()
    }
}

/// How many poses a deforming mesh keeps (a step's start and end, and the step after's end).
const POSES_KEPT: usize = 4;

/// A contact of a particle with a deforming mesh over a step (the mesh's frame).
#[derive(Clone, Copy, Debug)]
pub struct SweptContact {
    /// Signed distance of the particle's end from the surface, m.
    pub distance: Real,
    /// Unit normal towards the side the particle came from.
    pub normal: Vec3,
    /// The particle's start carried to the step's end by the surface nearest it.
    pub from: Vec3,
    /// The contact point's move over the step, m.
    pub moved: Vec3,
}

/// Where the closest point is on its triangle.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Feature {
    Face,
    Edge(u32, u32),
    Vertex(u32),
}

/// The closest point on the triangle `a b c` to `p`, its barycentric weights and its feature
/// (Ericson, *Real-Time Collision Detection*, 5.1.5); corners given as local 0, 1, 2.
fn closest_on_triangle(p: Vec3, a: Vec3, b: Vec3, c: Vec3) -> (Vec3, [Real; 3], Feature) {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return (a, [1.0, 0.0, 0.0], Feature::Vertex(0));
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return (b, [0.0, 1.0, 0.0], Feature::Vertex(1));
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return (a + ab * v, [1.0 - v, v, 0.0], Feature::Edge(0, 1));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return (c, [0.0, 0.0, 1.0], Feature::Vertex(2));
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return (a + ac * w, [1.0 - w, 0.0, w], Feature::Edge(0, 2));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (b + (c - b) * w, [0.0, 1.0 - w, w], Feature::Edge(1, 2));
    }
    let denom = 1.0 / (va + vb + vc);
    let (v, w) = (vb * denom, vc * denom);
    (a + ab * v + ac * w, [1.0 - v - w, v, w], Feature::Face)
}

/// Squared distance from `p` to the box `b` (0 inside).
#[inline]
fn box_distance2(b: &Aabb, p: Vec3) -> Real {
    let d = (b[0] - p).max(Vec3::ZERO).max(p - b[1]);
    d.length_squared()
}

/// Whether the segment from `p` along `d` (parameter in [0, 1]) meets the box `b`.
#[inline]
fn segment_hits_box(b: &Aabb, p: Vec3, d: Vec3) -> bool {
    let (mut lo, mut hi) = (0.0, 1.0);
    for k in 0..3 {
        let (o, v, mn, mx) = (p[k], d[k], b[0][k], b[1][k]);
        if v.abs() < 1e-300 {
            if o < mn || o > mx {
                return false;
            }
        } else {
            let (mut t0, mut t1) = ((mn - o) / v, (mx - o) / v);
            if t0 > t1 {
                std::mem::swap(&mut t0, &mut t1);
            }
            lo = Real::max(lo, t0);
            hi = Real::min(hi, t1);
            if lo > hi {
                return false;
            }
        }
    }
    true
}

/// The closest point found so far: squared distance, point, triangle, weights, feature.
type Closest = (Real, Vec3, u32, [Real; 3], Feature);

impl Deform {
    /// The deformation of a mesh of file `vertices` and `triangles` (indices from 0) scaled by
    /// `scale`, moved by `motion` (whose frames the caller has checked to have the vertex
    /// count). Vertices with identical rest coordinates are merged (a texture seam), zero-area
    /// rest triangles dropped, and a closed mesh's parts wound outwards, as a still mesh's.
    pub(crate) fn new(
        vertices: &[Vec3],
        triangles: &[[u32; 3]],
        scale: Real,
        motion: PointMotion,
    ) -> Self {
        let mut index_of: HashMap<[u64; 3], u32> = HashMap::new();
        let mut first_of: Vec<usize> = Vec::new();
        let remap: Vec<u32> = vertices
            .iter()
            .enumerate()
            .map(|(i, v)| {
                let p = *v * scale;
                *index_of
                    .entry([p.x.to_bits(), p.y.to_bits(), p.z.to_bits()])
                    .or_insert_with(|| {
                        first_of.push(i);
                        (first_of.len() - 1) as u32
                    })
            })
            .collect();
        let rest: Vec<Vec3> = first_of.iter().map(|&i| vertices[i] * scale).collect();
        let mut tris: Vec<[u32; 3]> = triangles
            .iter()
            .map(|t| t.map(|i| remap[i as usize]))
            .filter(|t| {
                let [a, b, c] = t.map(|i| rest[i as usize]);
                (b - a).cross(c - a).length_squared() > 0.0
            })
            .collect();
        let closed = super::mesh::closed_and_oriented(&rest, &mut tris);
        let frames: Vec<Vec<Vec3>> = motion
            .frames
            .iter()
            .map(|f| first_of.iter().map(|&i| f[i] * scale).collect())
            .collect();
        // Adjacency for the pseudo-normals.
        let mut vert_start = vec![0u32; rest.len() + 1];
        for t in &tris {
            for &v in t {
                vert_start[v as usize + 1] += 1;
            }
        }
        for v in 0..rest.len() {
            vert_start[v + 1] += vert_start[v];
        }
        let mut fill = vert_start.clone();
        let mut vert_tris = vec![0u32; vert_start[rest.len()] as usize];
        let mut edge_tris: HashMap<(u32, u32), [u32; 2]> = HashMap::new();
        for (k, t) in tris.iter().enumerate() {
            for (j, &v) in t.iter().enumerate() {
                vert_tris[fill[v as usize] as usize] = k as u32;
                fill[v as usize] += 1;
                let w = t[(j + 1) % 3];
                let e = edge_tris
                    .entry((v.min(w), v.max(w)))
                    .or_insert([u32::MAX; 2]);
                if e[0] == u32::MAX {
                    e[0] = k as u32;
                } else {
                    e[1] = k as u32;
                }
            }
        }
        let points_digest = {
            let mut h: u64 = 0xcbf2_9ce4_8422_2325;
            let mut eat = |x: u64| {
                for b in x.to_le_bytes() {
                    h ^= u64::from(b);
                    h = h.wrapping_mul(0x0000_0100_0000_01b3);
                }
            };
            eat(motion.frames.len() as u64);
            for f in motion.frames.iter() {
                for p in f {
                    for c in p.to_array() {
                        eat(c.to_bits());
                    }
                }
            }
            h
        };
        let mut d = Self {
            points_digest,
            motion,
            remap,
            frames,
            tris,
            closed,
            nodes: Vec::new(),
            order: Vec::new(),
            vert_start,
            vert_tris,
            edge_tris,
            cache: Mutex::new(Vec::new()),
        };
        d.build_tree(&rest);
        d
    }

    /// Whether the mesh is a closed solid.
    pub fn is_closed(&self) -> bool {
        self.closed
    }

    /// Number of triangles in the queries.
    pub fn triangle_count(&self) -> usize {
        self.tris.len()
    }

    fn build_tree(&mut self, rest: &[Vec3]) {
        let centroids: Vec<Vec3> = self
            .tris
            .iter()
            .map(|t| t.map(|i| rest[i as usize]).iter().sum::<Vec3>() / 3.0)
            .collect();
        let mut order: Vec<u32> = (0..self.tris.len() as u32).collect();
        let mut nodes = Vec::new();
        fn split(order: &mut [u32], offset: u32, c: &[Vec3], nodes: &mut Vec<Node>) {
            let me = nodes.len();
            nodes.push(Node {
                first: offset,
                count: order.len() as u32,
            });
            if order.len() <= 4 {
                return;
            }
            let (mut lo, mut hi) = (Vec3::splat(Real::INFINITY), Vec3::splat(-Real::INFINITY));
            for &t in order.iter() {
                lo = lo.min(c[t as usize]);
                hi = hi.max(c[t as usize]);
            }
            let ext = hi - lo;
            let axis = if ext.x >= ext.y && ext.x >= ext.z {
                0
            } else if ext.y >= ext.z {
                1
            } else {
                2
            };
            let mid = order.len() / 2;
            order.select_nth_unstable_by(mid, |&a, &b| {
                c[a as usize][axis]
                    .total_cmp(&c[b as usize][axis])
                    .then(a.cmp(&b))
            });
            let (left, right) = order.split_at_mut(mid);
            split(left, offset, c, nodes);
            let r = nodes.len() as u32;
            split(right, offset + mid as u32, c, nodes);
            nodes[me] = Node { first: r, count: 0 };
        }
        if !order.is_empty() {
            split(&mut order, 0, &centroids, &mut nodes);
        }
        self.nodes = nodes;
        self.order = order;
    }

    /// Each frame's scene time (s) and merged points (the mesh's own coordinates, m).
    pub(crate) fn frames(&self) -> impl Iterator<Item = (Real, &[Vec3])> {
        self.frames.iter().enumerate().map(|(i, f)| {
            (
                self.motion.start + i as Real / self.motion.frame_rate,
                f.as_slice(),
            )
        })
    }

    /// The mesh's points at time `t` (s), frames interpolated linearly.
    fn points_at(&self, t: Real) -> Vec<Vec3> {
        let (i, j, w) = self.motion.segment(t);
        if w == 0.0 {
            return self.frames[i].clone();
        }
        self.frames[i]
            .iter()
            .zip(&self.frames[j])
            .map(|(a, b)| *a + (*b - *a) * w)
            .collect()
    }

    /// The pose at time `t` (s): from the cache when a recent step asked for the same time.
    pub fn pose(&self, t: Real) -> Arc<Pose> {
        if let Ok(cache) = self.cache.lock()
            && let Some(p) = cache.iter().find(|p| p.time.to_bits() == t.to_bits())
        {
            return p.clone();
        }
        let points = self.points_at(t);
        let mut boxes = vec![[Vec3::ZERO; 2]; self.nodes.len()];
        for k in (0..self.nodes.len()).rev() {
            let n = self.nodes[k];
            boxes[k] = if n.count > 0 {
                let mut b = [Vec3::splat(Real::INFINITY), Vec3::splat(-Real::INFINITY)];
                for &t in &self.order[n.first as usize..(n.first + n.count) as usize] {
                    for &v in &self.tris[t as usize] {
                        let p = points[v as usize];
                        b = [b[0].min(p), b[1].max(p)];
                    }
                }
                b
            } else {
                let (l, r) = (boxes[k + 1], boxes[n.first as usize]);
                [l[0].min(r[0]), l[1].max(r[1])]
            };
        }
        let pose = Arc::new(Pose {
            time: t,
            points,
            boxes,
        });
        if let Ok(mut cache) = self.cache.lock() {
            if cache.len() >= POSES_KEPT {
                cache.remove(0);
            }
            cache.push(pose.clone());
        }
        pose
    }

    /// The largest move of any point between two poses, m.
    pub fn max_move(&self, a: &Pose, b: &Pose) -> Real {
        a.points
            .iter()
            .zip(&b.points)
            .map(|(p, q)| (*q - *p).length_squared())
            .fold(0.0, Real::max)
            .sqrt()
    }

    /// The file's vertices at pose `p` (for drawing), one per file vertex.
    pub fn file_points(&self, p: &Pose) -> Vec<Vec3> {
        self.remap.iter().map(|&i| p.points[i as usize]).collect()
    }

    fn corners(&self, p: &Pose, t: u32) -> [Vec3; 3] {
        self.tris[t as usize].map(|i| p.points[i as usize])
    }

    fn face_normal(&self, p: &Pose, t: u32) -> Vec3 {
        let [a, b, c] = self.corners(p, t);
        (b - a).cross(c - a).normalize_or(Vec3::Y)
    }

    /// The closest surface point of pose `p` to `q` within `max_dist` (m).
    fn closest(&self, p: &Pose, q: Vec3, max_dist: Real) -> Option<Closest> {
        if self.nodes.is_empty() {
            return None;
        }
        let mut best: Option<Closest> = None;
        let mut bound = if max_dist.is_finite() {
            max_dist * max_dist
        } else {
            Real::INFINITY
        };
        let mut stack: Vec<u32> = Vec::with_capacity(64);
        stack.push(0);
        while let Some(k) = stack.pop() {
            if box_distance2(&p.boxes[k as usize], q) > bound {
                continue;
            }
            let n = self.nodes[k as usize];
            if n.count > 0 {
                for &t in &self.order[n.first as usize..(n.first + n.count) as usize] {
                    let [a, b, c] = self.corners(p, t);
                    let (cp, w, f) = closest_on_triangle(q, a, b, c);
                    let d2 = (q - cp).length_squared();
                    if d2 <= bound && best.is_none_or(|b| d2 < b.0) {
                        bound = d2;
                        best = Some((d2, cp, t, w, f));
                    }
                }
            } else {
                // Nearer child last, so it is searched first.
                let (l, r) = (k + 1, n.first);
                let (dl, dr) = (
                    box_distance2(&p.boxes[l as usize], q),
                    box_distance2(&p.boxes[r as usize], q),
                );
                if dl <= dr {
                    stack.push(r);
                    stack.push(l);
                } else {
                    stack.push(l);
                    stack.push(r);
                }
            }
        }
        best
    }

    /// The first crossing of the segment from `q0` to `q1` with pose `p`'s triangles: its
    /// parameter in [0, 1] and triangle.
    fn ray(&self, p: &Pose, q0: Vec3, q1: Vec3) -> Option<(Real, u32)> {
        let d = q1 - q0;
        let mut best: Option<(Real, u32)> = None;
        let mut stack: Vec<u32> = vec![0];
        while let Some(k) = stack.pop() {
            if !segment_hits_box(&p.boxes[k as usize], q0, d) {
                continue;
            }
            let n = self.nodes[k as usize];
            if n.count == 0 {
                stack.push(n.first);
                stack.push(k + 1);
                continue;
            }
            for &t in &self.order[n.first as usize..(n.first + n.count) as usize] {
                let [a, b, c] = self.corners(p, t);
                // Moller-Trumbore, two-sided.
                let (e1, e2) = (b - a, c - a);
                let h = d.cross(e2);
                let det = e1.dot(h);
                if det.abs() < 1e-300 {
                    continue;
                }
                let inv = 1.0 / det;
                let s = q0 - a;
                let u = s.dot(h) * inv;
                if !(0.0..=1.0).contains(&u) {
                    continue;
                }
                let qv = s.cross(e1);
                let v = d.dot(qv) * inv;
                if v < 0.0 || u + v > 1.0 {
                    continue;
                }
                let at = e2.dot(qv) * inv;
                if (0.0..=1.0).contains(&at) && best.is_none_or(|(b, bt)| (at, t) < (b, bt)) {
                    best = Some((at, t));
                }
            }
        }
        best
    }

    /// The angle-weighted pseudo-normal of the closest feature (see the module docs).
    fn pseudo_normal(&self, p: &Pose, tri: u32, f: Feature) -> Vec3 {
        let t = self.tris[tri as usize];
        match f {
            Feature::Face => self.face_normal(p, tri),
            Feature::Edge(i, j) => {
                let (a, b) = (t[i as usize], t[j as usize]);
                match self.edge_tris.get(&(a.min(b), a.max(b))) {
                    Some(&[u, w]) if w != u32::MAX => {
                        self.face_normal(p, u) + self.face_normal(p, w)
                    }
                    _ => self.face_normal(p, tri),
                }
            }
            Feature::Vertex(i) => {
                let v = t[i as usize];
                let range =
                    self.vert_start[v as usize] as usize..self.vert_start[v as usize + 1] as usize;
                let mut sum = Vec3::ZERO;
                for &k in &self.vert_tris[range] {
                    let tk = self.tris[k as usize];
                    let j = tk.iter().position(|&x| x == v).unwrap_or(0);
                    let o = p.points[v as usize];
                    let e1 = p.points[tk[(j + 1) % 3] as usize] - o;
                    let e2 = p.points[tk[(j + 2) % 3] as usize] - o;
                    let angle = e1.angle_between(e2);
                    sum += self.face_normal(p, k) * angle;
                }
                sum
            }
        }
    }

    /// Signed distance and normal of `q` from its closest point `(c, tri, feature)`.
    fn signed(&self, p: &Pose, q: Vec3, c: Vec3, tri: u32, f: Feature) -> (Real, Vec3) {
        let diff = q - c;
        let dist = diff.length();
        if dist <= 1e-12 * (1.0 + c.abs().max_element()) {
            return (0.0, self.face_normal(p, tri));
        }
        let n = diff / dist;
        if self.closed && diff.dot(self.pseudo_normal(p, tri, f)) < 0.0 {
            (-dist, -n)
        } else {
            (dist, n)
        }
    }

    /// Signed distance of `q` from pose `p` (negative inside a closed mesh) and the unit normal
    /// from the surface towards `q`.
    pub fn distance(&self, p: &Pose, q: Vec3) -> (Real, Vec3) {
        match self.closest(p, q, Real::INFINITY) {
            Some((_, c, tri, _, f)) => self.signed(p, q, c, tri, f),
            None => (Real::INFINITY, Vec3::Y),
        }
    }

    /// `q0` (at pose `a`) carried to pose `b` by the triangle nearest it within `reach` (m):
    /// the same combination of that triangle's corner, edges and unit normal. `None` when no
    /// triangle is that near.
    pub fn carry(&self, a: &Pose, b: &Pose, q0: Vec3, reach: Real) -> Option<Vec3> {
        let (_, _, tri, _, _) = self.closest(a, q0, reach)?;
        Some(self.carry_by(a, b, tri, q0))
    }

    fn carry_by(&self, a: &Pose, b: &Pose, tri: u32, q0: Vec3) -> Vec3 {
        let (s, t, h) = self.coordinates(a, tri, q0);
        self.place(b, tri, s, t, h)
    }

    /// `q` as `a + s e1 + t e2 + h n` over triangle `tri` of pose `p` (corner `a`, edges `e1`,
    /// `e2`, unit normal `n`): `(s, t, h)`; a degenerate triangle gives its corner's offset.
    fn coordinates(&self, p: &Pose, tri: u32, q: Vec3) -> (Real, Real, Real) {
        let [a, b, c] = self.corners(p, tri);
        let (e1, e2) = (b - a, c - a);
        let n = e1.cross(e2);
        let n2 = n.length_squared();
        let r = q - a;
        if n2 == 0.0 {
            return (0.0, 0.0, r.length());
        }
        // r = s e1 + t e2 + h n (n not unit here): solved by the cross products.
        let s = r.cross(e2).dot(n) / n2;
        let t = e1.cross(r).dot(n) / n2;
        (s, t, r.dot(n) / n2.sqrt())
    }

    /// The point `a + s e1 + t e2 + h n` over triangle `tri` of pose `p` (see
    /// [`Deform::bind`]).
    pub fn place(&self, p: &Pose, tri: u32, s: Real, t: Real, h: Real) -> Vec3 {
        let [a, b, c] = self.corners(p, tri);
        let (f1, f2) = (b - a, c - a);
        let m = f1.cross(f2).normalize_or(Vec3::Y);
        a + f1 * s + f2 * t + m * h
    }

    /// The triangle of pose `p` nearest `q` and `q`'s place over it, `(tri, s, t, h)`: `q` is
    /// `a + s e1 + t e2 + h n` over its corner `a`, edges `e1`, `e2` and unit normal `n`.
    pub fn bind(&self, p: &Pose, q: Vec3) -> (u32, Real, Real, Real) {
        let tri = self
            .closest(p, q, Real::INFINITY)
            .map_or(0, |(_, _, tri, _, _)| tri);
        let (s, t, h) = self.coordinates(p, tri, q);
        (tri, s, t, h)
    }

    /// The contact of a particle moving from `q0` (at pose `a`) to `q1` (at pose `b`) within
    /// `reach` (m) of the surface, in the surface's frame (see the module docs); `max_move` is
    /// the largest move of any point from `a` to `b` (m).
    pub fn swept_contact(
        &self,
        a: &Pose,
        b: &Pose,
        max_move: Real,
        q0: Vec3,
        q1: Vec3,
        reach: Real,
    ) -> Option<SweptContact> {
        let same = std::ptr::eq(a, b);
        let from = if same {
            q0
        } else {
            let near = reach + (q1 - q0).length() + max_move;
            self.carry(a, b, q0, near)?
        };
        let step = q1 - from;
        let len = step.length();
        let (_, c, tri, w, f) = self.closest(b, q1, reach.max(len))?;
        let moved = |tri: u32, w: [Real; 3]| {
            if same {
                return Vec3::ZERO;
            }
            let t = self.tris[tri as usize];
            (0..3)
                .map(|k| (b.points[t[k] as usize] - a.points[t[k] as usize]) * w[k])
                .sum()
        };
        if len > 0.0
            && (q1 - c).length() <= len
            && let Some((at, hit)) = self.ray(b, from, q1)
        {
            let x = from + step * at;
            let face = self.face_normal(b, hit);
            let side = (from - x).dot(face);
            let n = if side > 0.0 {
                Some(face)
            } else if side < 0.0 && !self.closed {
                Some(-face)
            } else {
                None
            };
            if let Some(n) = n {
                let [p0, p1, p2] = self.corners(b, hit);
                let (_, wh, _) = closest_on_triangle(x, p0, p1, p2);
                return Some(SweptContact {
                    distance: (q1 - x).dot(n),
                    normal: n,
                    from,
                    moved: moved(hit, wh),
                });
            }
        }
        let (distance, normal) = self.signed(b, q1, c, tri, f);
        Some(SweptContact {
            distance,
            normal,
            from,
            moved: moved(tri, w),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A unit cube's 8 corners and 12 triangles wound outwards.
    fn cube() -> (Vec<Vec3>, Vec<[u32; 3]>) {
        let v = (0..8)
            .map(|i| {
                Vec3::new(
                    (i & 1) as Real - 0.5,
                    ((i >> 1) & 1) as Real - 0.5,
                    ((i >> 2) & 1) as Real - 0.5,
                )
            })
            .collect();
        let quads = [
            [0, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
        ];
        let t = quads
            .iter()
            .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
            .collect();
        (v, t)
    }

    fn motion(frames: Vec<Vec<Vec3>>) -> PointMotion {
        PointMotion {
            source: PointSource::Sequence("test_##.obj".into()),
            frame_rate: 10.0,
            start: 0.0,
            frames: Arc::new(frames),
        }
    }

    /// A cube growing frame by frame: distances and the inside test agree with the box's closed
    /// form at the interpolated size, and a surface point's carry follows the scaling.
    #[test]
    fn a_growing_cube_answers_as_a_box_of_its_size() {
        let (v, t) = cube();
        let frames = (0..3)
            .map(|k| v.iter().map(|p| *p * (1.0 + k as Real)).collect())
            .collect();
        let d = Deform::new(&v, &t, 1.0, motion(frames));
        assert!(d.is_closed());
        // At 0.15 s: between frames 1 and 2, half way: side 2.5, half 1.25.
        let p = d.pose(0.15);
        let (dist, n) = d.distance(&p, Vec3::new(2.0, 0.1, -0.2));
        assert!((dist - 0.75).abs() < 1e-12 && (n - Vec3::X).length() < 1e-12);
        let (dist, n) = d.distance(&p, Vec3::new(0.0, 1.0, 0.0));
        assert!((dist + 0.25).abs() < 1e-12 && (n - Vec3::Y).length() < 1e-12);
        // Held after the last frame and before the first.
        assert_eq!(d.distance(&d.pose(7.0), Vec3::new(2.0, 0.0, 0.0)).0, 0.5);
        assert_eq!(d.distance(&d.pose(-1.0), Vec3::new(2.0, 0.0, 0.0)).0, 1.5);
        // A point 0.1 above the top face at 0 s is carried 0.1 above it at 0.1 s.
        let (a, b) = (d.pose(0.0), d.pose(0.1));
        let q = d.carry(&a, &b, Vec3::new(0.2, 0.6, 0.1), 1.0).unwrap();
        assert!((q - Vec3::new(0.4, 1.1, 0.2)).length() < 1e-12, "{q}");
    }

    /// A face sweeping over a still point is caught as a crossing, from the side the point was
    /// on: the point ends outside at the surface, whatever the speed.
    #[test]
    fn a_fast_face_does_not_pass_a_point() {
        let (v, t) = cube();
        for shift in [0.01, 0.3, 5.0] {
            let frames = vec![v.clone(), v.iter().map(|p| *p + Vec3::X * shift).collect()];
            let d = Deform::new(&v, &t, 1.0, motion(frames));
            let (a, b) = (d.pose(0.0), d.pose(0.1));
            let q = Vec3::new(0.505, 0.0, 0.0);
            let c = d
                .swept_contact(&a, &b, d.max_move(&a, &b), q, q, 0.01)
                .unwrap();
            assert!(
                (c.distance + shift - 0.005).abs() < 1e-9,
                "{shift}: {}",
                c.distance
            );
            assert!((c.normal - Vec3::X).length() < 1e-12);
            assert!((c.moved - Vec3::X * shift).length() < 1e-12);
        }
    }
}
