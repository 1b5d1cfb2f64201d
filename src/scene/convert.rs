//! `raylink convert`: writes a [`Scene`] (from any reader) as a native TOML scene. Meshes are
//! referenced, not inlined: each triangle or quad mesh is written, in world space, to a
//! binary PLY file in a `NAME.meshes/` folder beside the output. Image textures and
//! environment maps are referenced by path (relative to the output when possible).
//!
//! Everything is written through temporary files renamed into place, the TOML last, so a
//! failed conversion never leaves a half-written scene behind.

use super::{Geometry, Scene, Texture};
use crate::image::filter::Filter;
use crate::math::Vec3;
use crate::Error;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Reads `input` (.pbrt or .toml) and writes it to `output` as a native TOML scene.
/// Returns the scene read (with its warnings).
pub fn convert(input: &Path, output: &Path) -> crate::Result<Scene> {
    let scene = Scene::load(input)?;
    write_toml(&scene, output)?;
    Ok(scene)
}

/// A float as TOML: shortest representation that reads back exactly.
fn num(x: f32) -> String {
    let s = format!("{x:?}");
    if s.contains(['.', 'e', 'E']) || s.contains("inf") || s.contains("NaN") {
        s
    } else {
        format!("{s}.0")
    }
}

fn v3(v: Vec3) -> String {
    format!("[{}, {}, {}]", num(v.x), num(v.y), num(v.z))
}

fn quote(s: &str) -> String {
    let mut out = String::from("\"");
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            '\n' => out.push_str("\\n"),
            c if c.is_control() => {
                let _ = write!(out, "\\u{:04X}", c as u32);
            }
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

/// A path written into the TOML: the referenced file as seen from `out_dir`.
fn reference(scene: &Scene, file: &Path, out_dir: &Path) -> String {
    let source_dir = scene.source.parent().unwrap_or(Path::new(""));
    let target = if file.is_absolute() {
        file.to_path_buf()
    } else {
        source_dir.join(file)
    };
    let abs = |p: &Path| std::path::absolute(p).unwrap_or_else(|_| p.to_path_buf());
    let (target, out_dir) = (abs(&target), abs(out_dir));
    relative(&target, &out_dir)
        .unwrap_or(target)
        .to_string_lossy()
        .into_owned()
}

/// `target` relative to `base` (both absolute), through `..` where needed.
fn relative(target: &Path, base: &Path) -> Option<PathBuf> {
    let t: Vec<_> = target.components().collect();
    let b: Vec<_> = base.components().collect();
    let common = t.iter().zip(&b).take_while(|(x, y)| x == y).count();
    if common == 0 {
        return None;
    }
    let mut out = PathBuf::new();
    for _ in common..b.len() {
        out.push("..");
    }
    for c in &t[common..] {
        out.push(c);
    }
    Some(out)
}

/// Writes `scene` as TOML to `output`, its meshes as PLY files beside it.
pub fn write_toml(scene: &Scene, output: &Path) -> crate::Result<()> {
    let out_dir = output
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."))
        .to_path_buf();
    if !out_dir.is_dir() {
        return Err(Error::Invalid(format!(
            "{}: the output's directory does not exist",
            output.display()
        )));
    }
    let stem = output
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "scene".into());
    let mesh_dir_name = format!("{stem}.meshes");
    let mut t = String::new();
    let _ = writeln!(
        t,
        "# Written by raylink {} from {}.\n",
        crate::VERSION,
        scene.source.display()
    );
    let c = &scene.camera;
    let _ = writeln!(
        t,
        "[camera]\nposition = {}\nlook_at = {}\nup = {}\nfov = {}\nwidth = {}\nheight = {}\n",
        v3(c.position),
        v3(c.look_at),
        v3(c.up),
        num(c.fov_deg),
        c.width,
        c.height
    );
    let _ = writeln!(
        t,
        "[world]\nambient = {}\nbackground = {}",
        v3(scene.ambient),
        v3(scene.background)
    );
    if let Some(env) = &scene.environment {
        let m = env.transform;
        let rows = (0..3)
            .map(|r| {
                let row = m.row(r);
                format!("[{}, {}, {}, 0.0]", num(row.x), num(row.y), num(row.z))
            })
            .collect::<Vec<_>>()
            .join(", ");
        let _ = writeln!(
            t,
            "environment = {{ file = {}, scale = {}, transform = {{ matrix = [{rows}, [0.0, 0.0, 0.0, 1.0]] }} }}",
            quote(&reference(scene, &env.file, &out_dir)),
            v3(env.scale)
        );
    }
    t.push('\n');
    let s = &scene.settings;
    if s != &Default::default() {
        t.push_str("[render]\n");
        if let Some(i) = &s.integrator {
            let _ = writeln!(t, "integrator = {}", quote(i));
        }
        if let Some(n) = s.spp {
            let _ = writeln!(t, "spp = {n}");
        }
        if let Some(n) = s.max_depth {
            let _ = writeln!(t, "max_depth = {n}");
        }
        if let Some(f) = s.filter {
            let f = match f {
                Filter::Box { radius } => format!("{{ type = \"box\", radius = {} }}", num(radius)),
                Filter::Triangle { radius } => {
                    format!("{{ type = \"triangle\", radius = {} }}", num(radius))
                }
                Filter::Gaussian { radius, sigma } => format!(
                    "{{ type = \"gaussian\", radius = {}, sigma = {} }}",
                    num(radius),
                    num(sigma)
                ),
            };
            let _ = writeln!(t, "filter = {f}");
        }
        t.push('\n');
    }
    // Material names as TOML keys: the scene's own where unique, else m<index>.
    let mut keys: Vec<String> = Vec::new();
    for (i, m) in scene.materials.iter().enumerate() {
        let key = if m.name.is_empty() || keys.contains(&m.name) {
            format!("m{i}")
        } else {
            m.name.clone()
        };
        keys.push(key);
    }
    for (m, key) in scene.materials.iter().zip(&keys) {
        let _ = writeln!(t, "[materials.{}]", quote(key));
        let diffuse = match &m.diffuse {
            Texture::Constant(c) => v3(*c),
            Texture::Checker { even, odd, size } => format!(
                "{{ checker = {{ even = {}, odd = {}, size = {} }} }}",
                v3(*even),
                v3(*odd),
                num(*size)
            ),
            Texture::UvChecker { even, odd, mapping } => format!(
                "{{ uv_checker = {{ even = {}, odd = {}, uscale = {}, vscale = {}, udelta = {}, vdelta = {} }} }}",
                v3(*even),
                v3(*odd),
                num(mapping.scale.x),
                num(mapping.scale.y),
                num(mapping.offset.x),
                num(mapping.offset.y)
            ),
            Texture::Image(img) => format!(
                "{{ image = {{ file = {}, encoding = {}, scale = {}, invert = {}, uscale = {}, vscale = {}, udelta = {}, vdelta = {} }} }}",
                quote(&reference(scene, &img.file, &out_dir)),
                quote(&img.encoding.name()),
                num(img.scale),
                img.invert,
                num(img.mapping.scale.x),
                num(img.mapping.scale.y),
                num(img.mapping.offset.x),
                num(img.mapping.offset.y)
            ),
        };
        let _ = writeln!(t, "diffuse = {diffuse}");
        if let Some(a) = m.ambient {
            let _ = writeln!(t, "ambient = {}", v3(a));
        }
        let _ = writeln!(
            t,
            "specular = {}\ntransmission = {}\nior = {}\nphong_exponent = {}\nroughness = {}\n\
             fresnel = {}\nemission = {}\n",
            v3(m.specular),
            v3(m.transmission),
            num(m.ior),
            num(m.phong_exponent),
            num(m.roughness),
            m.fresnel,
            v3(m.emission)
        );
    }
    // Meshes go to a temporary folder that replaces NAME.meshes only once all is written.
    let final_mesh_dir = out_dir.join(&mesh_dir_name);
    let mesh_dir = out_dir.join(format!(".{mesh_dir_name}.tmp-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&mesh_dir);
    let cleanup = TempDir(mesh_dir.clone());
    let mut wrote_meshes = false;
    for (i, shape) in scene.shapes.iter().enumerate() {
        let _ = writeln!(t, "[[shapes]]");
        match &shape.geometry {
            Geometry::Sphere { center, radius } => {
                let _ = writeln!(
                    t,
                    "type = \"sphere\"\ncenter = {}\nradius = {}",
                    v3(*center),
                    num(*radius)
                );
            }
            g => {
                if !wrote_meshes {
                    std::fs::create_dir_all(&mesh_dir).map_err(|e| Error::io(&mesh_dir, e))?;
                    wrote_meshes = true;
                }
                let name = format!("mesh_{i:04}.ply");
                let path = mesh_dir.join(&name);
                match g {
                    Geometry::Triangles(m) => super::ply::write(
                        &path,
                        &m.positions,
                        m.normals.as_deref(),
                        m.uvs.as_deref(),
                        &m.indices,
                        &[],
                    )?,
                    Geometry::Quads(q) => {
                        super::ply::write(&path, &q.positions, None, None, &[], &q.indices)?
                    }
                    Geometry::Sphere { .. } => unreachable!("handled above"),
                }
                let _ = writeln!(
                    t,
                    "type = \"ply\"\nfile = {}",
                    quote(&format!("{mesh_dir_name}/{name}"))
                );
            }
        }
        let _ = writeln!(t, "material = {}\n", quote(&keys[shape.material]));
    }
    for light in &scene.lights {
        match light {
            super::Light::Point {
                position,
                intensity,
            } => {
                let _ = writeln!(
                    t,
                    "[[lights]]\ntype = \"point\"\nposition = {}\nintensity = {}\n",
                    v3(*position),
                    v3(*intensity)
                );
            }
            super::Light::Directional {
                direction,
                irradiance,
            } => {
                let _ = writeln!(
                    t,
                    "[[lights]]\ntype = \"directional\"\ndirection = {}\nirradiance = {}\n",
                    v3(*direction),
                    v3(*irradiance)
                );
            }
        }
    }
    if wrote_meshes {
        // Swap the new meshes in: old folder aside, new one in place, old one removed.
        let old = out_dir.join(format!(".{mesh_dir_name}.old-{}", std::process::id()));
        let had_old = final_mesh_dir.exists();
        if had_old {
            std::fs::rename(&final_mesh_dir, &old).map_err(|e| Error::io(&final_mesh_dir, e))?;
        }
        if let Err(e) = std::fs::rename(&mesh_dir, &final_mesh_dir) {
            if had_old {
                let _ = std::fs::rename(&old, &final_mesh_dir);
            }
            return Err(Error::io(&final_mesh_dir, e));
        }
        if had_old {
            let _ = std::fs::remove_dir_all(&old);
        }
    }
    drop(cleanup);
    crate::atomic_file::write(output, t.as_bytes())
}

/// A temporary folder removed on drop (after a failure, or when it was renamed away).
struct TempDir(PathBuf);

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}
