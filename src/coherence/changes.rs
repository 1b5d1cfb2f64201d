//! What changed between two frames (section 3.3): objects that moved, appeared, disappeared or
//! changed material give boxes whose voxels are marked changed; lights give boxes for the
//! shadow tables or, when they move, reach every block that found a surface; anything that
//! every pixel depends on forces a full frame.

use crate::lights::LightSet;
use crate::math::Vec3;
use crate::scene::{Geometry, Light, QuadMesh, Scene, Shape, TriangleMesh};
use rustc_hash::FxHashMap;
use std::hash::{Hash, Hasher};

/// An axis-aligned box.
pub type Aabb = (Vec3, Vec3);

/// What a frame's pixels can depend on, in a form two frames can be compared by.
#[derive(Clone, Debug)]
pub struct FrameSummary {
    /// Shapes by fingerprint (geometry and material): their boxes and whether they emit.
    shapes: FxHashMap<u64, Vec<(Aabb, bool)>>,
    lights: Vec<Light>,
    /// Everything that reaches every pixel (camera, world settings, the light choice of the
    /// Monte Carlo integrators), as text.
    global: String,
}

/// The difference between two frames.
#[derive(Clone, Debug, Default)]
pub struct Changes {
    /// Boxes around changed objects (old and new places): both tables of their voxels.
    pub objects: Vec<Aabb>,
    /// Boxes around lights whose intensity changed: shadow tables only.
    pub shadows: Vec<Aabb>,
    /// A light moved, appeared, vanished or turned: every block that found a surface may
    /// now face it differently.
    pub light_moved: bool,
    /// Why every pixel must be retraced, if so.
    pub everything: Option<String>,
}

impl Changes {
    pub fn is_empty(&self) -> bool {
        self.objects.is_empty()
            && self.shadows.is_empty()
            && !self.light_moved
            && self.everything.is_none()
    }
}

fn hash_f32s(h: &mut impl Hasher, v: impl IntoIterator<Item = f32>) {
    for x in v {
        x.to_bits().hash(h);
    }
}

fn shape_bounds(shape: &Shape) -> Aabb {
    match &shape.geometry {
        Geometry::Sphere { center, radius } => (*center - *radius, *center + *radius),
        Geometry::Triangles(TriangleMesh { positions, .. })
        | Geometry::Quads(QuadMesh { positions, .. }) => positions.iter().fold(
            (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |(lo, hi), p| (lo.min(*p), hi.max(*p)),
        ),
    }
}

fn shape_fingerprint(shape: &Shape, material: &str) -> u64 {
    let mut h = std::collections::hash_map::DefaultHasher::new();
    material.hash(&mut h);
    match &shape.geometry {
        Geometry::Sphere { center, radius } => {
            0u8.hash(&mut h);
            hash_f32s(&mut h, center.to_array().into_iter().chain([*radius]));
        }
        Geometry::Triangles(m) => {
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
        Geometry::Quads(m) => {
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
        let materials: Vec<String> = scene.materials.iter().map(|m| format!("{m:?}")).collect();
        let mut shapes: FxHashMap<u64, Vec<(Aabb, bool)>> = FxHashMap::default();
        for shape in &scene.shapes {
            let m = &scene.materials[shape.material];
            let emits = m.emission.max_element() > 0.0;
            shapes
                .entry(shape_fingerprint(shape, &materials[shape.material]))
                .or_default()
                .push((shape_bounds(shape), emits));
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
                global += &format!("|{:?}|{}", ls.center, ls.radius);
            }
        }
        FrameSummary {
            shapes,
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
                for (bounds, emits) in list.iter().chain(b.shapes.get(key).into_iter().flatten()) {
                    c.objects.push(*bounds);
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
                if let Light::Point { position, .. } = l {
                    c.shadows.push((*position, *position));
                }
            }
            return c;
        }
        for (a, b) in self.lights.iter().zip(&next.lights) {
            match (a, b) {
                _ if a == b => {}
                (
                    Light::Point {
                        position: pa,
                        intensity: ia,
                    },
                    Light::Point {
                        position: pb,
                        intensity: ib,
                    },
                ) => {
                    if pa != pb {
                        c.light_moved = true;
                    }
                    if ia != ib || pa != pb {
                        c.shadows.push((*pa, *pa));
                        c.shadows.push((*pb, *pb));
                    }
                }
                // A directional light lights everything that faces it.
                _ => c.light_moved = true,
            }
        }
        c
    }
}
