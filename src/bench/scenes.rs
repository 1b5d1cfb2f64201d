//! The bench's scene ladder: scene files, and procedural scenes of any size generated in code
//! (a field of tessellated spheres on a floor, and a displaced terrain grid).

use crate::error::{Error, Result};
use crate::math::{Rgb, Rng, Vec3};
use crate::scene::{Camera, Geometry, Light, Material, QuadMesh, Scene, Shape, TriangleMesh};
use std::f32::consts::{PI, TAU};
use std::path::{Path, PathBuf};

/// The default ladder, from tens of triangles to over a million.
pub const DEFAULT_LADDER: &str = "cornell,spheres-10k,spheres-100k,terrain-1m,spheres-1m";
/// The `--quick` ladder: small enough for CI.
pub const QUICK_LADDER: &str = "cornell,spheres-10k";

/// A scene of the ladder, by name.
#[derive(Clone, Debug, PartialEq)]
pub enum SceneSpec {
    File(PathBuf),
    Spheres(usize),
    Terrain(usize),
}

impl SceneSpec {
    /// Parses a name: a `.toml` path, `cornell` (scenes/cornell-box.toml), `spheres-N` or
    /// `terrain-N` with N a triangle count such as 5000, 100k or 1m.
    pub fn parse(name: &str) -> Result<SceneSpec> {
        if name.ends_with(".toml") {
            return Ok(SceneSpec::File(name.into()));
        }
        if name == "cornell" {
            return Ok(SceneSpec::File(cornell_path()));
        }
        let bad = || {
            Error::Invalid(format!(
                "unknown bench scene {name:?}: expected cornell, spheres-N, terrain-N (N like \
                 10k or 1m) or a .toml scene file"
            ))
        };
        let (kind, count) = name.split_once('-').ok_or_else(bad)?;
        let triangles = parse_count(count).ok_or_else(bad)?;
        match kind {
            "spheres" => Ok(SceneSpec::Spheres(triangles)),
            "terrain" => Ok(SceneSpec::Terrain(triangles)),
            _ => Err(bad()),
        }
    }

    /// Loads or generates the scene.
    pub fn load(&self) -> Result<Scene> {
        match self {
            SceneSpec::File(path) => Scene::load(path),
            SceneSpec::Spheres(n) => Ok(sphere_field(*n)),
            SceneSpec::Terrain(n) => Ok(terrain(*n)),
        }
    }
}

/// Loads or generates a scene by name (see [`SceneSpec::parse`]).
pub fn resolve(name: &str) -> Result<Scene> {
    SceneSpec::parse(name)?.load()
}

/// A file of the repository, `relative` to the working directory where it is there, else
/// to the source tree; `None` if it is in neither.
pub(crate) fn repository_file(relative: &str) -> Option<PathBuf> {
    [
        PathBuf::from(relative),
        Path::new(env!("CARGO_MANIFEST_DIR")).join(relative),
    ]
    .into_iter()
    .find(|p| p.exists())
}

/// scenes/cornell-box.toml, relative to the working directory, else to the source tree (where
/// a missing file is reported when the scene is read).
fn cornell_path() -> PathBuf {
    const CORNELL: &str = "scenes/cornell-box.toml";
    repository_file(CORNELL).unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join(CORNELL))
}

/// "5000", "10k", "1m", "2.5m" → a count.
fn parse_count(s: &str) -> Option<usize> {
    let s = s.to_ascii_lowercase();
    let (digits, scale) = match s.as_bytes().last()? {
        b'k' => (&s[..s.len() - 1], 1e3),
        b'm' => (&s[..s.len() - 1], 1e6),
        _ => (&s[..], 1.0),
    };
    let n = digits.parse::<f64>().ok()? * scale;
    (1.0..=1e9).contains(&n).then_some(n.round() as usize)
}

/// Triangles (a quad counts as two) and spheres of a scene.
pub fn primitive_count(scene: &Scene) -> usize {
    scene.primitive_count()
}

fn base_scene(name: String, camera: Camera, light: Vec3) -> Scene {
    Scene {
        media: Vec::new(),
        camera_medium: None,
        source: name.into(),
        camera,
        materials: vec![Material::default()],
        shapes: Vec::new(),
        prototypes: Vec::new(),
        instances: Vec::new(),
        lights: vec![Light::Point(crate::scene::lights::PointLight {
            position: light,
            intensity: Rgb::splat(100.0),
            spectrum: None,
        })],
        ambient: Rgb::splat(0.05),
        background: Rgb::splat(0.2),
        settings: Default::default(),
        setting_sources: Vec::new(),
        output: None,
        color_space: None,
        inputs: Vec::new(),
        environment: None,
        warnings: Vec::new(),
    }
}

fn camera(position: Vec3, look_at: Vec3) -> Camera {
    Camera {
        position,
        look_at,
        up: Vec3::Y,
        fov_deg: 45.0,
        width: 640,
        height: 480,
        projection: crate::scene::Projection::Pinhole,
    }
}

/// Stacks of a bench sphere; its triangle count is 2 · slices · (stacks − 1).
const SPHERE_STACKS: u32 = 24;
const SPHERE_SLICES: u32 = 2 * SPHERE_STACKS;

/// A field of tessellated spheres (about `triangles` triangles in all, one shape each) with
/// random radii on a square floor quad, seen from above at an angle, lit by a point light.
pub fn sphere_field(triangles: usize) -> Scene {
    let per_sphere = (2 * SPHERE_SLICES * (SPHERE_STACKS - 1)) as usize;
    let count = triangles.div_ceil(per_sphere).max(1);
    let side = (count as f32).sqrt().ceil() as usize;
    let half = side as f32 * 0.5;
    let mut scene = base_scene(
        format!("spheres-{triangles}"),
        camera(
            Vec3::new(0.0, half * 1.1 + 1.0, half * 1.9 + 2.0),
            Vec3::new(0.0, 0.0, -half * 0.1),
        ),
        Vec3::new(half * 0.4, half * 2.0 + 3.0, half * 0.6),
    );
    let s = half + 1.0;
    scene.shapes.push(Shape {
        media: None,
        geometry: Geometry::Quads(QuadMesh {
            positions: vec![
                Vec3::new(-s, 0.0, -s),
                Vec3::new(-s, 0.0, s),
                Vec3::new(s, 0.0, s),
                Vec3::new(s, 0.0, -s),
            ],
            indices: vec![[0, 1, 2, 3]],
        }),
        material: 0,
        alpha: None,
        motion: None,
    });
    let mut rng = Rng::for_key(17, &[count as u64]);
    for i in 0..count {
        let (gx, gz) = ((i % side) as f32, (i / side) as f32);
        let radius = 0.3 + 0.25 * rng.uniform();
        let center = Vec3::new(
            gx - half + 0.5 + 0.3 * (rng.uniform() - 0.5),
            radius * (0.6 + 0.8 * rng.uniform()),
            gz - half + 0.5 + 0.3 * (rng.uniform() - 0.5),
        );
        scene.shapes.push(Shape {
            media: None,
            geometry: Geometry::Triangles(uv_sphere(center, radius)),
            material: 0,
            alpha: None,
            motion: None,
        });
    }
    scene
}

/// A latitude-longitude sphere with shared vertices and per-vertex normals.
fn uv_sphere(center: Vec3, radius: f32) -> TriangleMesh {
    let (stacks, slices) = (SPHERE_STACKS, SPHERE_SLICES);
    let mut normals = vec![Vec3::Y];
    for i in 1..stacks {
        let theta = PI * i as f32 / stacks as f32;
        for j in 0..slices {
            let phi = TAU * j as f32 / slices as f32;
            normals.push(Vec3::new(
                theta.sin() * phi.cos(),
                theta.cos(),
                -theta.sin() * phi.sin(),
            ));
        }
    }
    normals.push(Vec3::NEG_Y);
    let south = normals.len() as u32 - 1;
    let ring = |i: u32, j: u32| 1 + (i - 1) * slices + j % slices;
    let mut indices = Vec::new();
    for j in 0..slices {
        indices.push([0, ring(1, j), ring(1, j + 1)]);
        indices.push([south, ring(stacks - 1, j + 1), ring(stacks - 1, j)]);
    }
    for i in 1..stacks - 1 {
        for j in 0..slices {
            let (a, b, c, d) = (
                ring(i, j),
                ring(i + 1, j),
                ring(i + 1, j + 1),
                ring(i, j + 1),
            );
            indices.push([a, b, c]);
            indices.push([a, c, d]);
        }
    }
    TriangleMesh {
        positions: normals.iter().map(|n| center + *n * radius).collect(),
        normals: Some(normals),
        uvs: None,
        indices,
    }
}

/// A square grid of about `triangles` triangles displaced by a sum of waves: a terrain seen
/// from above at an angle, lit by a point light.
pub fn terrain(triangles: usize) -> Scene {
    let n = ((triangles as f32 / 2.0).sqrt().ceil() as u32).max(1);
    let size = 20.0;
    let mut scene = base_scene(
        format!("terrain-{triangles}"),
        camera(Vec3::new(0.0, 9.0, 17.0), Vec3::new(0.0, 0.0, -1.0)),
        Vec3::new(-6.0, 15.0, 4.0),
    );
    let height = |x: f32, z: f32| {
        0.8 * (0.35 * x).sin() * (0.3 * z).cos()
            + 0.25 * (1.3 * x + 0.7 * z).sin()
            + 0.06 * (5.1 * x).sin() * (4.3 * z).sin()
    };
    let mut positions = Vec::with_capacity(((n + 1) * (n + 1)) as usize);
    for i in 0..=n {
        for j in 0..=n {
            let x = size * (j as f32 / n as f32 - 0.5);
            let z = size * (i as f32 / n as f32 - 0.5);
            positions.push(Vec3::new(x, height(x, z), z));
        }
    }
    let at = |i: u32, j: u32| i * (n + 1) + j;
    let mut indices = Vec::with_capacity(2 * (n * n) as usize);
    for i in 0..n {
        for j in 0..n {
            // Counter-clockwise seen from above: normals point up.
            indices.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
            indices.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
        }
    }
    scene.shapes.push(mesh_shape(positions, indices));
    scene
}

/// A triangle mesh without normals or uvs, in material 0.
pub fn mesh_shape(positions: Vec<Vec3>, indices: Vec<[u32; 3]>) -> Shape {
    Shape {
        media: None,
        geometry: Geometry::Triangles(TriangleMesh {
            positions,
            normals: None,
            uvs: None,
            indices,
        }),
        material: 0,
        alpha: None,
        motion: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_parse_with_suffixes() {
        assert_eq!(parse_count("5000"), Some(5000));
        assert_eq!(parse_count("10k"), Some(10_000));
        assert_eq!(parse_count("2.5M"), Some(2_500_000));
        assert_eq!(parse_count("0"), None);
        assert_eq!(parse_count("k"), None);
        assert_eq!(parse_count("-3"), None);
    }

    #[test]
    fn procedural_scenes_have_about_the_asked_size() {
        for n in [10_000, 100_000] {
            for scene in [sphere_field(n), terrain(n)] {
                let got = primitive_count(&scene);
                assert!(got >= n && got < n + n / 5 + 2500, "{n}: {got}");
            }
        }
    }

    #[test]
    fn sphere_mesh_is_closed_and_outward() {
        let m = uv_sphere(Vec3::new(1.0, 2.0, 3.0), 0.5);
        let expected = 2 * SPHERE_SLICES * (SPHERE_STACKS - 1);
        assert_eq!(m.indices.len(), expected as usize);
        // Every edge is used once in each direction.
        let mut edges = std::collections::HashMap::new();
        for t in &m.indices {
            for k in 0..3 {
                *edges.entry((t[k], t[(k + 1) % 3])).or_insert(0) += 1;
            }
        }
        for (&(a, b), &c) in &edges {
            assert_eq!(c, 1);
            assert_eq!(edges.get(&(b, a)), Some(&1));
        }
        for i in 0..m.indices.len() {
            let [a, b, c] = m.triangle(i);
            let n = (b - a).cross(c - a);
            let centroid = (a + b + c) / 3.0 - Vec3::new(1.0, 2.0, 3.0);
            assert!(n.dot(centroid) > 0.0, "triangle {i} faces inwards");
        }
    }

    #[test]
    fn unknown_names_are_option_errors() {
        for name in ["nope", "spheres-", "cubes-10k", "terrain-x"] {
            assert!(matches!(resolve(name), Err(Error::Invalid(_))), "{name}");
        }
    }
}
