//! Self-collision response, in three stages per step.
//!
//! 1. **In the solve (the paper, 4.2).** A vertex closer than the thickness `d`
//!    to a triangle, and not moving away from it fast enough, is constrained
//!    along the contact normal n: the solve keeps only the tangential part of
//!    its acceleration, `a = (F - (F.n) n) / m`, and adds the triangle's
//!    acceleration along n (estimated from the triangle's velocity change in
//!    the previous step: both sides are unknowns of the same solve), plus a
//!    velocity change that stops the approach and pushes back out to `d`.
//! 2. **Impulses.** Every proximity contact (vertex-triangle and edge-edge)
//!    found within `d + margin` gets mass-weighted impulses, Gauss-Seidel in
//!    sorted order, so that its relative normal velocity `vn` satisfies
//!    `vn >= -(dist - d) / h` (do not get closer than `d` this step) or, inside
//!    `d`, `vn >= push (d - dist) / h` (move a fraction `push` back out).
//! 2b. **Continuous collisions.** The step from the start positions to
//!    `x0 + h v` is checked with the engine's continuous query; every element
//!    pair that would meet gets an inelastic impulse at its time of impact
//!    (see [`continuous_impulses`]), so fast folds do not pass through in one step.
//! 3. **Correction.** The end-of-step positions are checked for intersecting
//!    triangle pairs with a conservative detector; the vertices of intersecting
//!    triangles are gathered into rigid impact zones that move rigidly from
//!    their (intersection-free) start-of-step positions, and the check repeats
//!    until no pair intersects (see [`correct`]).

use super::solver::Filter;
use crate::detect::continuous::Impact;
use crate::detect::hierarchy::BvhDetector;
use crate::detect::narrow::ElementPair;
use crate::detect::{Detection, Detector, ProximityContacts};
use crate::geom::distance::{point_triangle_distance2, segment_segment_distance2};
use crate::error::{Error, Result};
use crate::mesh::Mesh;
use super::springs::outer;
use glam::{DMat3, DQuat, DVec3};
use std::time::Instant;

/// Contact thickness and how contacts are handled.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactParams {
    /// Thickness d (m): the cloth keeps this distance from itself.
    pub thickness: f64,
    /// Extra detection distance (m) beyond `d`, so that contacts are seen a
    /// step before they close; the detector runs with thickness `d + margin`.
    pub margin: f64,
    /// Fraction of a penetration of the thickness pushed back out per step, in [0, 1].
    pub push: f64,
    /// Most Gauss-Seidel sweeps of the impulse stage.
    pub sweeps: u32,
}

impl ContactParams {
    /// Defaults scaled to a mesh: `d` = 10% and the margin 25% of the mean rest edge length.
    pub fn for_mesh(mesh: &Mesh) -> ContactParams {
        let e = mesh.mean_edge_length();
        ContactParams {
            thickness: 0.1 * e,
            margin: 0.25 * e,
            push: 0.1,
            sweeps: 20,
        }
    }

    /// The distance the detector reports contacts within: `d + margin`.
    pub fn detection_distance(&self) -> f64 {
        self.thickness + self.margin
    }

    /// Checks ranges: d > 0, margin >= 0, push in [0, 1], all finite.
    pub fn validate(&self) -> Result<()> {
        let ok = self.thickness > 0.0
            && self.thickness.is_finite()
            && self.margin >= 0.0
            && self.margin.is_finite()
            && (0.0..=1.0).contains(&self.push);
        if ok {
            Ok(())
        } else {
            Err(Error::InvalidParameter(format!(
                "contact parameters out of range (thickness > 0, margin >= 0, push in [0, 1]): {self:?}"
            )))
        }
    }
}

/// Which elements a contact is between.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ContactKind {
    /// A vertex (slot 0) and a triangle (slots 1-3).
    VertexTriangle,
    /// Two edges (slots 0-1 and 2-3).
    EdgeEdge,
}

/// A proximity contact as a weighted set of four vertices: the relative
/// position of the two sides is `sum_k weights[k] x[verts[k]]` (first side
/// minus second), and `normal` points from the second side to the first.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Contact {
    /// The vertices involved.
    pub verts: [u32; 4],
    /// Their weights: positive on the first side, negative on the second.
    pub weights: [f64; 4],
    /// Unit normal, from the second side to the first.
    pub normal: DVec3,
    /// Distance between the two sides when detected (m).
    pub distance: f64,
    /// What touches what.
    pub kind: ContactKind,
}

impl Contact {
    /// Relative velocity along the normal, `sum_k w_k v_k . n` (positive: separating).
    #[inline]
    pub fn normal_velocity(&self, v: &[DVec3]) -> f64 {
        self.combine(v).dot(self.normal)
    }

    /// `sum_k w_k y_k` for a per-vertex field `y`.
    #[inline]
    fn combine(&self, y: &[DVec3]) -> DVec3 {
        (0..4)
            .map(|k| y[self.verts[k] as usize] * self.weights[k])
            .sum()
    }
}

/// `v / |v|`, or `fallback` when `v` is too short to have a direction.
fn unit_or(v: DVec3, scale: f64, fallback: DVec3) -> DVec3 {
    let l = v.length();
    if l > 1e-12 * scale {
        v / l
    } else {
        fallback
    }
}

/// Turns the detector's proximity contacts at positions `x` into [`Contact`]s,
/// vertex-triangle contacts first, each list in the detector's sorted order.
pub fn gather(mesh: &Mesh, x: &[DVec3], found: &ProximityContacts) -> Vec<Contact> {
    let at = |k: u32| x[k as usize];
    let vt = found
        .vertex_triangle
        .iter()
        .map(|c| vertex_triangle_contact(mesh, at, c.vertex, c.triangle, c.bary, c.distance));
    let ee = found
        .edge_edge
        .iter()
        .map(|c| edge_edge_contact(mesh, at, c.edges, c.params, c.distance));
    vt.chain(ee).collect()
}

/// Vertex `v` against triangle `t` at positions `at`, closest point at barycentrics `w`.
fn vertex_triangle_contact(
    mesh: &Mesh,
    at: impl Fn(u32) -> DVec3,
    v: u32,
    t: u32,
    w: [f64; 3],
    distance: f64,
) -> Contact {
    let scale = mesh.mean_edge_length();
    let tri = mesh.triangles()[t as usize];
    let [a, b, c] = tri.map(&at);
    let q = a * w[0] + b * w[1] + c * w[2];
    let face = unit_or((b - a).cross(c - a), scale * scale, DVec3::Z);
    Contact {
        verts: [v, tri[0], tri[1], tri[2]],
        weights: [1.0, -w[0], -w[1], -w[2]],
        normal: unit_or(at(v) - q, scale, face),
        distance,
        kind: ContactKind::VertexTriangle,
    }
}

/// Edges `e` at positions `at`, closest points at parameters `st` along each.
fn edge_edge_contact(mesh: &Mesh, at: impl Fn(u32) -> DVec3, e: [u32; 2], st: [f64; 2], distance: f64) -> Contact {
    let scale = mesh.mean_edge_length();
    let edges = &mesh.topology().edges;
    let ([a, b], [p, q]) = (edges[e[0] as usize], edges[e[1] as usize]);
    let [s, t] = st;
    let (xa, xb, xp, xq) = (at(a), at(b), at(p), at(q));
    let across = unit_or((xb - xa).cross(xq - xp), scale * scale, DVec3::Z);
    let gap = (xa + (xb - xa) * s) - (xp + (xq - xp) * t);
    Contact {
        verts: [a, b, p, q],
        weights: [1.0 - s, s, t - 1.0, -t],
        normal: unit_or(gap, scale, across),
        distance,
        kind: ContactKind::EdgeEdge,
    }
}

/// The relative normal velocity a contact must reach this step (see the module doc).
#[inline]
fn goal(c: &Contact, p: &ContactParams, h: f64) -> f64 {
    let gap = c.distance - p.thickness;
    if gap < 0.0 {
        -p.push * gap / h
    } else {
        -gap / h
    }
}

/// Stage 1: constrains, in the solve's filter, every vertex closer than `d` to
/// a triangle that is not separating at the goal speed. `dv_prev` is the last
/// step's velocity change (the triangle's acceleration estimate). Returns the
/// number of constraints added.
pub fn constrain(
    contacts: &[Contact],
    v: &[DVec3],
    dv_prev: &[DVec3],
    p: &ContactParams,
    h: f64,
    filter: &mut Filter,
) -> usize {
    let mut added = 0;
    for c in contacts
        .iter()
        .filter(|c| c.kind == ContactKind::VertexTriangle && c.distance < p.thickness)
    {
        let (vn, want) = (c.normal_velocity(v), goal(c, p, h));
        if vn >= want {
            continue;
        }
        // The triangle's part of sum w dv (weights 1..3 are minus its barycentrics).
        let obstacle_dv: DVec3 = (1..4)
            .map(|k| dv_prev[c.verts[k] as usize] * -c.weights[k])
            .sum();
        let target = want - vn + obstacle_dv.dot(c.normal);
        if filter.constrain(c.verts[0] as usize, c.normal, target) {
            added += 1;
        }
    }
    added
}

/// What the impulse stage did.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ImpulseStats {
    /// Gauss-Seidel sweeps run.
    pub sweeps: u32,
    /// Impulses applied, over all sweeps.
    pub impulses: u64,
}

/// Stage 2: mass-weighted impulses until every contact meets its goal normal
/// velocity (or `p.sweeps` sweeps). An impulse `j` along n changes `v_k` by
/// `w_k j n / m_k`, with `j = (goal - vn) / sum_k w_k^2 / m_k`, so momentum is
/// conserved and pinned vertices (inverse mass 0) do not move.
pub fn impulses(
    contacts: &[Contact],
    inv_mass: &[f64],
    v: &mut [DVec3],
    p: &ContactParams,
    h: f64,
) -> ImpulseStats {
    resolve(contacts, inv_mass, v, p.sweeps, 1e-9 * p.thickness / h, |c| goal(c, p, h))
}

/// Gauss-Seidel over `contacts` until each has relative normal velocity at
/// least `goal(c)` (within `slack`), or `sweeps` sweeps.
fn resolve(
    contacts: &[Contact],
    inv_mass: &[f64],
    v: &mut [DVec3],
    sweeps: u32,
    slack: f64,
    goal: impl Fn(&Contact) -> f64,
) -> ImpulseStats {
    let mut stats = ImpulseStats::default();
    while stats.sweeps < sweeps {
        stats.sweeps += 1;
        let mut applied = 0;
        for c in contacts {
            let deficit = goal(c) - c.normal_velocity(v);
            if deficit <= slack {
                continue;
            }
            let w_m: f64 = (0..4)
                .map(|k| c.weights[k] * c.weights[k] * inv_mass[c.verts[k] as usize])
                .sum();
            if !(w_m > 0.0) {
                continue;
            }
            let j = deficit / w_m;
            for k in 0..4 {
                let i = c.verts[k] as usize;
                v[i] += c.normal * (c.weights[k] * inv_mass[i] * j);
            }
            applied += 1;
        }
        stats.impulses += applied;
        if applied == 0 {
            break;
        }
    }
    stats
}

/// What the continuous stage did.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ContinuousStats {
    /// Continuous queries run.
    pub rounds: u32,
    /// Element pairs found meeting during the step, over all rounds.
    pub impacts: u64,
    /// Impulses applied, over all rounds.
    pub impulses: u64,
    /// Query time (s).
    pub detect_time: f64,
}

/// Stage 2b, continuous collisions (Bridson et al. 2002): the step moves every
/// vertex from `x0` to `x0 + h v`. Each element pair that comes within
/// `separation` on the way (the engine's continuous query, no false negatives)
/// gets an inelastic impulse that stops its approach along the normal at its
/// time of impact; the query repeats with the new velocities, up to `rounds`
/// times. What is left is for the correction stage.
pub fn continuous_impulses(
    query: &mut BvhDetector,
    x0: &[DVec3],
    inv_mass: &[f64],
    v: &mut [DVec3],
    h: f64,
    separation: f64,
    rounds: u32,
) -> Result<ContinuousStats> {
    let mesh = query.mesh().clone();
    let mut stats = ContinuousStats::default();
    let mut x1 = vec![DVec3::ZERO; x0.len()];
    while stats.rounds < rounds {
        for ((e, a), b) in x1.iter_mut().zip(x0).zip(v.iter()) {
            *e = *a + *b * h;
        }
        let t0 = Instant::now();
        let found = query.continuous(x0, &x1, separation)?;
        stats.detect_time += t0.elapsed().as_secs_f64();
        stats.rounds += 1;
        let hits: Vec<Contact> = found
            .vertex_triangle
            .iter()
            .chain(&found.edge_edge)
            .map(|i| impact_contact(&mesh, x0, &x1, i))
            .collect();
        stats.impacts += hits.len() as u64;
        let applied = resolve(&hits, inv_mass, v, 20, 0.0, |_| 0.0).impulses;
        stats.impulses += applied;
        if applied == 0 {
            break;
        }
    }
    Ok(stats)
}

/// The contact of an impact at its time: closest points and normal there.
fn impact_contact(mesh: &Mesh, x0: &[DVec3], x1: &[DVec3], i: &Impact) -> Contact {
    let at = |k: u32| x0[k as usize].lerp(x1[k as usize], i.toi);
    match i.pair {
        ElementPair::VertexTriangle(v, t) => {
            let [a, b, c] = mesh.triangles()[t as usize].map(at);
            let (d2, w) = point_triangle_distance2(at(v), a, b, c);
            vertex_triangle_contact(mesh, at, v, t, w, d2.sqrt())
        }
        ElementPair::EdgeEdge(e0, e1) => {
            let edges = &mesh.topology().edges;
            let ([a, b], [p, q]) = (edges[e0 as usize], edges[e1 as usize]);
            let (d2, s, t) = segment_segment_distance2(at(a), at(b), at(p), at(q));
            edge_edge_contact(mesh, at, [e0, e1], [s, t], d2.sqrt())
        }
    }
}

/// What the correction stage did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Correction {
    /// Detections run (the last one at the final positions).
    pub rounds: u32,
    /// Vertices moved rigidly with an impact zone (or put back, if frozen).
    pub zone_vertices: usize,
    /// Impact zones at the end of the stage.
    pub zones: usize,
    /// Intersecting pairs left (0 unless the step started with intersections).
    pub remaining: usize,
    /// Detection time (s).
    pub detect_time: f64,
    /// The last detection, at the final positions.
    pub detection: Detection,
}

/// Start-of-step state and masses the correction stage moves zones with.
pub struct StepStart<'a> {
    /// Positions at the start of the step (intersection-free).
    pub x0: &'a [DVec3],
    /// Vertex masses.
    pub mass: &'a [f64],
    /// Pinned vertices: a zone holding one is frozen.
    pub pinned: &'a [bool],
    /// Time step (s).
    pub h: f64,
}

/// Stage 3, rigid impact zones (Provot 1997; Bridson et al. 2002), checked
/// with `detector` (which must be conservative for the guarantee):
///
/// while the detector finds intersecting pairs at `x`: merge the vertices of
/// each pair's two triangles into one zone (union-find); every zone then moves
/// rigidly from its start-of-step positions with its own momentum and angular
/// momentum, `x_i = c0 + h v_c + R(h w) (x0_i - c0)`, `w = I^-1 L` (pinned
/// vertices count with their zero velocity and stay put). A rigid motion keeps
/// the zone's own triangles as intersection-free as they were at `x0`, so each
/// round must merge or grow zones, unless a pin stayed behind; if a round
/// cannot, the zones still intersecting are frozen at `x0` with zero velocity,
/// and if that cannot help either, the stage stops and reports the pairs left.
pub fn correct(detector: &mut dyn Detector, start: &StepStart, x: &mut [DVec3], v: &mut [DVec3]) -> Result<Correction> {
    let mesh = detector.mesh().clone();
    let tris = mesh.triangles();
    let mut zones = Zones::new(x.len(), start.pinned);
    let v_in = v.to_vec();
    let mut out = Correction::default();
    loop {
        let t0 = Instant::now();
        let det = detector.detect(x)?;
        out.detect_time += t0.elapsed().as_secs_f64();
        out.rounds += 1;
        let mut changed = false;
        for &[a, b] in &det.pairs {
            let (ta, tb) = (tris[a as usize], tris[b as usize]);
            for &i in ta.iter().chain(&tb) {
                changed |= zones.join(ta[0] as usize, i as usize);
            }
        }
        if !changed && !det.pairs.is_empty() {
            for &[a, b] in &det.pairs {
                changed |= zones.freeze(tris[a as usize][0] as usize);
                changed |= zones.freeze(tris[b as usize][0] as usize);
            }
        }
        if !changed {
            out.remaining = det.pairs.len();
            out.zones = zones.count();
            out.zone_vertices = zones.members();
            out.detection = det;
            return Ok(out);
        }
        zones.move_rigidly(start, &v_in, x, v);
    }
}

/// Impact zones: a union-find over vertices, with membership and a frozen flag per root.
struct Zones {
    parent: Vec<u32>,
    member: Vec<bool>,
    frozen: Vec<bool>,
    pinned: Vec<bool>,
}

impl Zones {
    fn new(n: usize, pinned: &[bool]) -> Zones {
        Zones { parent: (0..n as u32).collect(), member: vec![false; n], frozen: vec![false; n], pinned: pinned.to_vec() }
    }

    fn root(&mut self, mut i: usize) -> usize {
        while self.parent[i] as usize != i {
            let p = self.parent[i] as usize;
            self.parent[i] = self.parent[p];
            i = p;
        }
        i
    }

    /// Puts `i` in `a`'s zone; true when that changed anything.
    fn join(&mut self, a: usize, i: usize) -> bool {
        let new_member = !(self.member[a] && self.member[i]);
        self.member[a] = true;
        self.member[i] = true;
        let (ra, ri) = (self.root(a), self.root(i));
        if ra == ri {
            return new_member;
        }
        // The smaller index becomes the root: the result does not depend on order.
        let (keep, drop) = (ra.min(ri), ra.max(ri));
        self.parent[drop] = keep as u32;
        self.frozen[keep] |= self.frozen[drop];
        true
    }

    /// Freezes `i`'s zone; true when it was not frozen.
    fn freeze(&mut self, i: usize) -> bool {
        let r = self.root(i);
        !std::mem::replace(&mut self.frozen[r], true)
    }

    fn members(&self) -> usize {
        self.member.iter().filter(|&&m| m).count()
    }

    fn count(&mut self) -> usize {
        (0..self.parent.len()).filter(|&i| self.member[i] && self.root(i) == i).count()
    }

    /// Moves every zone rigidly from `x0` with the momentum of the velocities `u`.
    fn move_rigidly(&mut self, s: &StepStart, u: &[DVec3], x: &mut [DVec3], v: &mut [DVec3]) {
        let n = x.len();
        let mut by_root: Vec<Vec<u32>> = vec![Vec::new(); n];
        for i in 0..n {
            if self.member[i] {
                let r = self.root(i);
                by_root[r].push(i as u32);
            }
        }
        for (r, verts) in by_root.iter().enumerate().filter(|(_, z)| !z.is_empty()) {
            let motion = if self.frozen[r] { RigidMotion::default() } else { RigidMotion::of(verts, s, u) };
            for &i in verts.iter().filter(|&&i| !self.pinned[i as usize]) {
                let i = i as usize;
                x[i] = motion.apply(s.x0[i]);
                v[i] = (x[i] - s.x0[i]) / s.h;
            }
        }
    }
}

/// A rigid displacement over one step: `p -> c0 + t + R (p - c0)`.
#[derive(Debug, Clone, Copy)]
struct RigidMotion {
    c0: DVec3,
    t: DVec3,
    r: DQuat,
}

impl Default for RigidMotion {
    fn default() -> Self {
        RigidMotion { c0: DVec3::ZERO, t: DVec3::ZERO, r: DQuat::IDENTITY }
    }
}

impl RigidMotion {
    /// The motion of `verts` with their total momentum and angular momentum (about
    /// the centre of mass at `x0`) under velocities `u`, over one step.
    fn of(verts: &[u32], s: &StepStart, u: &[DVec3]) -> RigidMotion {
        let m = |i: u32| s.mass[i as usize];
        let total: f64 = verts.iter().map(|&i| m(i)).sum();
        let c0 = verts.iter().map(|&i| s.x0[i as usize] * m(i)).sum::<DVec3>() / total;
        let vc = verts.iter().map(|&i| u[i as usize] * m(i)).sum::<DVec3>() / total;
        let (mut l, mut inertia) = (DVec3::ZERO, DMat3::ZERO);
        for &i in verts {
            let r = s.x0[i as usize] - c0;
            l += r.cross(u[i as usize] - vc) * m(i);
            inertia += (DMat3::from_diagonal(DVec3::splat(r.length_squared())) - outer(r)) * m(i);
        }
        // A small regularisation keeps a (nearly) collinear zone's inertia invertible.
        let eps = 1e-9 * (inertia.x_axis.x + inertia.y_axis.y + inertia.z_axis.z) + f64::MIN_POSITIVE;
        let inertia = inertia + DMat3::from_diagonal(DVec3::splat(eps));
        let w = if inertia.determinant() > 0.0 { inertia.inverse() * l } else { DVec3::ZERO };
        let angle = w.length() * s.h;
        let r = if angle > 0.0 && angle.is_finite() { DQuat::from_axis_angle(w / w.length(), angle) } else { DQuat::IDENTITY };
        RigidMotion { c0, t: vc * s.h, r }
    }

    #[inline]
    fn apply(&self, p: DVec3) -> DVec3 {
        self.c0 + self.t + self.r * (p - self.c0)
    }
}
