//! What changed between two frames (section 3.3): objects that moved, appeared, disappeared or
//! changed material give boxes whose voxels are marked changed; lights give boxes for the
//! shadow tables or, when they move, reach every block that found a surface; anything that
//! every pixel depends on forces a full frame.

use crate::math::Vec3;
use crate::scene::lights::LightSet;
use crate::scene::{Geometry, Light, Primitives, Scene, Shape};
use rustc_hash::FxHashMap;
use std::hash::{Hash, Hasher};
use std::sync::Arc;

/// An axis-aligned box.
pub type Aabb = (Vec3, Vec3);

/// What a frame's pixels can depend on, in a form two frames can be compared by.
#[derive(Clone, Debug)]
pub struct FrameSummary {
    /// Shapes by fingerprint (geometry and material): their boxes, whether they emit, and
    /// their geometry (whose surface a change marks).
    shapes: FxHashMap<u64, Vec<(Aabb, bool, Arc<Geometry>)>>,
    /// Shape `i`'s fingerprint: a hit on shape `i` recorded in an earlier frame names the
    /// same object now only if its fingerprint is the same (shapes come and go).
    pub keys: Vec<u64>,
    lights: Vec<Light>,
    /// Everything that reaches every pixel (camera, world settings, the light choice of the
    /// Monte Carlo integrators), as text.
    global: String,
}

/// The difference between two frames.
#[derive(Clone, Debug, Default)]
pub struct Changes {
    /// Boxes around changed objects (old and new places).
    pub objects: Vec<Aabb>,
    /// The changed objects' geometry (old and new places), one per box of `objects`: the
    /// voxels its surface touches are marked, both tables ([`surface_boxes`](Self::surface_boxes)).
    pub geometry: Vec<Arc<Geometry>>,
    /// Boxes around lights that moved, appeared or vanished: shadow tables only.
    pub shadows: Vec<Aabb>,
    /// Point lights whose intensity alone changed (indices into the scene's lights): the
    /// blocks whose shadow rays went to them, and only those, see the change.
    pub dimmed: Vec<usize>,
    /// A light moved, appeared, vanished or turned: every block that found a surface may
    /// now face it differently.
    pub light_moved: bool,
    /// Why every pixel must be retraced, if so.
    pub everything: Option<String>,
}

impl Changes {
    /// Boxes no larger than `size` along any axis (but for rounding) that together cover
    /// the surfaces of the changed objects (old and new places), and the shadow boxes of
    /// changed lights: where a change can alter a ray's answer. A ray segment is only
    /// affected by an object that moved (appeared, vanished, changed material) if it ends on
    /// the object's old surface or crosses its new one (a segment starting on it starts on
    /// its surface too), so the voxels its surface touches suffice; its box would also mark
    /// the empty space inside and around it (a plank lying aslant, the hole of a torus).
    pub fn surface_boxes(&self, size: f32) -> Vec<Aabb> {
        let mut out = Vec::new();
        for g in &self.geometry {
            surface_boxes(g, size, &mut out);
        }
        out.extend_from_slice(&self.shadows);
        out
    }
}

fn hash_f32s(h: &mut impl Hasher, v: impl IntoIterator<Item = f32>) {
    for x in v {
        x.to_bits().hash(h);
    }
}

/// Boxes no larger than `size` covering the surface of `g` (appended to `out`).
pub fn surface_boxes(g: &Geometry, size: f32, out: &mut Vec<Aabb>) {
    let size = size.max(1e-6);
    match g.primitives() {
        Primitives::Sphere { center, radius } => {
            // The cells of a lattice over its box that the sphere's surface passes through.
            let n = ((2.0 * radius / size).ceil() as u32).clamp(1, 256);
            let step = 2.0 * radius / n as f32;
            let lo = center - radius;
            for z in 0..n {
                for y in 0..n {
                    for x in 0..n {
                        let a = lo + Vec3::new(x as f32, y as f32, z as f32) * step;
                        let b = a + step;
                        let nearest = center.clamp(a, b).distance(center);
                        let farthest = (center - a).abs().max((center - b).abs()).length();
                        // A hair of slack for rounding (the boxes are grown again when used).
                        if nearest <= radius * (1.0 + 1e-5) && farthest >= radius * (1.0 - 1e-5) {
                            out.push((a, b));
                        }
                    }
                }
            }
        }
        Primitives::Triangles(m) => {
            for t in &m.indices {
                let p = t.map(|i| m.positions[i as usize]);
                triangle_boxes(p, size, 0, out);
            }
        }
        Primitives::Quads(m) => {
            // Both ways of cutting each quad into triangles (the backends may differ).
            for q in &m.indices {
                let p = q.map(|i| m.positions[i as usize]);
                for t in [[0, 1, 2], [0, 2, 3], [0, 1, 3], [1, 2, 3]] {
                    triangle_boxes(t.map(|i| p[i]), size, 0, out);
                }
            }
        }
    }
}

/// Boxes no larger than `size` covering the triangle `p`: its box, or those of its four
/// halves (midpoint subdivision), recursively.
fn triangle_boxes(p: [Vec3; 3], size: f32, depth: u32, out: &mut Vec<Aabb>) {
    let (lo, hi) = (p[0].min(p[1]).min(p[2]), p[0].max(p[1]).max(p[2]));
    if (hi - lo).max_element() <= size || depth >= 12 {
        out.push((lo, hi));
        return;
    }
    let m = [
        (p[0] + p[1]) * 0.5,
        (p[1] + p[2]) * 0.5,
        (p[2] + p[0]) * 0.5,
    ];
    for t in [
        [p[0], m[0], m[2]],
        [m[0], p[1], m[1]],
        [m[2], m[1], p[2]],
        [m[0], m[1], m[2]],
    ] {
        triangle_boxes(t, size, depth + 1, out);
    }
}

/// Material `i` as text, with the materials a mix chooses from (to `depth` levels): a change
/// to any of them changes it.
fn material_text(scene: &Scene, i: usize, depth: usize) -> String {
    let m = &scene.materials[i];
    let mut text = format!("{m:?}");
    if let Some(mix) = m.mix().filter(|_| depth > 0) {
        for j in mix.materials {
            text += &material_text(scene, j, depth - 1);
        }
    }
    text
}

fn shape_fingerprint(shape: &Shape, material: &str) -> u64 {
    let mut h = std::collections::hash_map::DefaultHasher::new();
    material.hash(&mut h);
    match shape.geometry.primitives() {
        Primitives::Sphere { center, radius } => {
            0u8.hash(&mut h);
            hash_f32s(&mut h, center.to_array().into_iter().chain([radius]));
        }
        Primitives::Triangles(m) => {
            1u8.hash(&mut h);
            hash_f32s(&mut h, m.positions.iter().flat_map(|p| p.to_array()));
            m.indices.hash(&mut h);
            if let Some(n) = &m.normals {
                hash_f32s(&mut h, n.iter().flat_map(|p| p.to_array()));
            }
            if let Some(uv) = &m.uvs {
                hash_f32s(&mut h, uv.iter().flat_map(|p| p.to_array()));
            }
        }
        Primitives::Quads(m) => {
            2u8.hash(&mut h);
            hash_f32s(&mut h, m.positions.iter().flat_map(|p| p.to_array()));
            m.indices.hash(&mut h);
        }
    }
    h.finish()
}

impl FrameSummary {
    /// `light_choice`: the integrator picks lights by power from a [`LightSet`] (the Monte
    /// Carlo integrators), so every pixel depends on every light's power.
    pub fn new(scene: &Scene, light_choice: Option<&LightSet>) -> FrameSummary {
        let materials: Vec<String> = (0..scene.materials.len())
            .map(|i| material_text(scene, i, 8))
            .collect();
        let mut shapes: FxHashMap<u64, Vec<(Aabb, bool, Arc<Geometry>)>> = FxHashMap::default();
        let mut keys = Vec::with_capacity(scene.shapes.len());
        for shape in &scene.shapes {
            let m = &scene.materials[shape.material];
            let emits = m.emission.max_element() > 0.0;
            let key = shape_fingerprint(shape, &materials[shape.material]);
            keys.push(key);
            shapes.entry(key).or_default().push((
                shape.geometry.bounds(),
                emits,
                Arc::new(shape.geometry.clone()),
            ));
        }
        let env = scene
            .environment
            .as_ref()
            .map(|e| format!("{:?} {:?} {:?}", e.file, e.transform, e.scale));
        let mut global = format!(
            "{:?}|{:?}|{:?}|{env:?}",
            scene.camera, scene.ambient, scene.background
        );
        if let Some(ls) = light_choice {
            let pmf: Vec<u32> = (0..ls.emitters.len())
                .map(|i| ls.pmf(i).to_bits())
                .collect();
            global += &format!("|{pmf:?}");
            if (0..ls.emitters.len()).any(|i| ls.is_infinite(i)) {
                // Directional and environment light come from a disk around the scene.
                global += &format!("|{:?}|{}", ls.world.center, ls.world.radius);
            }
        }
        FrameSummary {
            shapes,
            keys,
            lights: scene.lights.clone(),
            global,
        }
    }

    /// What changed from `self` (the previous frame) to `next`.
    pub fn diff(&self, next: &FrameSummary) -> Changes {
        let mut c = Changes::default();
        if self.global != next.global {
            c.everything = Some("the camera, world or light choice changed".into());
            return c;
        }
        // Objects present in one frame and not the other (a moved object is both).
        let mut emitter_changed = false;
        for (a, b) in [(self, next), (next, self)] {
            for (key, list) in &a.shapes {
                let kept = b.shapes.get(key).map_or(0, Vec::len);
                if kept >= list.len() {
                    continue;
                }
                // Duplicates of one object: mark all copies (which ones moved is unknown).
                for (bounds, emits, geometry) in
                    list.iter().chain(b.shapes.get(key).into_iter().flatten())
                {
                    c.objects.push(*bounds);
                    c.geometry.push(geometry.clone());
                    emitter_changed |= *emits;
                }
            }
        }
        // An emitter that moves or appears can light surfaces that did not face it before
        // and so sent it no shadow rays.
        if emitter_changed {
            c.light_moved = true;
        }
        if self.lights.len() != next.lights.len() {
            c.light_moved = true;
            for l in self.lights.iter().chain(&next.lights) {
                if let Light::Point(l) = l {
                    c.shadows.push((l.position, l.position));
                }
            }
            return c;
        }
        for (i, (a, b)) in self.lights.iter().zip(&next.lights).enumerate() {
            match (a, b) {
                _ if a == b => {}
                (Light::Point(la), Light::Point(lb)) => {
                    let (pa, pb) = (la.position, lb.position);
                    if pa != pb {
                        c.light_moved = true;
                        c.shadows.push((pa, pa));
                        c.shadows.push((pb, pb));
                    } else if la.intensity != lb.intensity {
                        c.dimmed.push(i);
                    }
                }
                // A directional light lights everything that faces it.
                _ => c.light_moved = true,
            }
        }
        c
    }
}
