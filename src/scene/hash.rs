//! A fingerprint of a scene's content, for checking that parts of an image, a checkpoint or
//! a cached preparation come from the same scene.

use super::Scene;

/// A hash of everything in the scene that changes pixels (camera, shapes, materials,
/// lights, background, ambient, environment map, media), for checking that tiles come from the
/// same scene. The scene's debug text is hashed as it is formatted, so a scene of millions
/// of triangles needs no string of hundreds of megabytes.
pub fn scene_hash(scene: &Scene) -> u64 {
    use std::fmt::Write;
    let mut h = Fnv1a(0xcbf29ce484222325);
    write!(
        h,
        "{:?}|{:?}|{:?}|{:?}|{:?}|{:?}|{:?}",
        scene.camera,
        scene.materials,
        scene.shapes,
        scene.lights,
        scene.background,
        scene.ambient,
        scene.environment
    )
    .expect("hashing never fails");
    if scene.has_instances() {
        write!(h, "|{:?}|{:?}", scene.prototypes, scene.instances).expect("hashing never fails");
    }
    if !scene.media.is_empty() {
        write!(h, "|{:?}|{:?}", scene.media, scene.camera_medium).expect("hashing never fails");
    }
    h.0
}

/// FNV-1a over the bytes written to it (crate::binary_file::fnv1a, streaming).
struct Fnv1a(u64);

impl std::fmt::Write for Fnv1a {
    fn write_str(&mut self, s: &str) -> std::fmt::Result {
        for &b in s.as_bytes() {
            self.0 ^= b as u64;
            self.0 = self.0.wrapping_mul(0x100000001b3);
        }
        Ok(())
    }
}
