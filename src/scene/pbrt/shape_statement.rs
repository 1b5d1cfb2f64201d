//! The Shape statement: a shape's geometry placed in world space with pbrt's orientation
//! rules (made in `shapes.rs`), given the current material or its emissive copy, and kept in
//! the world or in the object being defined.

use super::builder::Builder;
use super::cost::Cost;
use super::params::Params;
use super::shapes;
use super::state::AreaEmission;
use super::Loc;
use crate::math::{Rgb, Vec2, Vec3};
use crate::scene::loop_subdivision;
use crate::scene::materials::{Diffuse, Surface};
use crate::scene::ply::{self, PlyMesh};
use crate::scene::{Geometry, Material, Shape, Sphere, Texture};
use glam::DVec3;

impl Builder {
    /// The material index for the next shape: the current material, or its emissive copy
    /// under an area light.
    fn shape_material(&mut self, loc: &Loc) -> usize {
        let base = match self.state.material {
            Some(i) => i,
            None => *self.default_material.get_or_insert_with(|| {
                self.materials.push(Material::new(
                    "pbrt-default",
                    Surface::Diffuse(Diffuse::new(Texture::Constant(Rgb::splat(0.5)))),
                ));
                self.materials.len() - 1
            }),
        };
        let Some(area) = self.state.area else {
            return base;
        };
        if self.object.is_some() {
            self.warn(loc, "area lights in object instances are not supported (nor by pbrt-v4); the shapes do not emit");
            return base;
        }
        self.emissive_copy(base, area)
    }

    /// The copy of material `base` that emits `radiance`; for a mix, a mix of its
    /// materials' emissive copies (whichever is chosen at a hit emits).
    fn emissive_copy(&mut self, base: usize, area: AreaEmission) -> usize {
        let (radiance, two_sided) = (area.radiance, area.two_sided);
        let key = (base, radiance.to_array().map(f32::to_bits), two_sided);
        if let Some(&i) = self.emissive.get(&key) {
            return i;
        }
        let mut m = self.materials[base].clone();
        if let Surface::Mix(mix) = &mut m.surface {
            for j in &mut mix.materials {
                *j = self.emissive_copy(*j, area);
            }
        }
        m.emission = radiance;
        m.emission_map = self
            .area_textures
            .get(&(radiance.to_array().map(f32::to_bits), two_sided))
            .cloned()
            .flatten();
        m.two_sided_emission = two_sided;
        m.emission_spectrum = area.spectrum;
        m.name = if m.name.is_empty() {
            "emitter".into()
        } else {
            format!("{}-emitter", m.name)
        };
        self.materials.push(m);
        self.emissive.insert(key, self.materials.len() - 1);
        self.materials.len() - 1
    }

    pub(super) fn make_shape(
        &mut self,
        ty: &str,
        p: &Params,
        loc: &Loc,
    ) -> crate::error::Result<()> {
        let st = format!("Shape \"{ty}\"");
        let st = st.as_str();
        let pe = Self::pe(loc);
        let alpha = self.shape_alpha(p, st, loc)?;
        p.ignore("emission");
        // pbrt's transform for the shape; the world mirror (if any) comes on top.
        let ctm = self.state.ctm;
        let in_object = self.object.is_some();
        let m = if in_object { ctm } else { self.mirror * ctm };
        let det = glam::DMat3::from_mat4(m).determinant();
        if !m.is_finite() || !det.is_finite() {
            return Err(loc.error(format!(
                "{st}: the transform overflows (it is not finite, determinant {det})"
            )));
        }
        if det.abs() < 1e-30 {
            return Err(loc.error(format!(
                "{st}: the transform is singular (determinant {det})"
            )));
        }
        let reverse = self.state.reverse_orientation;
        // Meshes: normals carried as normals (negated by ReverseOrientation); without
        // normals, the winding flips with ReverseOrientation XOR a mirroring transform.
        let mesh_sign = if reverse { -1.0 } else { 1.0 };
        let mesh_flip = reverse ^ shapes::swaps_handedness(&m);
        // Quadrics: outward normals, negated when ReverseOrientation XOR pbrt's own
        // transform mirrors.
        let quadric_sign = if reverse ^ shapes::swaps_handedness(&ctm) {
            -1.0
        } else {
            1.0
        };
        let float = |name: &str, default: f64| p.float_or(name, default).map_err(&pe);
        let geometries: Vec<Geometry> = match ty {
            "trianglemesh" => {
                let mesh = self.mesh_params(p, 3, st, loc)?;
                shapes::place(mesh, &m, mesh_sign, mesh_flip)
            }
            "loopsubdiv" => {
                // pbrt-v4's LoopSubdivide: `levels` (3) over the control mesh, on the limit
                // surface, its normals the limit's; a uv or N given is not used (as pbrt-v4).
                let levels = p.int("levels").map_err(&pe)?.unwrap_or(3);
                let mut mesh = self.mesh_params(p, 3, st, loc)?;
                let levels = u32::try_from(levels)
                    .ok()
                    .filter(|&l| l <= loop_subdivision::MAX_LEVELS)
                    .ok_or_else(|| {
                        loc.error(format!(
                            "{st}: \"levels\" must be between 0 and {}, got {levels}",
                            loop_subdivision::MAX_LEVELS
                        ))
                    })?;
                let triangles = (mesh.triangles.len() as u128) << (2 * levels);
                if triangles > loop_subdivision::MAX_TRIANGLES as u128 {
                    return Err(loc.error(format!(
                        "{st}: {levels} levels make {triangles} triangles, more than {}",
                        loop_subdivision::MAX_TRIANGLES
                    )));
                }
                // Its working set (positions and normals in f64 and f32, edge tables) against
                // the memory budget before it is made; the mesh made is counted as every
                // shape's is, below.
                let working = Cost {
                    data: 160u64.saturating_mul(triangles as u64),
                    primitives: triangles as u64,
                };
                self.budget.check(
                    &format!("line {}: {st}: {levels} levels of subdivision", loc.line),
                    working.bytes(),
                )?;
                let s = loop_subdivision::subdivide(&mesh.positions, &mesh.triangles, levels)
                    .map_err(|e| loc.error(format!("{st}: {e}")))?;
                mesh.positions = s.positions;
                mesh.triangles = s.triangles;
                mesh.normals = Some(s.normals);
                mesh.uvs = None;
                shapes::place(mesh, &m, mesh_sign, mesh_flip)
            }
            "bilinearmesh" => {
                let mut mesh = self.mesh_params(p, 4, st, loc)?;
                // Patches list (p00, p10, p01, p11); as polygons (p00, p10, p11, p01).
                for q in &mut mesh.quads {
                    q.swap(2, 3);
                }
                shapes::place(mesh, &m, mesh_sign, mesh_flip)
            }
            "plymesh" => {
                let file = p
                    .string("filename")
                    .map_err(&pe)?
                    .ok_or_else(|| loc.error(format!("{st} needs a \"string filename\"")))?;
                if p.find("displacement", &["texture", "float"])
                    .ok()
                    .flatten()
                    .is_some()
                {
                    self.warn(loc, format!("{st}: displacement is not supported; ignored"));
                }
                p.ignore("edgelength");
                let path = loc.dir().join(&file);
                if !self.find_input(&path, st, &file, loc) {
                    // Reading goes on to find the other missing files.
                    return Ok(());
                }
                let mesh = ply::read(&path).map_err(|e| loc.error(format!("{st}: {e}")))?;
                if mesh.skipped_faces > 0 {
                    self.warn(
                        loc,
                        format!("{st}: faces with more than 4 vertices are left out"),
                    );
                }
                shapes::place(mesh, &m, mesh_sign, mesh_flip)
            }
            "sphere" => {
                let r = float("radius", 1.0)?;
                if r.is_nan() || r <= 0.0 {
                    return Err(loc.error(format!("{st}: radius must be positive, got {r}")));
                }
                let (zmin, zmax, phimax) = (
                    float("zmin", -r)?,
                    float("zmax", r)?,
                    float("phimax", 360.0)?,
                );
                let full = zmin <= -r && zmax >= r && phimax >= 360.0;
                match shapes::uniform_scale(&m) {
                    Some(s) if full && quadric_sign > 0.0 => vec![Geometry::Sphere(Sphere {
                        center: m.transform_point3(DVec3::ZERO).as_vec3(),
                        radius: (r * s) as f32,
                    })],
                    _ => shapes::place(
                        shapes::sphere(r, zmin, zmax, phimax),
                        &m,
                        quadric_sign,
                        false,
                    ),
                }
            }
            "disk" => {
                let (h, r, ri, phimax) = (
                    float("height", 0.0)?,
                    float("radius", 1.0)?,
                    float("innerradius", 0.0)?,
                    float("phimax", 360.0)?,
                );
                if !(r > 0.0 && ri >= 0.0 && ri < r) {
                    return Err(loc.error(format!(
                        "{st}: need 0 <= innerradius < radius, got {ri} and {r}"
                    )));
                }
                shapes::place(shapes::disk(h, r, ri, phimax), &m, quadric_sign, false)
            }
            "cylinder" => {
                let (r, zmin, zmax, phimax) = (
                    float("radius", 1.0)?,
                    float("zmin", -1.0)?,
                    float("zmax", 1.0)?,
                    float("phimax", 360.0)?,
                );
                if !(r > 0.0 && zmin != zmax) {
                    return Err(loc.error(format!("{st}: need a positive radius and zmin != zmax")));
                }
                shapes::place(
                    shapes::cylinder(r, zmin, zmax, phimax),
                    &m,
                    quadric_sign,
                    false,
                )
            }
            _ => {
                for q in &p.list {
                    p.ignore(&q.name);
                }
                self.warn(loc, format!("{st} is not supported; the shape is left out"));
                return Ok(());
            }
        };
        for g in &geometries {
            let finite = match g {
                Geometry::Sphere(Sphere { center, radius }) => {
                    center.is_finite() && radius.is_finite()
                }
                Geometry::Triangles(t) => t.positions.iter().all(|p| p.is_finite()),
                Geometry::Quads(q) => q.positions.iter().all(|p| p.is_finite()),
            };
            if !finite {
                return Err(loc.error(format!(
                    "{st}: the transform overflows: it moves the shape out of the range of finite numbers"
                )));
            }
        }
        let cost = geometries
            .iter()
            .fold(Cost::default(), |c, g| c.add(Cost::of(g)));
        self.reserve(loc, st, cost, !in_object)?;
        let material = self.shape_material(loc);
        let end = if in_object {
            self.state.end_ctm
        } else {
            self.mirror * self.state.end_ctm
        };
        let mut geometries = self.moving(loc, st, geometries, (m, end));
        if self.materials[material].is_emissive() && geometries.iter().any(|g| g.1.is_some()) {
            // Light samples are taken on still emitters: an emitter that moved would light
            // its surroundings from where it was at shutter open.
            self.warn(
                loc,
                format!(
                    "{st}: a moving area light is not supported (nor by pbrt-v4); it stays \
                     where it is at shutter open"
                ),
            );
            geometries.iter_mut().for_each(|g| g.1 = None);
        }
        let media = self.shape_media(loc)?;
        let new = geometries.into_iter().map(|(geometry, motion)| Shape {
            media,
            geometry,
            material,
            alpha: alpha.clone(),
            motion,
        });
        match &mut self.object {
            Some((_, shapes)) => shapes.extend(new),
            None => self.shapes.extend(new),
        }
        Ok(())
    }

    /// `P`, `indices`, `N`, `uv` of a triangle (`arity` 3) or bilinear (4) mesh.
    fn mesh_params(
        &mut self,
        p: &Params,
        arity: usize,
        st: &str,
        loc: &Loc,
    ) -> crate::error::Result<PlyMesh> {
        let pe = Self::pe(loc);
        let positions: Vec<Vec3> = p
            .floats("P", "point3")
            .map_err(&pe)?
            .ok_or_else(|| loc.error(format!("{st} needs \"point3 P\"")))?
            .chunks_exact(3)
            .map(|c| Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32))
            .collect();
        let n = positions.len();
        let indices = match p.ints("indices").map_err(&pe)? {
            Some(ix) => ix,
            None if n == arity => (0..arity as i64).collect(),
            None => {
                return Err(loc.error(format!(
                    "{st} needs \"integer indices\" (it has {n} points)"
                )))
            }
        };
        if indices.len() % arity != 0 {
            return Err(loc.error(format!(
                "{st}: \"indices\" must be a multiple of {arity} long, got {}",
                indices.len()
            )));
        }
        if let Some(&k) = indices.iter().find(|&&k| k < 0 || k as usize >= n) {
            return Err(loc.error(format!(
                "{st}: vertex index {k} out of range (the mesh has {n} points)"
            )));
        }
        let normals = match p.floats("N", "normal3").map_err(&pe)? {
            Some(v) if v.len() / 3 != n => {
                return Err(loc.error(format!(
                    "{st}: \"N\" needs one normal per point ({n}), got {}",
                    v.len() / 3
                )))
            }
            Some(v) => Some(
                v.chunks_exact(3)
                    .map(|c| Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32))
                    .collect(),
            ),
            None => None,
        };
        let uvs = match p.floats("uv", "point2").map_err(&pe)? {
            Some(v) if v.len() / 2 != n => {
                return Err(loc.error(format!(
                    "{st}: \"uv\" needs one uv per point ({n}), got {}",
                    v.len() / 2
                )))
            }
            Some(v) => Some(
                v.chunks_exact(2)
                    .map(|c| Vec2::new(c[0] as f32, c[1] as f32))
                    .collect(),
            ),
            None => None,
        };
        for q in ["S", "faceIndices"] {
            p.ignore(q);
        }
        if positions.iter().any(|p| !p.is_finite()) {
            return Err(loc.error(format!("{st}: \"P\" must be finite")));
        }
        let ix: Vec<u32> = indices.iter().map(|&k| k as u32).collect();
        let mut mesh = PlyMesh {
            positions,
            normals,
            uvs,
            ..PlyMesh::default()
        };
        if arity == 3 {
            mesh.triangles = ix.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
        } else {
            mesh.quads = ix
                .chunks_exact(4)
                .map(|c| [c[0], c[1], c[2], c[3]])
                .collect();
        }
        Ok(mesh)
    }
}
