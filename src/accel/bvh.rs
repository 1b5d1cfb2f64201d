//! The pure-Rust backend: obvhs's compressed wide BVH (CWBVH: eight children per node,
//! quantised child boxes, 80 bytes a node) over every primitive of the scene, with primitive
//! tests written to answer as Embree does, so that images match between backends:
//!
//! - triangles: Embree's robust (Plücker) test: edge functions computed from the vertices
//!   relative to the ray origin, so neighbouring triangles agree on their shared edge
//!   (watertight); u, v are the weights of vertices 1 and 2; Ng = (v1 − v0) × (v2 − v0);
//! - quads: split as Embree splits them, into (v0, v1, v3) and (v2, v3, v1), reporting the
//!   quad index and Embree's quad parameterisation (u along v0→v1, v along v0→v3);
//! - spheres: Embree's point-sphere test: the nearer root in `[tmin, tmax]`, else the farther
//!   one; Ng points outwards; u = v = 0; prim_id 0.
//!
//! A shape with an alpha has a `Cutout` that every candidate hit on it passes before it
//! counts (a sphere's exit point is tried when its entry point is cut out, as Embree does).
//!
//! Primitives are stored in BVH leaf order, so a leaf indexes them directly, as three indices
//! into the scene's shared vertices.
//!
//! Instances make a second level: each prototype has a BVH of its own, and the scene's BVH
//! holds one slot per instance, boxed by its placed prototype; a ray reaching the slot is
//! carried into the prototype's space and traced through its BVH, as Embree does.

use super::cutout::Cutout;
use super::{Accel, Hit};
use crate::error::Result;
use crate::math::{Ray, Vec3};
use crate::scene::{Geometry, Instance, Primitives, Scene, Shape};
use obvhs::aabb::Aabb;
use obvhs::cwbvh::builder::build_cwbvh;
use obvhs::cwbvh::CwBvh;
use obvhs::ray::Ray as TraversalRay;
use obvhs::BvhBuildParams;
// The `traverse!` macro names obvhs's `UVec2` at the call site.
use obvhs_glam::{UVec2, Vec3A};
use std::time::Duration;

/// obvhs's node test ignores `ray.tmin` and clamps the entry distance to 1e-4 instead, which
/// would skip boxes holding hits closer than 1e-4 ray lengths (a shadow ray's direction spans
/// its whole segment). Traversal therefore runs on a copy of the ray whose direction is
/// scaled by this power of two: every t is scaled by its inverse exactly, and the clamp falls
/// to 1e-4 × 2⁻²⁰ ≈ 1e-10. Primitive tests use the original ray.
const TRAVERSAL_DIR_SCALE: f32 = 1.0 / (1u32 << 20) as f32;

/// Largest magnitude of a traversal inverse direction: keeps slab distances finite (no
/// inf − inf in the node test) for scenes within ±1e6; a direction component below 1e-30
/// (after scaling) already puts the slabs beyond any reachable t.
const MAX_INV_DIR: f32 = 1e30;

/// What a primitive slot holds, and how its hit is reported.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    Triangle,
    /// Triangle (v0, v1, v3) of a quad: u, v as computed.
    QuadFirst,
    /// Triangle (v2, v3, v1) of a quad: u, v mirrored (1 − u, 1 − v) into the quad's.
    QuadSecond,
    /// `p[0]` is the centre, `p[1].x` the radius.
    Sphere,
    /// A placed prototype: the slot's first index is the instance's.
    Instance,
}

/// One primitive's geometry, gathered from the shared vertices: three vertices, or a
/// sphere's centre and radius.
#[derive(Clone, Copy, Debug)]
struct Prim {
    p: [Vec3A; 3],
}

/// Which shape and primitive a slot answers for, and how.
#[derive(Clone, Copy, Debug)]
struct Meta {
    geom_id: u32,
    prim_id: u32,
    kind: Kind,
}

/// A primitive's ids, read only for the final hit.
#[derive(Clone, Copy, Debug)]
struct Ids {
    geom_id: u32,
    prim_id: u32,
}

/// [`Accel`] over obvhs's CWBVH.
pub struct BvhAccel {
    bvh: CwBvh,
    /// Every shape's vertices, shared by its primitives as in the meshes (a sphere has two:
    /// its centre and (radius, 0, 0)). Indexing them keeps the primitive data small (meshes
    /// share each vertex among about six triangles), which saves memory traffic.
    vertices: Vec<Vec3A>,
    /// Each primitive's three vertex indices, in BVH leaf order (`bvh.primitive_indices`
    /// already applied), with their kinds (read for every test, so kept apart from the ids,
    /// read once per query).
    prims: Vec<[u32; 3]>,
    kinds: Vec<Kind>,
    ids: Vec<Ids>,
    /// Each shape's alpha test, by geometry id; empty when no shape has one.
    cutouts: Vec<Option<Cutout>>,
    /// One BVH per prototype, and the instances placing them (slots of kind `Instance`).
    prototypes: Vec<BvhAccel>,
    instances: Vec<Instance>,
    /// `vertices` at shutter close, empty when no shape moves: a primitive is met
    /// interpolated between the two at the ray's time.
    motion: Vec<Vec3A>,
}

fn to_a(p: Vec3) -> Vec3A {
    Vec3A::new(p.x, p.y, p.z)
}

fn to_vec3(p: Vec3A) -> Vec3 {
    Vec3::new(p.x, p.y, p.z)
}

fn from_glam(p: glam::Vec3A) -> Vec3A {
    Vec3A::new(p.x, p.y, p.z)
}

fn to_glam(p: Vec3A) -> glam::Vec3A {
    glam::Vec3A::new(p.x, p.y, p.z)
}

/// Every shape's vertices at shutter close, in the order of `collect_prims`'s (empty when
/// nothing moves).
fn collect_motion(shapes: &[Shape]) -> Vec<Vec3A> {
    if !shapes.iter().any(|s| s.moves()) {
        return Vec::new();
    }
    let mut vertices = Vec::new();
    for shape in shapes {
        push_vertices(
            &mut vertices,
            shape.motion.as_ref().unwrap_or(&shape.geometry),
        );
    }
    vertices
}

/// Appends a shape's vertices as the primitives index them: a sphere's centre, then its
/// radius in x.
fn push_vertices(vertices: &mut Vec<Vec3A>, geometry: &Geometry) {
    match geometry.primitives() {
        Primitives::Sphere { center, radius } => {
            vertices.extend([to_a(center), Vec3A::new(radius, 0.0, 0.0)]);
        }
        Primitives::Triangles(m) => vertices.extend(m.positions.iter().map(|p| to_a(*p))),
        Primitives::Quads(q) => vertices.extend(q.positions.iter().map(|p| to_a(*p))),
    }
}

/// The shapes' vertices, and their primitives in shape order (the BVH reorders them).
fn collect_prims(shapes: &[Shape]) -> (Vec<Vec3A>, Vec<[u32; 3]>, Vec<Meta>) {
    let mut vertices = Vec::new();
    let mut prims = Vec::new();
    let mut meta = Vec::new();
    for (geom_id, shape) in shapes.iter().enumerate() {
        let base = vertices.len() as u32;
        let mut push = |p: [u32; 3], prim_id: usize, kind: Kind| {
            prims.push(p.map(|k| base + k));
            meta.push(Meta {
                geom_id: geom_id as u32,
                prim_id: prim_id as u32,
                kind,
            });
        };
        match shape.geometry.primitives() {
            Primitives::Sphere { .. } => push([0, 1, 1], 0, Kind::Sphere),
            Primitives::Triangles(m) => {
                for (i, t) in m.indices.iter().enumerate() {
                    push(*t, i, Kind::Triangle);
                }
            }
            Primitives::Quads(q) => {
                for (i, &[v0, v1, v2, v3]) in q.indices.iter().enumerate() {
                    push([v0, v1, v3], i, Kind::QuadFirst);
                    push([v2, v3, v1], i, Kind::QuadSecond);
                }
            }
        }
        push_vertices(&mut vertices, &shape.geometry);
    }
    (vertices, prims, meta)
}

impl Prim {
    fn aabb(&self, kind: Kind) -> Aabb {
        match kind {
            Kind::Sphere => {
                let r = Vec3A::splat(self.p[1].x);
                Aabb::new(self.p[0] - r, self.p[0] + r)
            }
            Kind::Instance => unreachable!("an instance's box is its placed prototype's"),
            _ => Aabb::from_points(&self.p),
        }
    }

    /// The hit distance in `[tmin, tmax]`, or infinity for a miss.
    #[inline(always)]
    fn hit_t(&self, kind: Kind, org: Vec3A, dir: Vec3A, tmin: f32, tmax: f32) -> f32 {
        let t = match kind {
            Kind::Sphere => sphere(self.p[0], self.p[1].x, org, dir, tmin, tmax).map(|h| h.0),
            _ => triangle(&self.p, org, dir).map(|h| h.t),
        };
        match t {
            Some(t) if t >= tmin && t <= tmax => t,
            _ => f32::INFINITY,
        }
    }

    /// u, v and Ng of a hit found by `hit_t` (recomputed with the same arithmetic).
    fn details(
        &self,
        kind: Kind,
        org: Vec3A,
        dir: Vec3A,
        tmin: f32,
        tmax: f32,
    ) -> (f32, f32, Vec3A) {
        match kind {
            Kind::Sphere => {
                let (_, ng) = sphere(self.p[0], self.p[1].x, org, dir, tmin, tmax)
                    .expect("the sphere was hit");
                (0.0, 0.0, ng)
            }
            _ => {
                let h = triangle(&self.p, org, dir).expect("the triangle was hit");
                let (u, v) = h.weights();
                match kind {
                    Kind::QuadSecond => (1.0 - u, 1.0 - v, h.ng),
                    _ => (u, v, h.ng),
                }
            }
        }
    }
}

/// A triangle hit before normalisation: edge functions U, V, W (weights of v1, v2, v0,
/// unscaled), their sum, the distance, and Ng.
struct TriangleHit {
    u: f32,
    v: f32,
    w: f32,
    uvw: f32,
    t: f32,
    ng: Vec3A,
}

/// Embree's robust ray-triangle test (Plücker coordinates), both faces. The distance is
/// returned unclipped; the caller checks it against the ray's interval.
#[inline(always)]
fn triangle(p: &[Vec3A; 3], org: Vec3A, dir: Vec3A) -> Option<TriangleHit> {
    let h = plucker(p, org, dir);
    let eps = f32::EPSILON * h.uvw.abs();
    let inside = h.u.min(h.v).min(h.w) >= -eps || h.u.max(h.v).max(h.w) <= eps;
    let den = h.ng.dot(dir);
    (inside && den != 0.0 && h.t.is_finite()).then_some(h)
}

/// The edge functions, distance and normal of the triangle test, for any ray.
#[inline(always)]
fn plucker(p: &[Vec3A; 3], org: Vec3A, dir: Vec3A) -> TriangleHit {
    let (u, v, w, [v0, _, _], ng) = edge_functions(p, org, dir);
    let t = v0.dot(ng) / ng.dot(dir);
    TriangleHit {
        u,
        v,
        w,
        uvw: u + v + w,
        t,
        ng,
    }
}

/// The test's edge functions U, V, W, the vertices relative to the origin, and the
/// normal: the hit point's recomputation calls it with the ray a backend reported a hit
/// for, so that both backends' hits come out of this arithmetic.
#[inline(always)]
fn edge_functions(p: &[Vec3A; 3], org: Vec3A, dir: Vec3A) -> (f32, f32, f32, [Vec3A; 3], Vec3A) {
    let v0 = p[0] - org;
    let v1 = p[1] - org;
    let v2 = p[2] - org;
    let e0 = v2 - v0;
    let e1 = v0 - v1;
    let e2 = v1 - v2;
    let u = e0.cross(v2 + v0).dot(dir);
    let v = e1.cross(v0 + v1).dot(dir);
    let w = e2.cross(v1 + v2).dot(dir);
    // e0 × e1 = (v2 − v0) × (v0 − v1) = (v1 − v0) × (v2 − v0), each component taken from
    // whichever of e0 × e1 and e1 × e2 cancels less, as Embree's robust mode does: the
    // plane of a sliver stays accurate, so rays leaving it do not meet it again.
    let ng = stable_normal(e0, e1, e2);
    (u, v, w, [v0, v1, v2], ng)
}

impl TriangleHit {
    /// The weights of vertices 1 and 2 (u, v normalised by their sum with w).
    #[inline(always)]
    fn weights(&self) -> (f32, f32) {
        normalised(self.u, self.v, self.uvw)
    }
}

#[inline(always)]
fn normalised(u: f32, v: f32, uvw: f32) -> (f32, f32) {
    let rcp = if uvw == 0.0 { 0.0 } else { 1.0 / uvw };
    ((u * rcp).min(1.0), (v * rcp).min(1.0))
}

/// The normal of a triangle with edges `a`, `b`, `c` (summing to zero): `a × b`, component
/// by component from `a × b` or `b × c`, whichever subtracts the smaller product (Embree's
/// `stable_triangle_normal`).
#[inline(always)]
fn stable_normal(a: Vec3A, b: Vec3A, c: Vec3A) -> Vec3A {
    let ab = Vec3A::new(a.z * b.y, a.x * b.z, a.y * b.x);
    let bc = Vec3A::new(b.z * c.y, b.x * c.z, b.y * c.x);
    let cross_ab = Vec3A::new(a.y * b.z - ab.x, a.z * b.x - ab.y, a.x * b.y - ab.z);
    let cross_bc = Vec3A::new(b.y * c.z - bc.x, b.z * c.x - bc.y, b.x * c.y - bc.z);
    Vec3A::select(ab.abs().cmplt(bc.abs()), cross_ab, cross_bc)
}

/// Embree's ray-sphere test: the entry point if it lies in `[tmin, tmax]`, else the exit point;
/// returns t and the outward normal (hit point minus centre, unnormalised).
#[inline(always)]
fn sphere(
    center: Vec3A,
    radius: f32,
    org: Vec3A,
    dir: Vec3A,
    tmin: f32,
    tmax: f32,
) -> Option<(f32, Vec3A)> {
    let [entry, exit] = sphere_roots(center, radius, org, dir)?;
    [entry, exit]
        .into_iter()
        .find(|(t, _)| *t >= tmin && *t <= tmax)
}

/// The entry and exit points of a ray through a sphere, as distance and outward normal, or
/// None when the ray passes by.
#[inline(always)]
fn sphere_roots(center: Vec3A, radius: f32, org: Vec3A, dir: Vec3A) -> Option<[(f32, Vec3A); 2]> {
    let rd2 = 1.0 / dir.dot(dir);
    let c0 = center - org;
    let proj = c0.dot(dir) * rd2;
    let perp = c0 - proj * dir;
    let l2 = perp.dot(perp);
    let r2 = radius * radius;
    if l2 > r2 || l2.is_nan() {
        return None;
    }
    let td = ((r2 - l2) * rd2).sqrt();
    Some([(proj - td, -td * dir - perp), (proj + td, td * dir - perp)])
}

/// A backend's triangle hit recomputed by this backend's test: the weights of vertices 1
/// and 2 and the unnormalised normal, whether or not the test would count it as a hit.
#[inline]
pub(super) fn triangle_weights(p: [Vec3; 3], org: Vec3, dir: Vec3) -> (f32, f32, Vec3) {
    let (u, v, w, _, ng) = edge_functions(&p.map(to_a), to_a(org), to_a(dir));
    let (u, v) = normalised(u, v, u + v + w);
    (u, v, to_vec3(ng))
}

/// A backend's sphere hit at distance `t` recomputed by this backend's test: the root
/// nearer `t` and its outward normal (None if this test finds no roots).
#[inline]
pub(super) fn sphere_point(
    center: Vec3,
    radius: f32,
    org: Vec3,
    dir: Vec3,
    t: f32,
) -> Option<(f32, Vec3)> {
    let [entry, exit] = sphere_roots(to_a(center), radius, to_a(org), to_a(dir))?;
    let nearer = if (entry.0 - t).abs() <= (exit.0 - t).abs() {
        entry
    } else {
        exit
    };
    Some((nearer.0, to_vec3(nearer.1)))
}

/// The ray obvhs's node test traverses with (see [`TRAVERSAL_DIR_SCALE`]). The inverse
/// direction takes its sign from the same `< 0.0` test obvhs uses to order slabs, so a
/// component of −0.0 is treated as +0.0 throughout (obvhs's own `Ray::new` gives it a
/// negative inverse, which makes the slabs empty and misses everything).
#[inline(always)]
fn traversal_ray(org: Vec3A, dir: Vec3A, tmax: f32) -> TraversalRay {
    let d = dir * TRAVERSAL_DIR_SCALE;
    let inv = |c: f32| {
        if c < 0.0 {
            -1.0 / (-c).max(1.0 / MAX_INV_DIR)
        } else {
            1.0 / c.max(1.0 / MAX_INV_DIR)
        }
    };
    TraversalRay {
        origin: org,
        direction: d,
        inv_direction: Vec3A::new(inv(d.x), inv(d.y), inv(d.z)),
        tmin: 0.0,
        tmax: tmax / TRAVERSAL_DIR_SCALE,
    }
}

impl BvhAccel {
    /// Builds the BVH over every shape of the scene (shape `i` answers as geometry `i`). The
    /// build runs on the current rayon pool.
    pub fn build(scene: &Scene) -> Result<BvhAccel> {
        let mut accel = BvhAccel::empty();
        accel.rebuild(scene)?;
        Ok(accel)
    }

    fn empty() -> BvhAccel {
        BvhAccel {
            bvh: CwBvh::default(),
            vertices: Vec::new(),
            prims: Vec::new(),
            kinds: Vec::new(),
            ids: Vec::new(),
            cutouts: Vec::new(),
            prototypes: Vec::new(),
            instances: Vec::new(),
            motion: Vec::new(),
        }
    }

    /// Rebuilds the BVH from the scene's current geometry: the entry point for animation
    /// (moved vertices, added or removed shapes). obvhs's PLOC builder is fast enough to
    /// rebuild every frame, which keeps the tree as good as a fresh one (a refit would not).
    pub fn rebuild(&mut self, scene: &Scene) -> Result<()> {
        self.prototypes = scene
            .prototypes
            .iter()
            .map(|p| {
                let mut level = BvhAccel::empty();
                level.fill(&p.shapes, &[], &scene.source)?;
                // Prototypes are opaque (the readers place shapes with an alpha as copies).
                level.cutouts.clear();
                Ok(level)
            })
            .collect::<Result<_>>()?;
        self.instances = scene.instances.clone();
        // Each prototype's box once, not once per instance.
        let own_boxes: Vec<_> = scene.prototypes.iter().map(|p| p.bounds()).collect();
        let boxes: Vec<Aabb> = scene
            .instances
            .iter()
            .map(|i| {
                let own = own_boxes[i.prototype as usize];
                if own.0.x > own.1.x {
                    // An empty object: a point box whose BVH finds nothing.
                    return Aabb::new(Vec3A::ZERO, Vec3A::ZERO);
                }
                let (lo, hi) = i.world_bounds(own);
                Aabb::new(to_a(lo), to_a(hi))
            })
            .collect();
        self.fill(&scene.shapes, &boxes, &scene.source)
    }

    /// Builds this level over `shapes` and, after them, one slot per box in `instances`.
    fn fill(
        &mut self,
        shapes: &[Shape],
        instances: &[Aabb],
        source: &std::path::Path,
    ) -> Result<()> {
        if let Some(i) = shapes.iter().position(|s| !s.motion_matches()) {
            return Err(crate::error::Error::input(
                source,
                format!("shape {i} moves into a shape of another kind or topology"),
            ));
        }
        let (vertices, mut prims, mut meta) = collect_prims(shapes);
        self.vertices = vertices;
        self.motion = collect_motion(shapes);
        self.cutouts = Cutout::of_shapes(shapes);
        if self.cutouts.iter().all(Option::is_none) {
            self.cutouts.clear();
        }
        for i in 0..instances.len() {
            prims.push([i as u32, 0, 0]);
            meta.push(Meta {
                geom_id: i as u32,
                prim_id: 0,
                kind: Kind::Instance,
            });
        }
        if prims.is_empty() {
            self.bvh = CwBvh::default();
            self.prims.clear();
            self.kinds.clear();
            self.ids.clear();
            return Ok(());
        }
        let aabbs: Vec<Aabb> = prims
            .iter()
            .zip(&meta)
            .map(|(p, m)| match m.kind {
                Kind::Instance => instances[p[0] as usize],
                kind if self.motion.is_empty() => self.gather(p, 0.0).aabb(kind),
                kind => self
                    .gather(p, 0.0)
                    .aabb(kind)
                    .union(&self.gather(p, 1.0).aabb(kind)),
            })
            .collect();
        if let Some(i) = aabbs
            .iter()
            .position(|b| !(b.min.is_finite() && b.max.is_finite()))
        {
            let what = match meta[i].kind {
                Kind::Instance => format!("instance {}", meta[i].geom_id),
                _ => format!("primitive {} of shape {}", meta[i].prim_id, meta[i].geom_id),
            };
            return Err(crate::error::Error::input(
                source,
                format!("{what} is not finite"),
            ));
        }
        let mut bvh = build_cwbvh(
            &aabbs,
            BvhBuildParams::medium_build(),
            &mut Duration::default(),
        );
        // Leaves index the reordered arrays directly, so the order itself is not kept.
        let order = std::mem::take(&mut bvh.primitive_indices);
        self.prims = order.iter().map(|&i| prims[i as usize]).collect();
        self.kinds = order.iter().map(|&i| meta[i as usize].kind).collect();
        self.ids = order
            .iter()
            .map(|&i| {
                let m = meta[i as usize];
                Ids {
                    geom_id: m.geom_id,
                    prim_id: m.prim_id,
                }
            })
            .collect();
        self.bvh = bvh;
        Ok(())
    }

    /// Bytes held by the BVH nodes and the primitive data (vertices, indices, kinds, ids).
    pub fn memory_bytes(&self) -> usize {
        self.bvh.nodes.capacity() * std::mem::size_of::<obvhs::cwbvh::node::CwBvhNode>()
            + self.bvh.primitive_indices.capacity() * 4
            + self.vertices.capacity() * std::mem::size_of::<Vec3A>()
            + self.prims.capacity() * std::mem::size_of::<[u32; 3]>()
            + self.kinds.capacity() * std::mem::size_of::<Kind>()
            + self.ids.capacity() * std::mem::size_of::<Ids>()
            + self.cutouts.capacity() * std::mem::size_of::<Option<Cutout>>()
            + self.motion.capacity() * std::mem::size_of::<Vec3A>()
            + self.instances.capacity() * std::mem::size_of::<Instance>()
            + self
                .prototypes
                .iter()
                .map(BvhAccel::memory_bytes)
                .sum::<usize>()
    }

    /// A primitive's vertices at shutter time `time`.
    #[inline(always)]
    fn gather(&self, p: &[u32; 3], time: f32) -> Prim {
        if self.motion.is_empty() {
            return Prim {
                p: p.map(|k| self.vertices[k as usize]),
            };
        }
        Prim {
            p: p.map(|k| {
                let (a, b) = (self.vertices[k as usize], self.motion[k as usize]);
                a + (b - a) * time
            }),
        }
    }

    /// Number of primitives in the tree (a quad counts as two triangles).
    pub fn primitive_count(&self) -> usize {
        self.prims.len()
    }
}

impl BvhAccel {
    /// The distance of slot `i`'s hit in `[tmin, tmax]` that its shape's alpha keeps
    /// (infinity for none), and the lower bound that finds it again (a sphere's exit point
    /// needs one above the entry point).
    #[inline(always)]
    fn kept_hit(&self, i: usize, ray: &Ray, org: Vec3A, dir: Vec3A, tmax: f32) -> (f32, f32) {
        let tmin = ray.tmin;
        let prim = self.gather(&self.prims[i], ray.time);
        let kind = self.kinds[i];
        let t = prim.hit_t(kind, org, dir, tmin, tmax);
        if self.cutouts.is_empty() || !t.is_finite() {
            return (t, tmin);
        }
        match &self.cutouts[self.ids[i].geom_id as usize] {
            None => (t, tmin),
            Some(cutout) => self.cutout_hit(cutout, i, (org, dir, ray.time), tmin, tmax, t),
        }
    }

    /// `kept_hit` for a hit at `t` on a shape with a cut-out (kept out of line: opaque
    /// scenes never come here).
    #[inline(never)]
    fn cutout_hit(
        &self,
        cutout: &Cutout,
        i: usize,
        (org, dir, time): (Vec3A, Vec3A, f32),
        tmin: f32,
        tmax: f32,
        t: f32,
    ) -> (f32, f32) {
        let prim = self.gather(&self.prims[i], time);
        let kind = self.kinds[i];
        let prim_id = self.ids[i].prim_id;
        let keeps = |t: f32, tmin: f32| {
            let (u, v, _) = prim.details(kind, org, dir, tmin, t);
            cutout.keeps_hit(to_vec3(org), to_vec3(dir), t, prim_id, u, v)
        };
        if keeps(t, tmin) {
            return (t, tmin);
        }
        if kind == Kind::Sphere {
            let exit_min = t.next_up();
            let exit = prim.hit_t(kind, org, dir, exit_min, tmax);
            if exit.is_finite() && keeps(exit, exit_min) {
                return (exit, exit_min);
            }
        }
        (f32::INFINITY, tmin)
    }
}

/// What a primitive visit tells the traversal.
enum Visit {
    Continue,
    /// A hit at this distance: only nearer ones matter now.
    Shorten(f32),
    Stop,
}

impl BvhAccel {
    /// Walks the primitives of every leaf the ray's box tests reach, calling `visit` with
    /// the primitive's slot.
    #[inline(always)]
    fn traverse(&self, org: Vec3A, dir: Vec3A, tmax: f32, mut visit: impl FnMut(usize) -> Visit) {
        let mut tray = traversal_ray(org, dir, tmax);
        let mut state = self.bvh.new_traversal(tray.direction);
        let mut node;
        // The macro's primitive loop is nested in its node loop: leave both by the label.
        'walk: {
            obvhs::traverse!(
                self.bvh,
                node,
                state,
                node.intersect_ray(&tray, state.oct_inv4),
                {
                    match visit(state.primitive_id as usize) {
                        Visit::Continue => {}
                        Visit::Shorten(t) => tray.tmax = t / TRAVERSAL_DIR_SCALE,
                        Visit::Stop => break 'walk,
                    }
                }
            );
        }
    }
}

impl BvhAccel {
    /// The closest hit with `ray.tmin <= t <= tmax` of `ray` at `org` along `dir` in this
    /// level's space (for a prototype's level, the normal in the prototype's space).
    fn closest(&self, ray: &Ray, org: Vec3A, dir: Vec3A, tmax: f32) -> Option<Hit> {
        let mut tmax = tmax;
        let mut best = None;
        let mut placed = None;
        let instanced = !self.instances.is_empty();
        self.traverse(org, dir, tmax, |i| {
            if instanced && self.kinds[i] == Kind::Instance {
                return match self.instance_closest(i, ray, org, dir, tmax) {
                    Some(hit) => {
                        tmax = hit.t;
                        placed = Some(hit);
                        best = None;
                        Visit::Shorten(hit.t)
                    }
                    None => Visit::Continue,
                };
            }
            let (t, tmin) = self.kept_hit(i, ray, org, dir, tmax);
            // A hit exactly at the current tmax replaces the last one, as in Embree.
            if t <= tmax && t.is_finite() {
                tmax = t;
                best = Some((i, tmin));
                placed = None;
                Visit::Shorten(t)
            } else {
                Visit::Continue
            }
        });
        if placed.is_some() {
            return placed;
        }
        let (i, tmin) = best?;
        let m = self.ids[i];
        let (u, v, ng) =
            self.gather(&self.prims[i], ray.time)
                .details(self.kinds[i], org, dir, tmin, tmax);
        Some(Hit {
            t: tmax,
            u,
            v,
            ng: to_vec3(ng),
            geom_id: m.geom_id,
            prim_id: m.prim_id,
            instance: None,
        })
    }

    /// The closest hit within slot `i`'s instance: the ray carried into its prototype's
    /// space (t is the same there: the direction is transformed, not normalised).
    #[inline(never)]
    fn instance_closest(
        &self,
        i: usize,
        ray: &Ray,
        org: Vec3A,
        dir: Vec3A,
        tmax: f32,
    ) -> Option<Hit> {
        let k = self.prims[i][0];
        let instance = &self.instances[k as usize];
        let (o, d) = to_object(instance, org, dir);
        let mut hit = self.prototypes[instance.prototype as usize].closest(ray, o, d, tmax)?;
        hit.ng = instance.normal_to_world(hit.ng);
        hit.instance = Some(k);
        Some(hit)
    }

    /// Whether anything lies along `ray`, at `org` along `dir` in this level's space.
    fn any_hit(&self, ray: &Ray, org: Vec3A, dir: Vec3A) -> bool {
        let mut hit = false;
        let instanced = !self.instances.is_empty();
        self.traverse(org, dir, ray.tmax, |i| {
            hit = if instanced && self.kinds[i] == Kind::Instance {
                let instance = &self.instances[self.prims[i][0] as usize];
                let (o, d) = to_object(instance, org, dir);
                self.prototypes[instance.prototype as usize].any_hit(ray, o, d)
            } else {
                self.kept_hit(i, ray, org, dir, ray.tmax).0.is_finite()
            };
            if hit {
                Visit::Stop
            } else {
                Visit::Continue
            }
        });
        hit
    }
}

/// A ray's origin and direction in an instance's prototype space.
#[inline(always)]
fn to_object(instance: &Instance, org: Vec3A, dir: Vec3A) -> (Vec3A, Vec3A) {
    let m = instance.to_object();
    (
        from_glam(m.transform_point3a(to_glam(org))),
        from_glam(m.transform_vector3a(to_glam(dir))),
    )
}

impl Accel for BvhAccel {
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        self.closest(ray, to_a(ray.origin), to_a(ray.dir), ray.tmax)
    }

    fn occluded(&self, ray: &Ray) -> bool {
        self.any_hit(ray, to_a(ray.origin), to_a(ray.dir))
    }
}
