//! Convex parts (paper 2.1: "the number of particles equals the number of
//! convex parts of the object"), read from normal cones over the hierarchy:
//! the fewest hierarchy nodes whose normal cones have a half-angle under 90
//! degrees (all normals in one open half-space: the traversal's own cone
//! criterion, [`crate::geom::NormalCone::is_positive`]) and that together
//! cover the mesh. A node's cone holds its children's, so the top-most
//! qualifying nodes are that fewest set. A flat sheet is one part, a tube or a
//! sphere a few, a crumpled sheet many.
//!
//! The count is a heuristic for the number of particles, and the sensor
//! recounts whenever the shape moves under its particles, so it must cost far
//! less than the exact method's refit of every box and cone. [`PartTree`]
//! therefore reads a sample: the hierarchy is cut at its top-most nodes of at
//! most `leaf_size` triangles (the coarse leaves); a coarse leaf's cone holds
//! the normals of [`SAMPLES`] of its triangles spread over it (all of them
//! when it has no more), and the nodes above merge their children's cones as
//! the refit does. A fit costs about `SAMPLES / leaf_size` of a refit and
//! touches no box. A sampled cone holds a subset of the node's normals, so it
//! is (up to the order of the pairwise merges) no wider than the refitted
//! one: the sampled count is at most about the exact count, and a coarse leaf
//! is always one part.
//!
//! Where the coarse leaves hold at most [`SAMPLES`] triangles (small meshes)
//! a leaf's cone is the refit's, its triangles' cones merged in order, and the
//! count is exactly the refitted hierarchy's cut at the coarse leaves. Above
//! that the leaf cone is an estimate from samples anyway, and it is the
//! cheaper cone around the samples' mean normal
//! ([`crate::geom::NormalCone::around`]: one dot product per sample where the
//! chain of merges took about 140 instructions per sample; the fit is ~40%
//! cheaper). It holds every sample's normal too; it is no narrower than the
//! smallest such cone and at most twice as wide, and differs from the chain
//! of merges (wider where the samples crowd one end of a fold's arc).
//!
//! A fit recomputes only what moved: a coarse leaf whose sampled triangles'
//! corners kept their positions (the part of a sheet that a fold, roll or
//! bend leaves in place) keeps its cone, and a node keeps its merged cone when
//! neither child's changed. The cones, and so the parts, are exactly those of
//! a fit from scratch. Telling what moved compares each sample's corners with
//! their copy from the last fit; where every leaf moves (skirt_32k's twist)
//! the copy adds about 6% to a fit.
//!
//! [`Parts`] says which part holds each particle, and gives per part its size
//! (triangles) and an anchor triangle, so that the sensor can see which parts
//! carry no particle (where a part appeared) and which carry several (where
//! parts merged); see [`super::Sensor::follow_parts`].
//! Only the public `Bvh` accessors (root, children) are used here.

use super::particle::SurfacePoint;
use crate::bvh::Bvh;
use crate::geom::NormalCone;
use crate::mesh::Mesh;
use glam::DVec3;
use std::ops::Range;

/// Triangles sampled per coarse leaf. With the gated detector's leaves (8
/// per particle at most: 63 triangles on skirt_32k, 35 on a 20k sheet) a
/// fit reads a quarter to a half of the triangles' normals and no box. Four
/// samples (a sixteenth) missed 351 and 706 contacts of skirt_32k's 10- and
/// 40-frame folds, 16 none (BENCHMARKS.md, "sensor-5: quiet cost"); the count
/// decides where particles go, and placement on a fast fold is sensitive to it.
pub const SAMPLES: usize = 16;

/// No parent (the root of the coarse tree).
const NONE: u32 = u32::MAX;

/// The top of a hierarchy, cut at nodes of at most `leaf_size` triangles, with
/// sampled normal cones (see the module documentation). Coarse node ids:
/// the coarse leaves first (depth-first, first child first), then the nodes
/// above them in post-order, so every child has a smaller id than its parent
/// and the root is the last node.
#[derive(Debug, Clone)]
pub struct PartTree {
    n_leaves: usize,
    /// Children of coarse internal node `n_leaves + i`.
    children: Vec<[u32; 2]>,
    /// Parent of every coarse node ([`NONE`] for the root).
    parent: Vec<u32>,
    /// Triangles under every coarse node.
    size: Vec<u32>,
    /// Sampled triangles of coarse leaf `l`: `samples[offsets[l]..offsets[l + 1]]`.
    offsets: Vec<u32>,
    samples: Vec<u32>,
    /// Vertices of every sampled triangle (copied from the mesh by the first
    /// fit), so that a fit reads the positions without the triangle list.
    sample_vertices: Vec<[u32; 3]>,
    /// Unit normal of every sample of a sampled leaf, as of its last fit
    /// (scratch for [`PartTree::spread_cone`]).
    normals: Vec<DVec3>,
    /// Coarse leaf of every triangle.
    leaf_of_triangle: Vec<u32>,
    /// Sampled cone of every coarse node, as of the last [`PartTree::fit`].
    cones: Vec<NormalCone>,
    /// Corners of every sampled triangle at the last fit (NaN before the
    /// first): a leaf whose samples all kept theirs keeps its cone.
    seen: Vec<[DVec3; 3]>,
    /// Whether each coarse node's cone changed in the last fit.
    moved: Vec<bool>,
    /// Coarse leaves of at most [`SAMPLES`] triangles: every triangle is
    /// sampled and the cones are the refit's (the triangles' cones merged in
    /// the refit's order), so the count is that of the refitted hierarchy cut
    /// at the coarse leaves (small meshes). Otherwise the cones are estimates
    /// from samples anyway, and a leaf's is the cheaper cone around its
    /// samples' mean normal ([`PartTree::spread_cone`]).
    exact: bool,
}

impl PartTree {
    /// The coarse tree of `bvh` (built on a mesh of `bvh.n_leaves` triangles),
    /// cut at nodes of at most `leaf_size` (>= 1) triangles.
    pub fn new(bvh: &Bvh, leaf_size: usize) -> PartTree {
        let leaf_size = leaf_size.max(1) as u32;
        // Triangles under every hierarchy node (children have smaller ids).
        let mut under = vec![1u32; bvh.n_nodes()];
        for node in bvh.n_leaves..bvh.n_nodes() {
            let [a, b] = bvh.children_of(node as u32);
            under[node] = under[a as usize] + under[b as usize];
        }
        let coarse = |node: u32| under[node as usize] <= leaf_size;
        // Coarse leaves in depth-first order, nodes above them in post-order.
        let (mut leaves, mut above) = (Vec::new(), Vec::new());
        let mut stack = vec![(bvh.root(), false)];
        while let Some((node, expanded)) = stack.pop() {
            if coarse(node) {
                leaves.push(node);
            } else if expanded {
                above.push(node);
            } else {
                let [a, b] = bvh.children_of(node);
                stack.extend([(node, true), (b, false), (a, false)]);
            }
        }
        let n_leaves = leaves.len();
        let n_coarse = n_leaves + above.len();
        let mut id = vec![NONE; bvh.n_nodes()];
        for (i, &node) in leaves.iter().chain(&above).enumerate() {
            id[node as usize] = i as u32;
        }
        let mut tree = PartTree {
            n_leaves,
            children: Vec::with_capacity(above.len()),
            parent: vec![NONE; n_coarse],
            size: leaves
                .iter()
                .chain(&above)
                .map(|&n| under[n as usize])
                .collect(),
            offsets: vec![0],
            samples: Vec::new(),
            sample_vertices: Vec::new(),
            normals: Vec::new(),
            leaf_of_triangle: vec![0; bvh.n_leaves],
            cones: vec![NormalCone::FULL; n_coarse],
            seen: Vec::new(),
            moved: vec![true; n_coarse],
            exact: leaf_size as usize <= SAMPLES,
        };
        for (i, &node) in above.iter().enumerate() {
            let kids = bvh.children_of(node).map(|c| id[c as usize]);
            for k in kids {
                tree.parent[k as usize] = (n_leaves + i) as u32;
            }
            tree.children.push(kids);
        }
        let mut tris = Vec::new();
        for (l, &node) in leaves.iter().enumerate() {
            tris.clear();
            triangles_under(bvh, node, &mut tris);
            for &t in &tris {
                tree.leaf_of_triangle[t as usize] = l as u32;
            }
            tree.samples.extend(spread(&tris, SAMPLES));
            tree.offsets.push(tree.samples.len() as u32);
        }
        tree.seen = vec![[DVec3::NAN; 3]; tree.samples.len()];
        tree.normals = vec![DVec3::ZERO; tree.samples.len()];
        tree
    }

    /// Number of coarse nodes.
    pub fn n_nodes(&self) -> usize {
        self.parent.len()
    }

    /// Number of coarse leaves.
    pub fn n_leaves(&self) -> usize {
        self.n_leaves
    }

    /// Triangles sampled per fit.
    pub fn n_samples(&self) -> usize {
        self.samples.len()
    }

    /// Fits the sampled cones to `positions` (a shape of `mesh`) and returns
    /// the part nodes: the top-most coarse nodes whose cone is positive, or
    /// coarse leaves, in depth-first order (first child first).
    pub fn fit(&mut self, mesh: &Mesh, positions: &[DVec3]) -> Vec<u32> {
        if self.sample_vertices.len() != self.samples.len() {
            let tris = mesh.triangles();
            self.sample_vertices = self.samples.iter().map(|&t| tris[t as usize]).collect();
        }
        for l in 0..self.n_leaves {
            self.moved[l] = self.leaf_moved(l, positions);
            if self.moved[l] {
                self.cones[l] = self.leaf_cone(l, positions);
            }
        }
        for (i, &[a, b]) in self.children.iter().enumerate() {
            let (a, b, node) = (a as usize, b as usize, self.n_leaves + i);
            self.moved[node] = self.moved[a] || self.moved[b];
            if self.moved[node] {
                self.cones[node] = self.cones[a].merge(&self.cones[b]);
            }
        }
        self.part_nodes()
    }

    /// True when a corner of coarse leaf `l`'s samples is not where it was at
    /// the last fit, bit for bit (a signed zero changes a cone's bits too).
    fn leaf_moved(&self, l: usize, positions: &[DVec3]) -> bool {
        let same = |a: DVec3, b: DVec3| {
            a.x.to_bits() == b.x.to_bits()
                && a.y.to_bits() == b.y.to_bits()
                && a.z.to_bits() == b.z.to_bits()
        };
        let range = self.offsets[l] as usize..self.offsets[l + 1] as usize;
        self.sample_vertices[range.clone()]
            .iter()
            .zip(&self.seen[range])
            .any(|(vertices, seen)| {
                let [a, b, c] = vertices.map(|v| positions[v as usize]);
                !(same(a, seen[0]) && same(b, seen[1]) && same(c, seen[2]))
            })
    }

    /// The sampled cone of coarse leaf `l` at `positions`; keeps the samples'
    /// corners. Where every triangle is sampled ([`PartTree::exact`]) it is
    /// the refit's own cone (the triangles' cones merged in order); otherwise
    /// the cheaper [`PartTree::spread_cone`].
    fn leaf_cone(&mut self, l: usize, positions: &[DVec3]) -> NormalCone {
        let range = self.offsets[l] as usize..self.offsets[l + 1] as usize;
        if !self.exact {
            return self.spread_cone(range, positions);
        }
        let mut cone = None;
        for s in range {
            let [a, b, c] = self.sample_vertices[s].map(|v| positions[v as usize]);
            self.seen[s] = [a, b, c];
            let t = NormalCone::of_triangle(a, b, c);
            cone = Some(cone.map_or(t, |x: NormalCone| x.merge(&t)));
        }
        cone.unwrap_or(NormalCone::FULL)
    }

    /// The cone of the samples `range` at `positions` around their mean unit
    /// normal ([`NormalCone::around`]: every sample's exact normal inside, one
    /// dot product per sample where the merges take a few dozen operations);
    /// the full cone when a sample has no normal. Keeps the samples' corners
    /// and normals.
    fn spread_cone(&mut self, range: Range<usize>, positions: &[DVec3]) -> NormalCone {
        let (mut sum, mut err, mut known) = (DVec3::ZERO, 0.0f64, true);
        let samples = self.sample_vertices[range.clone()]
            .iter()
            .zip(&mut self.seen[range.clone()])
            .zip(&mut self.normals[range.clone()]);
        for ((&[a, b, c], seen), normal) in samples {
            let [a, b, c] = [
                positions[a as usize],
                positions[b as usize],
                positions[c as usize],
            ];
            *seen = [a, b, c];
            match NormalCone::unit_normal(a, b, c) {
                Some((n, e)) => {
                    *normal = n;
                    sum += n;
                    if e > err {
                        err = e;
                    }
                }
                None => known = false,
            }
        }
        if !known {
            return NormalCone::FULL;
        }
        NormalCone::around(sum.normalize_or_zero(), &self.normals[range], err)
    }

    /// The top-most coarse nodes whose cone is positive, or coarse leaves, in
    /// depth-first order (first child first).
    fn part_nodes(&self) -> Vec<u32> {
        let mut stack = vec![(self.n_nodes() - 1) as u32];
        let mut parts = Vec::new();
        while let Some(node) = stack.pop() {
            let i = node as usize;
            if i < self.n_leaves || self.cones[i].is_positive() {
                parts.push(node);
            } else {
                let [a, b] = self.children[i - self.n_leaves];
                stack.extend([b, a]);
            }
        }
        parts
    }

    /// The parts `nodes` (from [`PartTree::fit`] at `positions`) as seen by the
    /// particles `points`: each particle's part, and each part's size and
    /// anchor. The anchor is the sampled triangle whose centroid is closest to
    /// the mean centroid of the part's samples (where a new particle goes);
    /// ties: the lowest triangle. Only a part that holds no particle gets one
    /// (particles are added only there); the others' samples are not read.
    /// O(samples of the parts without a particle + particles).
    pub fn parts(
        &self,
        nodes: &[u32],
        mesh: &Mesh,
        positions: &[DVec3],
        points: &[SurfacePoint],
    ) -> Parts {
        let mut part = vec![NONE; self.n_nodes()];
        for (p, &node) in nodes.iter().enumerate() {
            part[node as usize] = p as u32;
        }
        // Top-down (parents have larger ids): a node below a part node is in that part.
        for c in (0..self.n_nodes()).rev() {
            let up = self.parent[c];
            if part[c] == NONE && up != NONE {
                part[c] = part[up as usize];
            }
        }
        let of_point: Vec<u32> = points
            .iter()
            .map(|p| part[self.leaf_of_triangle[p.tri as usize] as usize])
            .collect();
        let mut held = vec![false; nodes.len()];
        for &p in &of_point {
            held[p as usize] = true;
        }
        Parts {
            of_point,
            size: nodes.iter().map(|&n| self.size[n as usize]).collect(),
            anchor: self.anchors(&part[..self.n_leaves], &held, mesh, positions),
        }
    }

    /// The anchor of every part that is not `held` (NONE for a held one),
    /// given the part of every coarse leaf: see [`PartTree::parts`].
    fn anchors(
        &self,
        leaf_parts: &[u32],
        held: &[bool],
        mesh: &Mesh,
        positions: &[DVec3],
    ) -> Vec<u32> {
        let centroid = |t: u32| {
            let [a, b, c] = mesh.corners(positions, t as usize);
            (a + b + c) / 3.0
        };
        let open = || {
            leaf_parts
                .iter()
                .enumerate()
                .filter(|&(_, &p)| !held[p as usize])
                .map(|(l, &p)| (self.leaf_samples(l), p as usize))
        };
        let mut mean = vec![(DVec3::ZERO, 0.0); held.len()];
        for (samples, p) in open() {
            let m = &mut mean[p];
            for &t in samples {
                *m = (m.0 + centroid(t), m.1 + 1.0);
            }
        }
        let mut best = vec![(f64::INFINITY, NONE); held.len()];
        for (samples, p) in open() {
            let centre = mean[p].0 / mean[p].1;
            for &t in samples {
                let d = centroid(t).distance_squared(centre);
                if (d, t) < best[p] {
                    best[p] = (d, t);
                }
            }
        }
        best.iter().map(|&(_, t)| t).collect()
    }

    fn leaf_samples(&self, l: usize) -> &[u32] {
        &self.samples[self.offsets[l] as usize..self.offsets[l + 1] as usize]
    }
}

/// Appends the triangles under `node` to `out`, depth-first, first child first.
fn triangles_under(bvh: &Bvh, node: u32, out: &mut Vec<u32>) {
    let mut stack = vec![node];
    while let Some(n) = stack.pop() {
        if bvh.is_leaf(n) {
            out.push(n);
        } else {
            let [a, b] = bvh.children_of(n);
            stack.extend([b, a]);
        }
    }
}

/// `m` items of `items` spread evenly (the middles of m equal runs), or all of
/// them when there are no more than `m`.
fn spread(items: &[u32], m: usize) -> Vec<u32> {
    if items.len() <= m {
        return items.to_vec();
    }
    (0..m)
        .map(|i| items[(2 * i + 1) * items.len() / (2 * m)])
        .collect()
}

/// The convex parts of one shape, as the sensor's particles see them.
#[derive(Debug, Clone, Default)]
pub struct Parts {
    /// Part id of every particle.
    pub of_point: Vec<u32>,
    /// Triangles per part.
    pub size: Vec<u32>,
    /// Anchor triangle of every part that holds no particle (where one is
    /// added); `u32::MAX` for a part that holds one.
    pub anchor: Vec<u32>,
}

impl Parts {
    /// Number of parts.
    pub fn len(&self) -> usize {
        self.size.len()
    }

    /// True when there is no part (a mesh always has one).
    pub fn is_empty(&self) -> bool {
        self.size.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::build::build;
    use crate::scene::{grid, Deformation};

    /// With coarse leaves of one triangle every triangle is sampled: the count
    /// is the exact top-most positive nodes of the refitted hierarchy.
    #[test]
    fn one_triangle_leaves_count_as_the_refitted_cones() {
        let (v, f) = grid(21, 1.0);
        let mesh = Mesh::new(v, f).unwrap();
        let mut bvh = build(&mesh);
        let mut tree = PartTree::new(&bvh, 1);
        assert_eq!(tree.n_leaves(), mesh.n_triangles());
        assert_eq!(tree.n_samples(), mesh.n_triangles());
        let crumpled = Deformation::Crumple {
            amplitude: 0.2,
            wavelength: 0.4,
            seed: 1,
        }
        .apply(mesh.rest());
        bvh.refit(&mesh, &crumpled);
        let mut stack = vec![bvh.root()];
        let mut exact = 0;
        while let Some(node) = stack.pop() {
            if bvh.is_leaf(node) || bvh.cones[node as usize].is_positive() {
                exact += 1;
            } else {
                stack.extend(bvh.children_of(node));
            }
        }
        assert!(exact > 1);
        assert_eq!(tree.fit(&mesh, &crumpled).len(), exact);
        assert_eq!(tree.fit(&mesh, mesh.rest()).len(), 1);
    }

    /// Coarse leaves cover every triangle once and hold at most `leaf_size`;
    /// parts label the particles and anchor inside their part.
    #[test]
    fn coarse_leaves_cover_the_mesh_and_parts_label_particles() {
        let (v, f) = grid(31, 1.0);
        let mesh = Mesh::new(v, f).unwrap();
        let bvh = build(&mesh);
        let crumpled = Deformation::Crumple {
            amplitude: 0.3,
            wavelength: 0.4,
            seed: 1,
        }
        .apply(mesh.rest());
        for leaf_size in [2, 8, 32, 5000] {
            let mut tree = PartTree::new(&bvh, leaf_size);
            let leaves = &tree.size[..tree.n_leaves()];
            assert_eq!(
                leaves.iter().sum::<u32>() as usize,
                mesh.n_triangles(),
                "{leaf_size}"
            );
            assert!(leaves.iter().all(|&s| s as usize <= leaf_size));
            let nodes = tree.fit(&mesh, &crumpled);
            assert!(!nodes.is_empty());
            let points: Vec<SurfacePoint> = (0..mesh.n_triangles() as u32)
                .step_by(97)
                .map(SurfacePoint::centroid)
                .collect();
            let parts = tree.parts(&nodes, &mesh, &crumpled, &points);
            assert_eq!(parts.len(), nodes.len());
            assert_eq!(parts.size.iter().sum::<u32>() as usize, mesh.n_triangles());
            for (p, &part) in points.iter().zip(&parts.of_point) {
                let leaf = tree.leaf_of_triangle[p.tri as usize];
                assert!(under_node(&tree, nodes[part as usize], leaf));
            }
            for (part, &t) in parts.anchor.iter().enumerate() {
                let held = parts.of_point.contains(&(part as u32));
                assert_eq!(t == NONE, held, "part {part}");
                if !held {
                    let leaf = tree.leaf_of_triangle[t as usize];
                    assert!(under_node(&tree, nodes[part], leaf));
                }
            }
        }
    }

    /// Folds an n x n sheet three ways, fitting the parts of `leaf_size`
    /// after each fold; checks that each fit after a fit recomputes only the
    /// leaves that moved and gives the cones and parts of a fit from scratch,
    /// then runs `check` on the tree and the folded positions.
    fn check_incremental_fits(
        n: usize,
        leaf_size: usize,
        check: impl Fn(&PartTree, &Mesh, &[DVec3]),
    ) {
        let (v, f) = grid(n, 1.0);
        let mesh = Mesh::new(v, f).unwrap();
        let bvh = build(&mesh);
        let mut tree = PartTree::new(&bvh, leaf_size);
        tree.fit(&mesh, mesh.rest());
        for angle in [1.0, 2.5, 3.5] {
            let folded = Deformation::Fold {
                angle,
                radius: 0.05,
            }
            .apply(mesh.rest());
            let parts = tree.fit(&mesh, &folded);
            let moved = tree.moved[..tree.n_leaves()].iter().filter(|&&m| m).count();
            assert!(0 < moved && moved < tree.n_leaves(), "{moved} leaves moved");
            let mut fresh = PartTree::new(&bvh, leaf_size);
            assert_eq!(fresh.fit(&mesh, &folded), parts, "fold {angle}");
            assert_eq!(fresh.cones, tree.cones, "fold {angle}");
            check(&tree, &mesh, &folded);
        }
    }

    /// A fit after another recomputes only the leaves whose samples moved,
    /// and gives the cones and parts of a fit from scratch.
    #[test]
    fn a_fit_after_a_fit_is_a_fit_from_scratch() {
        check_incremental_fits(41, 8, |_, _, _| {});
    }

    /// Above [`SAMPLES`] triangles per coarse leaf the leaf cones are the
    /// cones around the samples' mean normals: they hold every sample's
    /// normal; a fit after a fit recomputes only the moved leaves and still
    /// gives the cones and parts of a fit from scratch.
    #[test]
    fn estimated_leaf_cones_hold_their_samples_and_refit_incrementally() {
        check_incremental_fits(61, 40, |tree, mesh, folded| {
            assert!(!tree.exact && tree.n_samples() < mesh.n_triangles());
            for l in 0..tree.n_leaves() {
                let cone = tree.cones[l];
                for &t in tree.leaf_samples(l) {
                    let [a, b, c] = mesh.corners(folded, t as usize);
                    let n = NormalCone::of_triangle(a, b, c);
                    let turn = cone.axis.dot(n.axis).clamp(-1.0, 1.0).acos();
                    assert!(turn <= cone.half_angle(), "leaf {l}");
                }
            }
        });
    }

    fn under_node(tree: &PartTree, node: u32, mut c: u32) -> bool {
        while c != node {
            match tree.parent[c as usize] {
                NONE => return false,
                up => c = up,
            }
        }
        true
    }
}
