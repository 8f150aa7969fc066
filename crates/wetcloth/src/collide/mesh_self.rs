//! Self-contact of a mesh cloth: vertex-triangle and edge-edge proximity, with the side each
//! pair belongs on taken from the step's start.
//!
//! The particle spheres of [`super::self_collision`] keep particles apart, but a garment's
//! edges (centimetres) are far longer than the spheres (millimetres): a sleeve's particles
//! pass between the torso's. Here the cloth is its triangles, `h = 2 * radius` thick: every
//! vertex closer than `h` to a triangle it is not a corner of, and every two edges sharing no
//! vertex closer than `h` to each other, are pushed apart by position corrections after the
//! step, as the sphere self-collision's are.
//!
//! **Which side.** A vertex belongs on the side of the triangle it was on at the step's start
//! (two edges: the side of the line through one the other was on). Each step the simulation
//! hands the positions at its start to [`MeshSelf::begin_step`]; a pair whose plane of contact
//! the step took the vertex (or edge) through is tested for a real crossing by continuous
//! collision: the times at which the four moving points are coplanar (a cubic in time, the
//! positions moving linearly over the step) are found by bisection between the cubic's turning
//! points, and at the first at which the vertex is inside the triangle (the two edges meet), the
//! pair crossed. A crossed pair is pushed back to the side it came from, however far the step
//! carried it (a patch thrown at a sheet at metres per second); any other pair closer than `h`
//! is pushed apart along the line between its closest points.
//!
//! **The push.** A contact moves its four points (vertex and triangle corners, or two edges'
//! ends) along one direction, by their barycentric weights times their inverse masses (held
//! particles do not move), so that it conserves momentum. All contacts are computed from the
//! same positions (Jacobi), each scaled by 1.5 over the most contacts any of its particles
//! takes part in (at most 1: a lone contact is not overshot), then summed per particle in the
//! contacts' order (fixed, whatever the thread count) and applied. The first iteration pushes
//! every pair closer than its distance (a cloth resting on itself stays where it lies instead
//! of falling a little and being thrown back); the next ones, at most [`MAX_ITERATIONS`] in
//! all, test only the pairs the last one moved, until none is short of its distance by more
//! than a hundredth of it.
//!
//! **Rest neighbours.** A pair closer at rest than `h` (a mesh finer than its thickness, a
//! sliver of a triangle) is not tested: the cloth's own tessellation does not push itself apart.
//! Its particles are left to the sphere self-collision, which keeps them at their rest distance.
//! Pairs that share a vertex, and the pairs of [`ExemptPairs`] (seams), are never tested.
//!
//! **Broad phase.** Each particle's box is the sweep of its move over the step, widened by a
//! skin of `2 h` (or half the mean edge at rest, if less); a triangle's or an edge's box holds
//! its corners'. Bounding volume hierarchies over the particles', triangles' and edges' boxes
//! (median splits, ties by index), traversed two at a time (particles against triangles,
//! edges against themselves) in independent subtrees over the thread pool, give every pair
//! whose boxes come within `h` of each other and whose distance could come within `h` while its
//! particles stay in their boxes: the candidate lists, sorted. They hold while every
//! particle's start and end positions stay in its box once a common move is taken away
//! (distances do not change when the whole cloth moves: a falling cloth keeps its lists). When
//! a few particles (a sixty-fourth at most) leave their boxes, theirs are widened, the
//! hierarchies refitted and the pairs the widening brings in added; more, or widening an
//! eighth of the particles since the build, and the lists are built again.
//!
//! **Pairs passed over.** Each pair keeps a distance it was at least apart at reference
//! positions (the build's, measured again at the first iteration's positions once more than a
//! quarter of the pairs came near): a pair farther apart there than `h` plus how far both its
//! sides have moved since is passed over untested, and one outside the slab of its triangle's
//! plane (the line through the other edge) on the side it started is let go before its closest
//! points are sought. After the first iteration, when every pair it found is short of `h` by
//! less than the slack less twice the largest move it made, no pair can be found by a second.
//!
//! Nothing here is saved: a checkpoint does not carry the lists and hierarchies, and since the
//! pairs passed over cannot touch and pairs that do not touch add nothing, a resumed run (or
//! one whose lists were built at other times) finds the same contacts in the same order and
//! continues bit for bit.
//!
//! Only the pairs a step brings within `h` (or through each other) are pushed, from where the
//! step started: a pair already on the wrong side at the step's start (left so by an earlier
//! step's unfinished iterations, or put there by the caller) is kept on that side.

use super::self_collision::ExemptPairs;
use crate::math::{Real, Soa, Vec3};
use crate::model::ClothMesh;
use rayon::prelude::*;

/// Most Jacobi iterations of the corrections per step.
pub const MAX_ITERATIONS: usize = 24;

/// The skin of the candidate lists, as a multiple of the thickness `h`...
const SKIN: Real = 2.0;

/// ... or of the mean edge at rest, if less (a mesh about as fine as it is thick would list
/// every particle with hundreds of triangles).
const SKIN_PER_EDGE: Real = 0.5;

/// A pair whose shortfall from its distance is below this share of it is resolved.
const SLACK: Real = 0.01;

/// Over-relaxation of the Jacobi iterations: each contact is scaled by this over the most
/// contacts any of its particles takes part in, at most 1 (a lone contact is not overshot).
const OMEGA: Real = 1.5;

/// Most boxes in a leaf of a hierarchy.
const LEAF: usize = 4;

/// A candidate pair: a vertex and a triangle, or two edges (indices into the mesh's edges).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Pair {
    a: u32,
    b: u32,
    /// Their distance when the lists were built, m.
    apart: Real,
}

/// One contact's correction: its four particles move by `amount[i] * direction`.
#[derive(Clone, Copy, Debug)]
struct Push {
    particles: [u32; 4],
    amount: [Real; 4],
    direction: Vec3,
    /// How far the pair is short of its distance, m.
    shortfall: Real,
}

/// A node of the hierarchy: a box, and either a run of boxes (`count > 0`) or two children (the
/// left one right after it, the right one at `right`).
#[derive(Clone, Copy, Debug, Default)]
struct Node {
    lo: Vec3,
    hi: Vec3,
    first: u32,
    count: u32,
    right: u32,
}

/// A bounding volume hierarchy over boxes, split at the median along the widest axis of their
/// centres (ties by index, so the same boxes build the same tree).
#[derive(Clone, Debug, Default)]
struct Bvh {
    nodes: Vec<Node>,
    order: Vec<u32>,
    /// The boxes, m.
    lo: Vec<Vec3>,
    hi: Vec<Vec3>,
}

impl Bvh {
    fn build(&mut self, lo: Vec<Vec3>, hi: Vec<Vec3>) {
        self.nodes.clear();
        self.order.clear();
        self.order.extend(0..lo.len() as u32);
        if !lo.is_empty() {
            // Twice each box's centre, by axis.
            let centres: Vec<[Real; 3]> = lo
                .iter()
                .zip(&hi)
                .map(|(a, b)| (*a + *b).to_array())
                .collect();
            self.split(&lo, &hi, &centres, 0, lo.len());
        }
        (self.lo, self.hi) = (lo, hi);
    }

    /// The node of boxes `order[first..end]`, its subtree after it; returns its index.
    fn split(
        &mut self,
        lo: &[Vec3],
        hi: &[Vec3],
        centres: &[[Real; 3]],
        first: usize,
        end: usize,
    ) -> u32 {
        let index = self.nodes.len();
        self.nodes.push(Node {
            first: first as u32,
            count: (end - first) as u32,
            ..Default::default()
        });
        if end - first <= LEAF {
            let (mut blo, mut bhi) = (Vec3::splat(Real::INFINITY), Vec3::splat(-Real::INFINITY));
            for &i in &self.order[first..end] {
                blo = blo.min(lo[i as usize]);
                bhi = bhi.max(hi[i as usize]);
            }
            (self.nodes[index].lo, self.nodes[index].hi) = (blo, bhi);
            return index as u32;
        }
        // Split at the median along the axis the centres spread most along.
        let (mut clo, mut chi) = ([Real::INFINITY; 3], [-Real::INFINITY; 3]);
        for &i in &self.order[first..end] {
            let c = centres[i as usize];
            for k in 0..3 {
                clo[k] = clo[k].min(c[k]);
                chi[k] = chi[k].max(c[k]);
            }
        }
        let extent = [chi[0] - clo[0], chi[1] - clo[1], chi[2] - clo[2]];
        let axis = if extent[0] >= extent[1] && extent[0] >= extent[2] {
            0
        } else if extent[1] >= extent[2] {
            1
        } else {
            2
        };
        let mid = (end - first) / 2;
        self.order[first..end].select_nth_unstable_by(mid, |&i, &j| {
            centres[i as usize][axis]
                .total_cmp(&centres[j as usize][axis])
                .then(i.cmp(&j))
        });
        self.nodes[index].count = 0;
        let left = self.split(lo, hi, centres, first, first + mid);
        let right = self.split(lo, hi, centres, first + mid, end);
        let (l, r) = (self.nodes[left as usize], self.nodes[right as usize]);
        let node = &mut self.nodes[index];
        (node.lo, node.hi, node.right) = (l.lo.min(r.lo), l.hi.max(r.hi), right);
        index as u32
    }

    /// Calls `hit` with every box overlapping `[lo, hi]`.
    fn query(&self, lo: Vec3, hi: Vec3, mut hit: impl FnMut(u32)) {
        if self.nodes.is_empty() {
            return;
        }
        // Depth-first; a tree of 2^22 boxes split at medians is 21 levels deep.
        let mut stack = [0u32; 64];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let index = stack[top];
            let node = &self.nodes[index as usize];
            if node.lo.cmpgt(hi).any() || lo.cmpgt(node.hi).any() {
                continue;
            }
            if node.count > 0 {
                for &i in self.items(index) {
                    let j = i as usize;
                    if !(self.lo[j].cmpgt(hi).any() || lo.cmpgt(self.hi[j]).any()) {
                        hit(i);
                    }
                }
            } else {
                stack[top] = index + 1;
                stack[top + 1] = node.right;
                top += 2;
            }
        }
    }

    /// The nodes' boxes again from their boxes' (children come after their parents).
    fn refit(&mut self) {
        for index in (0..self.nodes.len()).rev() {
            let node = self.nodes[index];
            let (lo, hi) = if node.count > 0 {
                let items = &self.order[node.first as usize..(node.first + node.count) as usize];
                items.iter().fold(
                    (Vec3::splat(Real::INFINITY), Vec3::splat(-Real::INFINITY)),
                    |(l, h), &i| (l.min(self.lo[i as usize]), h.max(self.hi[i as usize])),
                )
            } else {
                let (l, r) = (self.nodes[index + 1], self.nodes[node.right as usize]);
                (l.lo.min(r.lo), l.hi.max(r.hi))
            };
            (self.nodes[index].lo, self.nodes[index].hi) = (lo, hi);
        }
    }

    /// Whether node `a` of `self` and node `b` of `other` overlap, `self`'s grown by `grow`.
    #[inline]
    fn nodes_meet(&self, a: u32, other: &Bvh, b: u32, grow: Vec3) -> bool {
        let (p, q) = (&self.nodes[a as usize], &other.nodes[b as usize]);
        !((p.lo - grow).cmpgt(q.hi).any() || q.lo.cmpgt(p.hi + grow).any())
    }

    /// Whether box `i` of `self` and box `j` of `other` overlap, `self`'s grown by `grow`.
    #[inline]
    fn boxes_meet(&self, i: u32, other: &Bvh, j: u32, grow: Vec3) -> bool {
        let (i, j) = (i as usize, j as usize);
        !((self.lo[i] - grow).cmpgt(other.hi[j]).any()
            || other.lo[j].cmpgt(self.hi[i] + grow).any())
    }

    #[inline]
    fn items(&self, node: u32) -> &[u32] {
        let n = &self.nodes[node as usize];
        &self.order[n.first as usize..(n.first + n.count) as usize]
    }

    /// Calls `hit(i, j)` for every box `i` under node `a` of `self` and box `j` under node `b` of
    /// `other` that overlap, `self`'s grown by `grow`; with `same` (the tree against itself,
    /// `a` and `b` the same node or disjoint ones) each pair of distinct boxes once.
    fn pairs(
        &self,
        a: u32,
        other: &Bvh,
        b: u32,
        grow: Vec3,
        same: bool,
        hit: &mut impl FnMut(u32, u32),
    ) {
        if !self.nodes_meet(a, other, b, grow) {
            return;
        }
        let (p, q) = (&self.nodes[a as usize], &other.nodes[b as usize]);
        if same && a == b {
            if p.count > 0 {
                let items = self.items(a);
                for (k, &i) in items.iter().enumerate() {
                    for &j in &items[k + 1..] {
                        if self.boxes_meet(i, other, j, grow) {
                            hit(i, j);
                        }
                    }
                }
            } else {
                self.pairs(a + 1, other, a + 1, grow, same, hit);
                self.pairs(p.right, other, p.right, grow, same, hit);
                self.pairs(a + 1, other, p.right, grow, same, hit);
            }
            return;
        }
        match (p.count > 0, q.count > 0) {
            (true, true) => {
                for &i in self.items(a) {
                    for &j in other.items(b) {
                        if self.boxes_meet(i, other, j, grow) {
                            hit(i, j);
                        }
                    }
                }
            }
            // Down the inner node; of two, the wider.
            (false, true) => {
                self.pairs(a + 1, other, b, grow, same, hit);
                self.pairs(p.right, other, b, grow, same, hit);
            }
            (true, false) => {
                self.pairs(a, other, b + 1, grow, same, hit);
                self.pairs(a, other, q.right, grow, same, hit);
            }
            (false, false) => {
                if (p.hi - p.lo).max_element() >= (q.hi - q.lo).max_element() {
                    self.pairs(a + 1, other, b, grow, same, hit);
                    self.pairs(p.right, other, b, grow, same, hit);
                } else {
                    self.pairs(a, other, b + 1, grow, same, hit);
                    self.pairs(a, other, q.right, grow, same, hit);
                }
            }
        }
    }

    /// The pairs of overlapping boxes of `self` and `other` (`self`'s grown by `grow`; with
    /// `same`, `other` is `self` and each pair of distinct boxes comes once), as the pairs
    /// `keep(i, j)` makes of them (their `a` below the number of `self`'s boxes), sorted by
    /// `a` then `b`. The traversal is shared out over the pool as independent pairs of
    /// subtrees.
    fn collect(
        &self,
        other: &Bvh,
        grow: Real,
        same: bool,
        keep: impl Fn(u32, u32) -> Option<Pair> + Sync + Send,
    ) -> Vec<Pair> {
        if self.nodes.is_empty() || other.nodes.is_empty() {
            return Vec::new();
        }
        let grow = Vec3::splat(grow);
        // Independent tasks: pairs of subtrees, split a few levels down.
        let mut tasks = vec![(0u32, 0u32)];
        for _ in 0..6 {
            let mut next = Vec::with_capacity(4 * tasks.len());
            for &(a, b) in &tasks {
                let (p, q) = (&self.nodes[a as usize], &other.nodes[b as usize]);
                if same && a == b {
                    if p.count > 0 {
                        next.push((a, b));
                    } else {
                        next.extend([(a + 1, a + 1), (p.right, p.right), (a + 1, p.right)]);
                    }
                } else if !self.nodes_meet(a, other, b, grow) {
                    // Nothing under these two meets.
                } else if p.count == 0 {
                    next.extend([(a + 1, b), (p.right, b)]);
                } else if q.count == 0 {
                    next.extend([(a, b + 1), (a, q.right)]);
                } else {
                    next.push((a, b));
                }
            }
            tasks = next;
        }
        let task = |&(a, b): &(u32, u32)| {
            let mut found = Vec::new();
            self.pairs(a, other, b, grow, same, &mut |i, j| {
                if let Some(item) = keep(i, j) {
                    found.push(item);
                }
            });
            found
        };
        // Shared out by the boxes' count (the tasks are few, each large).
        let found: Vec<Vec<Pair>> = if crate::exec::use_pool(self.lo.len() + other.lo.len()) {
            tasks.par_iter().map(task).collect()
        } else {
            tasks.iter().map(task).collect()
        };
        // Counted into place by `a`, then each run sorted by `b`.
        let mut start = vec![0u32; self.lo.len() + 1];
        for p in found.iter().flatten() {
            start[p.a as usize + 1] += 1;
        }
        for i in 0..self.lo.len() {
            start[i + 1] += start[i];
        }
        let mut out = vec![Pair::default(); start[self.lo.len()] as usize];
        let mut fill = start.clone();
        for p in found.into_iter().flatten() {
            out[fill[p.a as usize] as usize] = p;
            fill[p.a as usize] += 1;
        }
        for w in start.windows(2) {
            out[w[0] as usize..w[1] as usize].sort_unstable_by_key(|p| p.b);
        }
        out
    }

    fn heap_bytes(&self) -> usize {
        self.nodes.capacity() * std::mem::size_of::<Node>()
            + self.order.capacity() * 4
            + (self.lo.capacity() + self.hi.capacity()) * std::mem::size_of::<Vec3>()
    }
}

/// Vertex-triangle and edge-edge self-contact of a mesh cloth (see the module docs): the
/// positions at the step's start, the candidate lists and their boxes, and scratch. Nothing of
/// it is saved in a checkpoint.
#[derive(Clone, Debug, Default)]
pub struct MeshSelf {
    /// The thickness `h`, m: the distance pairs are kept at.
    thickness: Real,
    /// How far the particles' boxes reach beyond their moves, m.
    skin: Real,
    /// Positions at the start of the step being taken, m.
    start: Soa,
    /// Whether the candidate lists are of the current exempt pairs.
    lists_valid: bool,
    /// The box each particle may be anywhere in while the lists hold, m, and how far that
    /// reaches from where the lists were built, m.
    lo: Vec<Vec3>,
    hi: Vec<Vec3>,
    reach: Vec<Real>,
    /// The edges at each particle: `vertex_edges[edge_start[k]..edge_start[k + 1]]`.
    edge_start: Vec<u32>,
    vertex_edges: Vec<u32>,
    /// Particles whose boxes were widened since the lists were built.
    repaired: usize,
    /// Candidate pairs: vertex-triangle, then edge-edge, each sorted.
    vertex_triangle: Vec<Pair>,
    edge_edge: Vec<Pair>,
    bvh: Bvh,
    edge_bvh: Bvh,
    vertex_bvh: Bvh,
    /// Scratch of the iterations.
    pushes: Vec<Push>,
    count: Vec<u32>,
    sum: Vec<Vec3>,
    touched: Vec<u32>,
    active: Vec<u32>,
    /// The end positions the lists were built at, m.
    built: Soa,
    /// The positions the pairs' distances were measured at, how far each particle has been
    /// from them during the step (m), and how many pairs the last step found near.
    reference: Soa,
    moved: Vec<Real>,
    near: usize,
    /// How many times the candidate lists were built.
    pub rebuilds: u64,
    /// How many times a few particles' boxes were widened instead.
    pub repairs: u64,
    /// Contacts found at the first iteration of the last step.
    pub contacts: usize,
}

impl MeshSelf {
    /// Self-contact of `mesh`, `thickness` (m) thick.
    pub fn new(mesh: &ClothMesh, thickness: Real) -> Self {
        let edge = mesh
            .edges
            .iter()
            .map(|&[a, b]| (mesh.rest[b as usize] - mesh.rest[a as usize]).length())
            .sum::<Real>()
            / mesh.edges.len().max(1) as Real;
        let n = mesh.len();
        let mut edge_start = vec![0u32; n + 1];
        for &[a, b] in &mesh.edges {
            edge_start[a as usize + 1] += 1;
            edge_start[b as usize + 1] += 1;
        }
        for k in 0..n {
            edge_start[k + 1] += edge_start[k];
        }
        let mut fill = edge_start.clone();
        let mut vertex_edges = vec![0u32; edge_start[n] as usize];
        for (e, &[a, b]) in mesh.edges.iter().enumerate() {
            for k in [a as usize, b as usize] {
                vertex_edges[fill[k] as usize] = e as u32;
                fill[k] += 1;
            }
        }
        Self {
            thickness,
            skin: (SKIN * thickness).min(SKIN_PER_EDGE * edge),
            edge_start,
            vertex_edges,
            ..Default::default()
        }
    }

    /// The thickness `h` pairs are kept apart by, m.
    pub fn thickness(&self) -> Real {
        self.thickness
    }

    /// Number of candidate pairs (vertex-triangle, edge-edge) in the current lists.
    pub fn candidate_count(&self) -> (usize, usize) {
        (self.vertex_triangle.len(), self.edge_edge.len())
    }

    /// Records the positions at the start of a step (m): the side each pair belongs on.
    pub fn begin_step(&mut self, x: &Soa) {
        self.start.clone_from(x);
    }

    /// Forgets the candidate lists (the exempt pairs changed, or the particles were moved).
    pub fn invalidate(&mut self) {
        self.lists_valid = false;
    }

    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        use std::mem::size_of;
        self.start.heap_bytes()
            + (self.lo.capacity() + self.hi.capacity() + self.sum.capacity()) * size_of::<Vec3>()
            + (self.vertex_triangle.capacity() + self.edge_edge.capacity()) * size_of::<Pair>()
            + self.pushes.capacity() * size_of::<Push>()
            + (self.count.capacity() + self.touched.capacity() + self.active.capacity()) * 4
            + self.bvh.heap_bytes()
            + self.edge_bvh.heap_bytes()
            + self.vertex_bvh.heap_bytes()
            + self.built.heap_bytes()
            + self.reference.heap_bytes()
            + (self.moved.capacity() + self.reach.capacity()) * size_of::<Real>()
            + (self.edge_start.capacity() + self.vertex_edges.capacity()) * 4
    }

    /// The particles whose start or end position, less `shift` (m), is out of its box.
    fn outside(&self, x: &Soa, shift: Vec3) -> Vec<u32> {
        let inside = |k: usize| {
            let (lo, hi) = (self.lo[k], self.hi[k]);
            let (a, b) = (self.start.get(k) - shift, x.get(k) - shift);
            lo.cmple(a).all() && a.cmple(hi).all() && lo.cmple(b).all() && b.cmple(hi).all()
        };
        (0..x.len() as u32)
            .filter(|&k| !inside(k as usize))
            .collect()
    }

    /// The tests a candidate pair passes, at the positions the lists were built at.
    fn filter<'a>(&'a self, mesh: &'a ClothMesh, exempt: &'a ExemptPairs) -> PairFilter<'a> {
        PairFilter {
            mesh,
            exempt,
            x: &self.built,
            reach: &self.reach,
            h: self.thickness,
        }
    }

    /// Builds the candidate lists for start positions `self.start` and end positions `x`.
    fn rebuild(&mut self, mesh: &ClothMesh, x: &Soa, exempt: &ExemptPairs) {
        self.rebuilds += 1;
        self.repaired = 0;
        self.lists_valid = true;
        self.built.clone_from(x);
        self.reference.clone_from(x);
        self.near = 0;
        let n = x.len();
        let h = self.thickness;
        let half_skin = Vec3::splat(0.5 * self.skin);
        self.lo.clear();
        self.hi.clear();
        for k in 0..n {
            let (a, b) = (self.start.get(k), x.get(k));
            self.lo.push(a.min(b) - half_skin);
            self.hi.push(a.max(b) + half_skin);
        }
        // How far each particle may be from its end position while the lists hold: to the
        // farthest corner of its box.
        self.reach.clear();
        self.reach.extend((0..n).map(|k| {
            let p = x.get(k);
            (p - self.lo[k]).max(self.hi[k] - p).length()
        }));
        let (tlo, thi) = self.triangle_boxes(mesh, 0..mesh.triangles.len());
        let (elo, ehi) = self.edge_boxes(mesh, 0..mesh.edges.len());
        let (vlo, vhi) = (self.lo.clone(), self.hi.clone());
        let (bvh, vertex_bvh, edge_bvh) = (&mut self.bvh, &mut self.vertex_bvh, &mut self.edge_bvh);
        let pooled = crate::exec::use_pool(n);
        both(
            pooled,
            || bvh.build(tlo, thi),
            || {
                both(
                    pooled,
                    || vertex_bvh.build(vlo, vhi),
                    || edge_bvh.build(elo, ehi),
                )
            },
        );
        let filter = self.filter(mesh, exempt);
        let (bvh, vertex_bvh, edge_bvh) = (&self.bvh, &self.vertex_bvh, &self.edge_bvh);
        // Vertex-triangle: every triangle whose box comes within h of the vertex's, and that
        // passes the filter; edge-edge: every two edges whose boxes come within h, each pair
        // once, the lower edge first.
        let (vertex_triangle, edge_edge) = both(
            pooled,
            || vertex_bvh.collect(bvh, h, false, |v, t| filter.vertex_triangle(v, t)),
            || edge_bvh.collect(edge_bvh, h, true, |e, f| filter.edge_edge(e, f)),
        );
        (self.vertex_triangle, self.edge_edge) = (vertex_triangle, edge_edge);
    }

    /// The boxes of triangles `range`: their corners' boxes together.
    fn triangle_boxes(
        &self,
        mesh: &ClothMesh,
        range: std::ops::Range<usize>,
    ) -> (Vec<Vec3>, Vec<Vec3>) {
        let (lo, hi) = (&self.lo, &self.hi);
        mesh.triangles[range]
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| i as usize);
                (lo[a].min(lo[b]).min(lo[c]), hi[a].max(hi[b]).max(hi[c]))
            })
            .unzip()
    }

    /// The boxes of edges `range`: their ends' boxes together.
    fn edge_boxes(
        &self,
        mesh: &ClothMesh,
        range: std::ops::Range<usize>,
    ) -> (Vec<Vec3>, Vec<Vec3>) {
        let (lo, hi) = (&self.lo, &self.hi);
        mesh.edges[range]
            .iter()
            .map(|&[a, b]| {
                let (a, b) = (a as usize, b as usize);
                (lo[a].min(lo[b]), hi[a].max(hi[b]))
            })
            .unzip()
    }

    /// Widens the boxes of the few particles `out` that left theirs to hold their start and end
    /// positions less `shift` (m), and adds the candidate pairs that widening brings in: the
    /// lists then hold as a rebuild's would, at a fraction of its cost.
    fn repair(
        &mut self,
        mesh: &ClothMesh,
        x: &Soa,
        exempt: &ExemptPairs,
        shift: Vec3,
        out: &[u32],
    ) {
        self.repairs += 1;
        self.repaired += out.len();
        let h = self.thickness;
        let half_skin = Vec3::splat(0.5 * self.skin);
        for &k in out {
            let k = k as usize;
            let (a, b) = (self.start.get(k) - shift, x.get(k) - shift);
            self.lo[k] = self.lo[k].min(a.min(b) - half_skin);
            self.hi[k] = self.hi[k].max(a.max(b) + half_skin);
            let p = self.built.get(k);
            self.reach[k] = (p - self.lo[k]).max(self.hi[k] - p).length();
            self.vertex_bvh.lo[k] = self.lo[k];
            self.vertex_bvh.hi[k] = self.hi[k];
        }
        // The triangles and edges of those particles, each once.
        let mut triangles: Vec<u32> = out
            .iter()
            .flat_map(|&k| mesh.triangles_of(k as usize).iter().copied())
            .collect();
        triangles.sort_unstable();
        triangles.dedup();
        let mut edges: Vec<u32> = out
            .iter()
            .flat_map(|&k| {
                let k = k as usize;
                self.vertex_edges[self.edge_start[k] as usize..self.edge_start[k + 1] as usize]
                    .iter()
                    .copied()
            })
            .collect();
        edges.sort_unstable();
        edges.dedup();
        for &t in &triangles {
            let (lo, hi) = self.triangle_boxes(mesh, t as usize..t as usize + 1);
            (self.bvh.lo[t as usize], self.bvh.hi[t as usize]) = (lo[0], hi[0]);
        }
        for &e in &edges {
            let (lo, hi) = self.edge_boxes(mesh, e as usize..e as usize + 1);
            (self.edge_bvh.lo[e as usize], self.edge_bvh.hi[e as usize]) = (lo[0], hi[0]);
        }
        self.bvh.refit();
        self.vertex_bvh.refit();
        self.edge_bvh.refit();
        let filter = self.filter(mesh, exempt);
        let grow = Vec3::splat(h);
        let mut vertex_triangle = Vec::new();
        for &v in out {
            let (lo, hi) = (self.lo[v as usize] - grow, self.hi[v as usize] + grow);
            self.bvh.query(lo, hi, |t| {
                vertex_triangle.extend(filter.vertex_triangle(v, t))
            });
        }
        for &t in &triangles {
            let (lo, hi) = (
                self.bvh.lo[t as usize] - grow,
                self.bvh.hi[t as usize] + grow,
            );
            self.vertex_bvh.query(lo, hi, |v| {
                vertex_triangle.extend(filter.vertex_triangle(v, t))
            });
        }
        let mut edge_edge = Vec::new();
        for &e in &edges {
            let (lo, hi) = (
                self.edge_bvh.lo[e as usize] - grow,
                self.edge_bvh.hi[e as usize] + grow,
            );
            self.edge_bvh.query(lo, hi, |f| {
                if f != e {
                    edge_edge.extend(filter.edge_edge(e, f));
                }
            });
        }
        // Their distances are of the lists' build, not of the reference: none known.
        for p in vertex_triangle.iter_mut().chain(edge_edge.iter_mut()) {
            p.apart = 0.0;
        }
        merge(&mut self.vertex_triangle, vertex_triangle);
        merge(&mut self.edge_edge, edge_edge);
    }

    /// Resolves the proximities of the mesh cloth `mesh` at positions `x` (m), the side of each
    /// pair taken from the positions [`MeshSelf::begin_step`] recorded (or `x` itself if none
    /// were). `inv_mass` weighs the moves; `held` particles do not move; the pairs of `exempt`
    /// are left alone. Returns the number of contacts found (at the first iteration).
    pub fn solve(
        &mut self,
        mesh: &ClothMesh,
        x: &mut Soa,
        inv_mass: &[Real],
        held: &[bool],
        exempt: &ExemptPairs,
    ) -> usize {
        let n = x.len();
        self.contacts = 0;
        if self.thickness <= 0.0 || n == 0 {
            return 0;
        }
        if self.start.len() != n {
            self.start.clone_from(x);
        }
        // Distances do not change when the whole cloth moves: the lists hold while the
        // particles stay in their boxes once a common move since they were built is taken
        // away (a falling cloth keeps its lists).
        let valid = self.lists_valid && self.lo.len() == n && self.built.len() == n;
        let shift = if valid {
            middle_move(x, &self.built)
        } else {
            Vec3::ZERO
        };
        let out = if valid {
            self.outside(x, shift)
        } else {
            Vec::new()
        };
        // A few particles out of their boxes: theirs widened; many, or boxes widened too often
        // since the lists were built: rebuilt.
        if !valid || out.len() > n / 64 || self.repaired + out.len() > n / 8 {
            self.rebuild(mesh, x, exempt);
        } else if !out.is_empty() {
            self.repair(mesh, x, exempt, shift, &out);
        }
        if self.vertex_triangle.is_empty() && self.edge_edge.is_empty() {
            return 0;
        }
        if self.count.len() != n {
            self.count = vec![0; n];
            self.sum = vec![Vec3::ZERO; n];
        }
        let im = |k: u32| {
            let k = k as usize;
            if held[k] { 0.0 } else { inv_mass[k] }
        };
        let h = self.thickness;
        let total = self.vertex_triangle.len() + self.edge_edge.len();
        // The pairs' distances (`apart`) are of the reference positions: those of the last
        // build, measured again (at the end positions, as the first iteration tests every
        // pair) once more than a quarter of the pairs came near.
        let remeasure = self.near * 4 > total;
        if remeasure {
            self.reference.clone_from(x);
        }
        // How far each particle has been from the reference (a common move taken away),
        // during the step: a pair that was farther apart there than its distance plus both
        // sides' moves cannot have come closer than its distance, nor crossed (the moves are
        // straight lines).
        let shift = middle_move(x, &self.reference);
        {
            let (x0, reference) = (&self.start, &self.reference);
            let xr = &*x;
            self.moved.clear();
            self.moved.extend((0..n).map(|k| {
                let b = reference.get(k) + shift;
                (x0.get(k) - b).length().max((xr.get(k) - b).length())
            }));
        }
        // The candidates to test: all of them first, then those with a particle the last
        // iteration moved (the others are as they were: apart); each passed over while it
        // cannot be within `h`.
        self.active.clear();
        for iteration in 0..MAX_ITERATIONS {
            let (x0, x1) = (&self.start, &*x);
            let (vt, ee) = (&self.vertex_triangle, &self.edge_edge);
            let (triangles, edges) = (&mesh.triangles, &mesh.edges);
            let particles = |i: usize| particles_of(vt, ee, triangles, edges, i);
            let moved = &self.moved;
            // Measuring every pair again: none passed over.
            let measure = remeasure && iteration == 0;
            let near = |i: usize, q: [u32; 4]| measure || may_touch(vt, ee, i, q, moved, h);
            // Every pair closer than its distance is pushed to it at the first iteration (a
            // cloth resting on itself is held where it lies); later iterations stop at a
            // shortfall of `SLACK`.
            let share = if iteration == 0 { 1.0 } else { 1.0 - SLACK };
            // A candidate's push, if any, and its distance (at least) if it was tested.
            let contact = |i: usize| -> (Option<Push>, Option<Real>) {
                let q = particles(i);
                let (push, apart) = if !near(i, q) {
                    return (None, None);
                } else if i < vt.len() {
                    vertex_triangle(x0, x1, q, h, h * share, im)
                } else {
                    edge_edge(x0, x1, q, h, h * share, im)
                };
                (push, Some(apart))
            };
            self.pushes.clear();
            let active = &self.active;
            let tested = if iteration == 0 { total } else { active.len() };
            let candidate = |j: usize| {
                if iteration == 0 {
                    j
                } else {
                    active[j] as usize
                }
            };
            let pooled = crate::exec::use_pool(tested);
            if measure {
                // Every pair's distance kept, as its distance at the new reference.
                let results: Vec<(Option<Push>, Option<Real>)> = if pooled {
                    (0..total)
                        .into_par_iter()
                        .with_min_len(512)
                        .map(contact)
                        .collect()
                } else {
                    (0..total).map(contact).collect()
                };
                let (vt_len, pushes) = (self.vertex_triangle.len(), &mut self.pushes);
                for (i, (push, apart)) in results.into_iter().enumerate() {
                    let pair = if i < vt_len {
                        &mut self.vertex_triangle[i]
                    } else {
                        &mut self.edge_edge[i - vt_len]
                    };
                    pair.apart = apart.unwrap_or(0.0);
                    pushes.extend(push);
                }
                self.near = 0;
            } else {
                let near_count = std::sync::atomic::AtomicUsize::new(0);
                let tally = |(push, apart): (Option<Push>, Option<Real>)| {
                    if iteration == 0 && apart.is_some() {
                        near_count.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                    }
                    push
                };
                if pooled {
                    self.pushes.par_extend(
                        (0..tested)
                            .into_par_iter()
                            .with_min_len(512)
                            .filter_map(|j| tally(contact(candidate(j)))),
                    );
                } else {
                    self.pushes
                        .extend((0..tested).filter_map(|j| tally(contact(candidate(j)))));
                }
                if iteration == 0 {
                    self.near = near_count.into_inner();
                }
            }
            if self.pushes.is_empty() {
                break;
            }
            if iteration == 0 {
                self.contacts = self.pushes.len();
            }
            // Each particle's number of contacts; each contact scaled by its busiest particle's.
            for push in &self.pushes {
                for (&k, &m) in push.particles.iter().zip(&push.amount) {
                    if m != 0.0 {
                        if self.count[k as usize] == 0 {
                            self.touched.push(k);
                        }
                        self.count[k as usize] += 1;
                    }
                }
            }
            for push in &self.pushes {
                let busiest = push
                    .particles
                    .iter()
                    .zip(&push.amount)
                    .filter(|&(_, &m)| m != 0.0)
                    .map(|(&k, _)| self.count[k as usize])
                    .max()
                    .unwrap_or(1);
                let scale = (OMEGA / busiest as Real).min(1.0);
                for (&k, &m) in push.particles.iter().zip(&push.amount) {
                    if m != 0.0 {
                        self.sum[k as usize] += push.direction * (m * scale);
                    }
                }
            }
            let mut largest_move: Real = 0.0;
            for &k in &self.touched {
                let k = k as usize;
                let p = x.get(k) + self.sum[k];
                largest_move = largest_move.max(self.sum[k].length());
                x.set(k, p);
                self.sum[k] = Vec3::ZERO;
                let b = self.reference.get(k) + shift;
                self.moved[k] = (self.start.get(k) - b).length().max((p - b).length());
            }
            // After the first iteration, every pair is short of `h` by at most the largest
            // shortfall it found plus the two sides' largest moves (no pair that was apart can
            // have come closer by more): when that is within the slack, the next iteration
            // would find nothing.
            let largest_shortfall = self.pushes.iter().map(|p| p.shortfall).fold(0.0, Real::max);
            if iteration == 0 && largest_shortfall + 2.0 * largest_move < SLACK * h {
                for &k in &self.touched {
                    self.count[k as usize] = 0;
                }
                self.touched.clear();
                break;
            }
            // The next iteration's candidates: those with a particle moved (`count` > 0) that
            // may now be within `h`.
            let (count, moved) = (&self.count, &self.moved);
            let (vt, ee) = (&self.vertex_triangle, &self.edge_edge);
            self.active.clear();
            self.active.extend(
                (0..total)
                    .filter(|&i| {
                        let q = particles_of(vt, ee, triangles, edges, i);
                        q.iter().any(|&k| count[k as usize] > 0)
                            && may_touch(vt, ee, i, q, moved, h)
                    })
                    .map(|i| i as u32),
            );
            for &k in &self.touched {
                self.count[k as usize] = 0;
            }
            self.touched.clear();
        }
        self.contacts
    }
}

/// The particles of candidate `i` of the vertex-triangle pairs `vt` then the edge-edge pairs
/// `ee`: the vertex and the triangle's corners, or the two edges' ends.
#[inline]
fn particles_of(
    vt: &[Pair],
    ee: &[Pair],
    triangles: &[[u32; 3]],
    edges: &[[u32; 2]],
    i: usize,
) -> [u32; 4] {
    if i < vt.len() {
        let p = vt[i];
        let [a, b, c] = triangles[p.b as usize];
        [p.a, a, b, c]
    } else {
        let p = ee[i - vt.len()];
        let [a, b] = edges[p.a as usize];
        let [c, d] = edges[p.b as usize];
        [a, b, c, d]
    }
}

/// The middle of the range of the moves from `from` to `x` (m) along each axis.
fn middle_move(x: &Soa, from: &Soa) -> Vec3 {
    let (mut lo, mut hi) = (Vec3::splat(Real::INFINITY), Vec3::splat(-Real::INFINITY));
    for k in 0..x.len() {
        let d = x.get(k) - from.get(k);
        lo = lo.min(d);
        hi = hi.max(d);
    }
    0.5 * (lo + hi)
}

/// Whether candidate `i` (of the vertex-triangle pairs `vt`, then the edge-edge pairs `ee`), of
/// particles `q`, may be within `h` (m): its distance at the lists' build less the farthest its
/// particles on each side have been since (`moved`, m) is below `h`.
#[inline]
fn may_touch(vt: &[Pair], ee: &[Pair], i: usize, q: [u32; 4], moved: &[Real], h: Real) -> bool {
    let m = |k: u32| moved[k as usize];
    if i < vt.len() {
        vt[i].apart - m(q[0]) - m(q[1]).max(m(q[2])).max(m(q[3])) < h
    } else {
        ee[i - vt.len()].apart - m(q[0]).max(m(q[1])) - m(q[2]).max(m(q[3])) < h
    }
}

/// The tests a candidate pair passes beyond its boxes', at positions `x` (where the lists were
/// built).
struct PairFilter<'a> {
    mesh: &'a ClothMesh,
    exempt: &'a ExemptPairs,
    x: &'a Soa,
    reach: &'a [Real],
    h: Real,
}

impl PairFilter<'_> {
    /// Vertex `v` and triangle `t`, unless `v` is a corner or an exempt partner of one, they
    /// cannot come within `h` while their particles stay in their boxes, or they were within
    /// `h` at rest.
    fn vertex_triangle(&self, v: u32, t: u32) -> Option<Pair> {
        let (mesh, h) = (self.mesh, self.h);
        let tri = &mesh.triangles[t as usize];
        let v = v as usize;
        if tri.contains(&(v as u32)) || self.exempt.any(v, tri) {
            return None;
        }
        let p = self.x.get(v);
        let [a, b, c] = tri.map(|i| self.x.get(i as usize));
        let w = closest_on_triangle(p, a, b, c);
        let d = (p - (a * w[0] + b * w[1] + c * w[2])).length();
        let [ra, rb, rc] = tri.map(|i| self.reach[i as usize]);
        if d > h + self.reach[v] + ra.max(rb).max(rc) {
            return None;
        }
        let [ra, rb, rc] = tri.map(|i| mesh.rest[i as usize]);
        let rp = mesh.rest[v];
        let wr = closest_on_triangle(rp, ra, rb, rc);
        if (rp - (ra * wr[0] + rb * wr[1] + rc * wr[2])).length() < h {
            return None;
        }
        Some(Pair {
            a: v as u32,
            b: t,
            apart: d,
        })
    }

    /// Edges `e` and `f` (either order; the pair names the lower first), unless they share a
    /// particle or an exempt pair, cannot come within `h`, or were within `h` at rest.
    fn edge_edge(&self, e: u32, f: u32) -> Option<Pair> {
        let (mesh, h) = (self.mesh, self.h);
        let (e, f) = (e.min(f), e.max(f));
        let [a, b] = mesh.edges[e as usize].map(|i| i as usize);
        let [c, d] = mesh.edges[f as usize].map(|i| i as usize);
        if c == a || c == b || d == a || d == b {
            return None;
        }
        let exempt = self.exempt;
        if exempt.any(a, &[c as u32, d as u32]) || exempt.any(b, &[c as u32, d as u32]) {
            return None;
        }
        let [pa, pb, pc, pd] = [a, b, c, d].map(|k| self.x.get(k));
        let (s, u) = closest_on_segments(pa, pb, pc, pd);
        let gap = (pa.lerp(pb, s) - pc.lerp(pd, u)).length();
        let r = self.reach;
        if gap > h + r[a].max(r[b]) + r[c].max(r[d]) {
            return None;
        }
        let r = [a, b, c, d].map(|i| mesh.rest[i]);
        let (s, u) = closest_on_segments(r[0], r[1], r[2], r[3]);
        if (r[0].lerp(r[1], s) - r[2].lerp(r[3], u)).length() < h {
            return None;
        }
        Some(Pair {
            a: e,
            b: f,
            apart: gap,
        })
    }
}

/// Adds `new` pairs to the sorted `list`, keeping it sorted by `(a, b)` and each pair once.
fn merge(list: &mut Vec<Pair>, mut new: Vec<Pair>) {
    if new.is_empty() {
        return;
    }
    new.sort_unstable_by_key(|p| (p.a, p.b));
    new.dedup_by_key(|p| (p.a, p.b));
    let old = std::mem::take(list);
    list.reserve(old.len() + new.len());
    let (mut i, mut j) = (0, 0);
    while i < old.len() || j < new.len() {
        let take_old =
            j == new.len() || (i < old.len() && (old[i].a, old[i].b) <= (new[j].a, new[j].b));
        if take_old {
            if j < new.len() && (old[i].a, old[i].b) == (new[j].a, new[j].b) {
                j += 1;
            }
            list.push(old[i]);
            i += 1;
        } else {
            list.push(new[j]);
            j += 1;
        }
    }
}

/// `(f(), g())`, side by side on the pool when `pooled`.
fn both<A: Send, B: Send>(
    pooled: bool,
    f: impl FnOnce() -> A + Send,
    g: impl FnOnce() -> B + Send,
) -> (A, B) {
    if pooled {
        rayon::join(f, g)
    } else {
        (f(), g())
    }
}

/// The sign of `v` as -1, 0 or 1.
#[inline]
fn sign(v: Real) -> Real {
    if v > 0.0 {
        1.0
    } else if v < 0.0 {
        -1.0
    } else {
        0.0
    }
}

/// The contact of vertex `q[0]` and triangle `q[1..4]` kept `target` (m) apart, from start
/// positions `x0` and end positions `x1`; `im` gives inverse masses. `None` when they are on
/// the right side, at least `reach` (m, at most `target`) apart. With it, a distance (m) they
/// are at least apart at `x1`.
#[inline]
fn vertex_triangle(
    x0: &Soa,
    x1: &Soa,
    q: [u32; 4],
    target: Real,
    reach: Real,
    im: impl Fn(u32) -> Real,
) -> (Option<Push>, Real) {
    let [p1, a1, b1, c1] = q.map(|k| x1.get(k as usize));
    let normal1 = (b1 - a1).cross(c1 - a1);
    let f1 = (p1 - a1).dot(normal1);
    let [p0, a0, b0, c0] = q.map(|k| x0.get(k as usize));
    let f0 = (p0 - a0).dot((b0 - a0).cross(c0 - a0));
    let flipped = (f0 > 0.0 && f1 < 0.0) || (f0 < 0.0 && f1 > 0.0);
    let length = normal1.length();
    // Outside the slab `reach` either side of the plane, on the side it started: apart.
    if !flipped && length > 0.0 && f1.abs() >= reach * length {
        return (None, f1.abs() / length);
    }
    let w = closest_on_triangle(p1, a1, b1, c1);
    let closest = a1 * w[0] + b1 * w[1] + c1 * w[2];
    let d = (p1 - closest).length();
    if d >= reach && !flipped {
        return (None, d);
    }
    let crossed = flipped
        && coplanar_time(
            [p0 - a0, p1 - a1],
            [b0 - a0, b1 - a1],
            [c0 - a0, c1 - a1],
            |t| {
                let [p, a, b, c] =
                    [(p0, p1), (a0, a1), (b0, b1), (c0, c1)].map(|(u, v)| lerp(u, v, t));
                inside_triangle(p, a, b, c)
            },
        );
    let (direction, shortfall) = if crossed {
        if length == 0.0 {
            return (None, d);
        }
        // Back to the start's side of the plane, `target` off it.
        let n = normal1 * (sign(f0) / length);
        (n, target - (p1 - a1).dot(n))
    } else {
        if d >= reach {
            return (None, d);
        }
        let n = if d > 1e-12 * target {
            (p1 - closest) / d
        } else {
            let side = if f0 != 0.0 { sign(f0) } else { sign(f1) };
            if length == 0.0 || side == 0.0 {
                return (None, d);
            }
            normal1 * (side / length)
        };
        (n, target - d)
    };
    let weight = [1.0, -w[0], -w[1], -w[2]];
    (push(q, weight, direction, shortfall, im), d)
}

/// The contact of edges `q[0..2]` and `q[2..4]` kept `target` (m) apart, and a distance they
/// are at least apart at `x1` (see [`vertex_triangle`]).
#[inline]
fn edge_edge(
    x0: &Soa,
    x1: &Soa,
    q: [u32; 4],
    target: Real,
    reach: Real,
    im: impl Fn(u32) -> Real,
) -> (Option<Push>, Real) {
    let [a1, b1, c1, d1] = q.map(|k| x1.get(k as usize));
    let m1 = (b1 - a1).cross(d1 - c1);
    let f1 = (c1 - a1).dot(m1);
    let [a0, b0, c0, d0] = q.map(|k| x0.get(k as usize));
    let m0 = (b0 - a0).cross(d0 - c0);
    let f0 = (c0 - a0).dot(m0);
    let flipped = (f0 > 0.0 && f1 < 0.0) || (f0 < 0.0 && f1 > 0.0);
    let length = m1.length();
    let across = length > 1e-6 * (b1 - a1).length() * (d1 - c1).length();
    // The lines through them (not near parallel) `reach` apart or more, on the sides they
    // started: apart.
    if !flipped && across && f1.abs() >= reach * length {
        return (None, f1.abs() / length);
    }
    let (s, u) = closest_on_segments(a1, b1, c1, d1);
    let (p, r) = (a1.lerp(b1, s), c1.lerp(d1, u));
    let d = (p - r).length();
    if d >= reach && !flipped {
        return (None, d);
    }
    let crossed = flipped
        && coplanar_time(
            [c0 - a0, c1 - a1],
            [b0 - a0, b1 - a1],
            [d0 - c0, d1 - c1],
            |t| {
                let [a, b, c, d] =
                    [(a0, a1), (b0, b1), (c0, c1), (d0, d1)].map(|(v, w)| lerp(v, w, t));
                let (s, u) = closest_on_segments(a, b, c, d);
                let gap = (a.lerp(b, s) - c.lerp(d, u)).length();
                gap <= 1e-6 * ((b - a).length() + (d - c).length())
            },
        );
    // The first edge's side of the second: `(a - c) . m`, that is `-f`.
    let (direction, shortfall) = if crossed {
        let n = if length > 1e-9 * (b1 - a1).length() * (d1 - c1).length() {
            m1 * (-sign(f0) / length)
        } else {
            let apart = a0.lerp(b0, s) - c0.lerp(d0, u);
            let l = apart.length();
            if l == 0.0 {
                return (None, d);
            }
            apart / l
        };
        (n, target - (p - r).dot(n))
    } else {
        if d >= reach {
            return (None, d);
        }
        let n = if d > 1e-12 * target {
            (p - r) / d
        } else {
            let side = if f0 != 0.0 { -sign(f0) } else { -sign(f1) };
            if length == 0.0 || side == 0.0 {
                return (None, d);
            }
            m1 * (side / length)
        };
        (n, target - d)
    };
    let weight = [1.0 - s, s, u - 1.0, -u];
    (push(q, weight, direction, shortfall, im), d)
}

/// The push moving particles `q` by `weight[i] * im(q[i]) * lambda` along `direction`, with
/// `lambda` such that the weighted sum of the moves along it is `shortfall` (m). Momentum is
/// conserved when the weights sum to zero. `None` if nothing can move.
#[inline]
fn push(
    q: [u32; 4],
    weight: [Real; 4],
    direction: Vec3,
    shortfall: Real,
    im: impl Fn(u32) -> Real,
) -> Option<Push> {
    if shortfall.is_nan() || shortfall <= 0.0 || !direction.is_finite() {
        return None;
    }
    let inv = q.map(&im);
    let denominator: Real = (0..4).map(|i| weight[i] * weight[i] * inv[i]).sum();
    if denominator.is_nan() || denominator <= 0.0 {
        return None;
    }
    let lambda = shortfall / denominator;
    Some(Push {
        particles: q,
        amount: [0, 1, 2, 3].map(|i| weight[i] * inv[i] * lambda),
        direction,
        shortfall,
    })
}

/// `a` at `t = 0` to `b` at `t = 1`, exactly at both ends.
#[inline]
fn lerp(a: Vec3, b: Vec3, t: Real) -> Vec3 {
    a * (1.0 - t) + b * t
}

/// Whether `p`, in the plane of triangle `(a, b, c)`, is inside it (a millionth of its size
/// outside counts as inside).
fn inside_triangle(p: Vec3, a: Vec3, b: Vec3, c: Vec3) -> bool {
    let n = (b - a).cross(c - a);
    let n2 = n.length_squared();
    if n2 == 0.0 {
        return false;
    }
    let tolerance = -1e-6 * n2;
    (b - a).cross(p - a).dot(n) >= tolerance
        && (c - b).cross(p - b).dot(n) >= tolerance
        && (a - c).cross(p - c).dot(n) >= tolerance
}

/// The first time `t` in [0, 1] at which `y(t) . (e(t) x g(t))` is zero (each vector moving
/// linearly from its `[start, end]`) and `accept(t)` holds: the moments four moving points are
/// coplanar, in order. The triple product is a cubic in `t`; its roots are bracketed between
/// its turning points and found by bisection on the product itself.
fn coplanar_time(y: [Vec3; 2], e: [Vec3; 2], g: [Vec3; 2], accept: impl Fn(Real) -> bool) -> bool {
    let f = |t: Real| lerp(y[0], y[1], t).dot(lerp(e[0], e[1], t).cross(lerp(g[0], g[1], t)));
    // Coefficients of the cubic k0 + k1 t + k2 t^2 + k3 t^3, for its turning points.
    let (vy, ve, vg) = (y[1] - y[0], e[1] - e[0], g[1] - g[0]);
    let mixed = ve.cross(g[0]) + e[0].cross(vg);
    let k1 = vy.dot(e[0].cross(g[0])) + y[0].dot(mixed);
    let k2 = vy.dot(mixed) + y[0].dot(ve.cross(vg));
    let k3 = vy.dot(ve.cross(vg));
    // Roots of 3 k3 t^2 + 2 k2 t + k1 in (0, 1).
    let mut cuts = [0.0, 1.0, 1.0, 1.0];
    let mut count = 1;
    let (qa, qb, qc) = (3.0 * k3, 2.0 * k2, k1);
    let scale = qa.abs().max(qb.abs()).max(qc.abs());
    if scale > 0.0 {
        if qa.abs() > 1e-12 * scale {
            let disc = qb * qb - 4.0 * qa * qc;
            if disc >= 0.0 {
                let root = disc.sqrt();
                // The numerically stable pair of roots.
                let w = -0.5 * (qb + qb.signum() * root);
                for t in [w / qa, if w != 0.0 { qc / w } else { Real::NAN }] {
                    if t > 0.0 && t < 1.0 {
                        cuts[count] = t;
                        count += 1;
                    }
                }
            }
        } else if qb != 0.0 {
            let t = -qc / qb;
            if t > 0.0 && t < 1.0 {
                cuts[count] = t;
                count += 1;
            }
        }
    }
    cuts[count] = 1.0;
    count += 1;
    let cuts = &mut cuts[..count];
    cuts.sort_unstable_by(Real::total_cmp);
    for w in cuts.windows(2) {
        let (mut lo, mut hi) = (w[0], w[1]);
        let (flo, fhi) = (f(lo), f(hi));
        let root = if flo == 0.0 {
            lo
        } else if fhi == 0.0 {
            hi
        } else if (flo > 0.0) != (fhi > 0.0) {
            for _ in 0..64 {
                let mid = 0.5 * (lo + hi);
                if mid <= lo || mid >= hi {
                    break;
                }
                let fm = f(mid);
                if fm == 0.0 {
                    lo = mid;
                    hi = mid;
                    break;
                }
                if (fm > 0.0) == (flo > 0.0) {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            0.5 * (lo + hi)
        } else {
            continue;
        };
        if accept(root) {
            return true;
        }
    }
    false
}

/// The point of triangle `(a, b, c)` closest to `p`, as the barycentric weights of `a`, `b`
/// and `c` (by the regions of the triangle's corners, sides and face).
pub(crate) fn closest_on_triangle(p: Vec3, a: Vec3, b: Vec3, c: Vec3) -> [Real; 3] {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return [1.0, 0.0, 0.0];
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return [0.0, 1.0, 0.0];
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return [1.0 - v, v, 0.0];
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return [0.0, 0.0, 1.0];
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return [1.0 - w, 0.0, w];
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return [0.0, 1.0 - w, w];
    }
    let total = va + vb + vc;
    if total.is_nan() || total <= 0.0 {
        // A crushed triangle: the nearest of its sides.
        let sides = [(a, b, [0, 1]), (b, c, [1, 2]), (c, a, [2, 0])];
        let mut best = (Real::INFINITY, [1.0, 0.0, 0.0]);
        for (u, v, [i, j]) in sides {
            let (s, _) = closest_on_segments(u, v, p, p);
            let d = (u.lerp(v, s) - p).length_squared();
            if d < best.0 {
                let mut w = [0.0; 3];
                w[i] = 1.0 - s;
                w[j] = s;
                best = (d, w);
            }
        }
        return best.1;
    }
    let (v, w) = (vb / total, vc / total);
    [1.0 - v - w, v, w]
}

/// The parameters `(s, u)` of the closest points `a + s (b - a)` and `c + u (d - c)` of two
/// segments, each in [0, 1].
pub(crate) fn closest_on_segments(a: Vec3, b: Vec3, c: Vec3, d: Vec3) -> (Real, Real) {
    let (e, g, r) = (b - a, d - c, a - c);
    let (ee, gg, gr) = (e.dot(e), g.dot(g), g.dot(r));
    if ee <= Real::MIN_POSITIVE && gg <= Real::MIN_POSITIVE {
        return (0.0, 0.0);
    }
    if ee <= Real::MIN_POSITIVE {
        return (0.0, (gr / gg).clamp(0.0, 1.0));
    }
    let er = e.dot(r);
    if gg <= Real::MIN_POSITIVE {
        return ((-er / ee).clamp(0.0, 1.0), 0.0);
    }
    let eg = e.dot(g);
    let denominator = ee * gg - eg * eg;
    let mut s = if denominator > 1e-14 * ee * gg {
        ((eg * gr - er * gg) / denominator).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let mut u = (eg * s + gr) / gg;
    if u < 0.0 {
        u = 0.0;
        s = (-er / ee).clamp(0.0, 1.0);
    } else if u > 1.0 {
        u = 1.0;
        s = ((eg - er) / ee).clamp(0.0, 1.0);
    }
    (s, u)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One triangle and one separate vertex as a mesh (two pieces), and its self-contact.
    fn vertex_over_triangle() -> (ClothMesh, MeshSelf) {
        let rest = vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(0.02, 0.0, 0.0),
            Vec3::new(0.0, 0.0, 0.02),
            Vec3::new(0.1, 0.0, 0.0),
            Vec3::new(0.12, 0.0, 0.0),
            Vec3::new(0.1, 0.0, 0.02),
        ];
        let mesh = ClothMesh::new(rest, vec![[0, 2, 1], [3, 5, 4]]).unwrap();
        let contact = MeshSelf::new(&mesh, 0.002);
        (mesh, contact)
    }

    fn soa(v: &[Vec3]) -> Soa {
        Soa::from_vec3(v)
    }

    fn momentum(x: &Soa, y: &Soa, inv_mass: &[Real]) -> Vec3 {
        (0..x.len())
            .map(|k| (y.get(k) - x.get(k)) / inv_mass[k])
            .sum()
    }

    /// A corner of the second triangle that went through the first during the step (10 mm in
    /// one step, five thicknesses) is put back on the side it came from, `h` off the first
    /// triangle, with the momentum of the move unchanged; one that came from below is put back
    /// below.
    #[test]
    fn a_vertex_that_crossed_a_triangle_goes_back_to_its_side() {
        for from in [1.0, -1.0] {
            let (mesh, mut contact) = vertex_over_triangle();
            let p = Vec3::new(0.005, 0.004 * from, 0.005);
            let far = [
                Vec3::new(0.0, 0.0, 0.0),
                Vec3::new(0.02, 0.0, 0.0),
                Vec3::new(0.0, 0.0, 0.02),
                p,
                p + Vec3::new(0.02, 0.0, 0.0),
                p + Vec3::new(0.0, 0.0, 0.02),
            ];
            let start = soa(&far);
            let mut end = far;
            end[3].y -= 0.01 * from;
            let end = soa(&end);
            contact.begin_step(&start);
            let mut x = end.clone();
            let inv_mass = [1.0, 2.0, 1.0, 1.0, 3.0, 1.0];
            let hits = contact.solve(
                &mesh,
                &mut x,
                &inv_mass,
                &[false; 6],
                &ExemptPairs::default(),
            );
            assert!(hits >= 1);
            let [a, b, c] = [0, 1, 2].map(|k| x.get(k));
            let normal = (b - a).cross(c - a).normalize();
            let height = (x.get(3) - a).dot(normal) * normal.y.signum();
            assert!(
                from * height >= 0.002 * (1.0 - 2.0 * SLACK),
                "from {from}: {height}"
            );
            let p = momentum(&end, &x, &inv_mass);
            assert!(p.length() < 1e-12, "momentum {p}");
        }
    }

    /// Held particles do not move: the free vertex takes the whole correction.
    #[test]
    fn held_particles_do_not_move() {
        let (mesh, mut contact) = vertex_over_triangle();
        let mut x = mesh.rest_positions();
        let p = Vec3::new(0.005, 0.0005, 0.005);
        x.set(3, p);
        contact.begin_step(&x);
        let held = [true, true, true, false, false, false];
        let before = x.clone();
        contact.solve(&mesh, &mut x, &[1.0; 6], &held, &ExemptPairs::default());
        for k in 0..3 {
            assert_eq!(x.get(k), before.get(k));
        }
        assert!(x.get(3).y >= 0.002 * (1.0 - 2.0 * SLACK), "{}", x.get(3));
    }

    /// Two edges that crossed during the step are put back on their sides.
    #[test]
    fn edges_that_crossed_go_back() {
        // Two triangles far apart at rest; at the start one's edge lies 3 mm above the
        // other's, crosswise; at the end 3 mm below.
        let rest = vec![
            Vec3::new(-0.01, 0.0, 0.0),
            Vec3::new(0.01, 0.0, 0.0),
            Vec3::new(0.0, 0.0, -0.02),
            Vec3::new(0.0, 0.1, -0.01),
            Vec3::new(0.0, 0.1, 0.01),
            Vec3::new(0.02, 0.1, 0.0),
        ];
        let mesh = ClothMesh::new(rest, vec![[0, 1, 2], [3, 4, 5]]).unwrap();
        let mut contact = MeshSelf::new(&mesh, 0.002);
        let mut start = mesh.rest_positions();
        for k in 3..6 {
            start.set(k, mesh.rest[k] - Vec3::new(0.0, 0.097, 0.0));
        }
        let mut x = start.clone();
        for k in 3..6 {
            x.set(k, start.get(k) - Vec3::new(0.0, 0.006, 0.0));
        }
        contact.begin_step(&start);
        contact.solve(
            &mesh,
            &mut x,
            &[1.0; 6],
            &[false; 6],
            &ExemptPairs::default(),
        );
        // The upper edge (3, 4) along z against the lower one (0, 1) along x: above it, `h`
        // off.
        let [a, b, c, d] = [0, 1, 3, 4].map(|k| x.get(k));
        let (s, u) = closest_on_segments(a, b, c, d);
        let apart = c.lerp(d, u) - a.lerp(b, s);
        assert!(apart.y > 0.0, "{apart}");
        assert!(apart.length() >= 0.002 * (1.0 - 2.0 * SLACK), "{apart}");
    }

    /// The hierarchies find every candidate pair a test of all pairs finds, after a build and
    /// after a few particles' boxes were widened.
    #[test]
    fn the_broad_phase_misses_no_pair() {
        // A crumpled 9 x 9 sheet of 1 cm edges, its particles moved up to 8 mm, 3 mm thick.
        let n = 9;
        let mut rest = Vec::new();
        for j in 0..n {
            for i in 0..n {
                rest.push(Vec3::new(i as Real * 0.01, 0.0, j as Real * 0.01));
            }
        }
        let mut triangles = Vec::new();
        for j in 0..n - 1 {
            for i in 0..n - 1 {
                let a = (j * n + i) as u32;
                let (b, c, d) = (a + 1, a + 1 + n as u32, a + n as u32);
                triangles.push([a, c, b]);
                triangles.push([a, d, c]);
            }
        }
        let mesh = ClothMesh::new(rest, triangles).unwrap();
        let mut seed: u64 = 0x2545_F491_4F6C_DD1D;
        let mut rnd = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as Real / (1u64 << 53) as Real * 2.0 - 1.0
        };
        let mut crumple = |scale: Real| {
            Soa::from_vec3(
                &mesh
                    .rest
                    .iter()
                    .map(|p| {
                        let y = 0.03 * (p.x * 300.0).sin() * (p.z * 200.0).cos();
                        *p + Vec3::new(rnd(), rnd() + y / scale, rnd()) * scale
                    })
                    .collect::<Vec<_>>(),
            )
        };
        let (start, end) = (crumple(0.008), crumple(0.008));
        let h = 0.003;
        let mut contact = MeshSelf::new(&mesh, h);
        contact.begin_step(&start);
        contact.rebuild(&mesh, &end, &ExemptPairs::default());
        let check = |contact: &MeshSelf| {
            let [vt, ee] = every_pair(contact, &mesh);
            let found = |l: &[Pair]| l.iter().map(|p| (p.a, p.b)).collect::<Vec<_>>();
            assert!(
                vt.len() > 100 && ee.len() > 100,
                "{} {}",
                vt.len(),
                ee.len()
            );
            assert_eq!(found(&contact.vertex_triangle), vt);
            assert_eq!(found(&contact.edge_edge), ee);
        };
        check(&contact);
        // A few particles leave their boxes: theirs are widened, and the lists are again every
        // pair a test of all pairs finds.
        let mut moved = end.clone();
        for k in [3, 40, 41, 77] {
            moved.set(k, end.get(k) + Vec3::new(0.004, -0.006, 0.002));
        }
        let out = contact.outside(&moved, Vec3::ZERO);
        assert_eq!(out, [3, 40, 41, 77]);
        contact.begin_step(&end);
        contact.repair(&mesh, &moved, &ExemptPairs::default(), Vec3::ZERO, &out);
        assert!(contact.outside(&moved, Vec3::ZERO).is_empty());
        check(&contact);
    }

    /// Every candidate pair of `contact`'s boxes, by testing all pairs: boxes within `h`,
    /// distance where the lists were built within `h` and the particles' reaches, not within
    /// `h` at rest.
    fn every_pair(contact: &MeshSelf, mesh: &ClothMesh) -> [Vec<(u32, u32)>; 2] {
        let h = contact.thickness;
        let x = &contact.built;
        let meet = |a: (Vec3, Vec3), b: (Vec3, Vec3)| {
            !((a.0 - Vec3::splat(h)).cmpgt(b.1).any() || b.0.cmpgt(a.1 + Vec3::splat(h)).any())
        };
        let (lo, hi) = (&contact.lo, &contact.hi);
        let reach = |k: u32| {
            let (k, p) = (k as usize, x.get(k as usize));
            (p - lo[k]).max(hi[k] - p).length()
        };
        let span = |ks: &[u32]| {
            let l = ks
                .iter()
                .map(|&k| lo[k as usize])
                .reduce(Vec3::min)
                .unwrap();
            let u = ks
                .iter()
                .map(|&k| hi[k as usize])
                .reduce(Vec3::max)
                .unwrap();
            (l, u)
        };
        let mut vt = Vec::new();
        for v in 0..mesh.len() as u32 {
            for (t, tri) in mesh.triangles.iter().enumerate() {
                if tri.contains(&v) || !meet(span(&[v]), span(tri)) {
                    continue;
                }
                let [a, b, c] = tri.map(|k| x.get(k as usize));
                let p = x.get(v as usize);
                let w = closest_on_triangle(p, a, b, c);
                let d = (p - (a * w[0] + b * w[1] + c * w[2])).length();
                let r = tri.map(reach);
                let [ra, rb, rc] = tri.map(|k| mesh.rest[k as usize]);
                let rp = mesh.rest[v as usize];
                let wr = closest_on_triangle(rp, ra, rb, rc);
                let rest = (rp - (ra * wr[0] + rb * wr[1] + rc * wr[2])).length();
                if d <= h + reach(v) + r[0].max(r[1]).max(r[2]) && rest >= h {
                    vt.push((v, t as u32));
                }
            }
        }
        let mut ee = Vec::new();
        for (e, &[a, b]) in mesh.edges.iter().enumerate() {
            for (f, &[c, d]) in mesh.edges.iter().enumerate().skip(e + 1) {
                if [a, b].iter().any(|k| *k == c || *k == d) || !meet(span(&[a, b]), span(&[c, d]))
                {
                    continue;
                }
                let [pa, pb, pc, pd] = [a, b, c, d].map(|k| x.get(k as usize));
                let (s, u) = closest_on_segments(pa, pb, pc, pd);
                let gap = (pa.lerp(pb, s) - pc.lerp(pd, u)).length();
                let r = [a, b, c, d].map(|k| mesh.rest[k as usize]);
                let (s, u) = closest_on_segments(r[0], r[1], r[2], r[3]);
                let rest = (r[0].lerp(r[1], s) - r[2].lerp(r[3], u)).length();
                if gap <= h + reach(a).max(reach(b)) + reach(c).max(reach(d)) && rest >= h {
                    ee.push((e as u32, f as u32));
                }
            }
        }
        [vt, ee]
    }

    #[test]
    fn coplanar_times_are_found_in_order() {
        // A point falling through the plane y = 0 at t = 0.25, inside a still triangle.
        let (a, b, c) = (Vec3::ZERO, Vec3::X, Vec3::Z);
        let (p0, p1) = (Vec3::new(0.2, 1.0, 0.2), Vec3::new(0.2, -3.0, 0.2));
        let hit = std::cell::Cell::new(Real::NAN);
        let found = coplanar_time([p0 - a, p1 - a], [b - a, b - a], [c - a, c - a], |t| {
            hit.set(t);
            true
        });
        assert!(found);
        assert!((hit.get() - 0.25).abs() < 1e-12, "{}", hit.get());
        // Beside the triangle: a root, not accepted.
        let (q0, q1) = (Vec3::new(2.0, 1.0, 2.0), Vec3::new(2.0, -3.0, 2.0));
        assert!(!coplanar_time(
            [q0 - a, q1 - a],
            [b - a, b - a],
            [c - a, c - a],
            |t| inside_triangle(lerp(q0, q1, t), a, b, c)
        ));
    }

    #[test]
    fn closest_points_are_right_on_each_region() {
        let (a, b, c) = (Vec3::ZERO, Vec3::X, Vec3::Z);
        let w = closest_on_triangle(Vec3::new(0.2, 1.0, 0.3), a, b, c);
        assert!((w[0] - 0.5).abs() + (w[1] - 0.2).abs() + (w[2] - 0.3).abs() < 1e-15);
        assert_eq!(
            closest_on_triangle(Vec3::new(-1.0, 0.0, -1.0), a, b, c),
            [1.0, 0.0, 0.0]
        );
        let w = closest_on_triangle(Vec3::new(1.0, 0.0, 1.0), a, b, c);
        assert!((w[1] - 0.5).abs() < 1e-15 && (w[2] - 0.5).abs() < 1e-15);
        let (s, u) = closest_on_segments(
            Vec3::new(-1.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.5, 1.0, -1.0),
            Vec3::new(0.5, 1.0, 1.0),
        );
        assert!((s - 0.75).abs() < 1e-15 && (u - 0.5).abs() < 1e-15);
    }
}
