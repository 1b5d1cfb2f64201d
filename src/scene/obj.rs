//! Wavefront OBJ + MTL meshes, through tobj.
//!
//! [`load`] returns the meshes in the file's own (object) space, triangulated, one group per
//! object and material, with the MTL materials translated to [`Material`]s. Every problem is an
//! [`Error::input`] naming the OBJ or MTL file and, where it can be known, the line.
//!
//! tobj reports errors without positions, and panics on some malformed MTL colours, so the
//! text is checked line by line here first; tobj then only sees input it handles.

use super::{Classic, Material, Texture, TriangleMesh};
use crate::error::Error;
use crate::input_file::{self, Allowance};
use crate::math::{Rgb, Vec2, Vec3};
use std::cell::RefCell;
use std::io::{BufRead, Read};
use std::path::Path;

/// The contents of an OBJ file.
#[derive(Clone, Debug, Default)]
pub struct ObjData {
    pub groups: Vec<ObjGroup>,
    /// The materials of the MTL files the OBJ names, in order; empty when not read.
    pub materials: Vec<Material>,
}

/// Triangles of one object that share one material.
#[derive(Clone, Debug)]
pub struct ObjGroup {
    /// The object (`o`) or group (`g`) name.
    pub name: String,
    /// Object-space triangles; normals and uvs when every vertex has them.
    pub mesh: TriangleMesh,
    /// Index into [`ObjData::materials`]; `None` for faces before any (known) `usemtl`.
    pub material: Option<usize>,
}

/// Reads an OBJ file. With `with_materials` the MTL files it names are read too (a missing or
/// broken one is an error, as is a `usemtl` naming no material); without, they are ignored.
pub fn load(path: &Path, with_materials: bool) -> crate::error::Result<ObjData> {
    load_within(path, with_materials, None)
}

/// [`load`], the OBJ file's text counted against the job's memory budget.
pub fn load_within(
    path: &Path,
    with_materials: bool,
    allowance: Option<&Allowance>,
) -> crate::error::Result<ObjData> {
    let text = read_text(path, "OBJ", &input_file::OBJ, allowance)?;
    prescan_obj(&text).map_err(|e| Error::input(path, e))?;

    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let materials: RefCell<Vec<Material>> = RefCell::new(Vec::new());
    // Every MTL file that fails, so that several missing ones are reported at once.
    let mtl_errors: RefCell<Vec<Error>> = RefCell::new(Vec::new());
    let loader = |name: &Path| -> tobj::MTLLoadResult {
        if !with_materials {
            return Ok((Vec::new(), Default::default()));
        }
        match load_mtl(&dir.join(name)) {
            Ok((raw, ours)) => {
                materials.borrow_mut().extend(ours);
                let map = raw
                    .iter()
                    .enumerate()
                    .map(|(i, m)| (m.name.clone(), i))
                    .collect();
                Ok((raw, map))
            }
            Err(e) => {
                mtl_errors.borrow_mut().push(e);
                Err(tobj::LoadError::GenericFailure)
            }
        }
    };
    let options = tobj::LoadOptions {
        single_index: true,
        triangulate: true,
        ignore_points: true,
        ignore_lines: true,
    };
    let mut reader = LineReader::new(text.as_bytes());
    let result = tobj::load_obj_buf(&mut reader, &options, loader);
    if let Some(e) = Error::joined(mtl_errors.into_inner()) {
        return Err(e);
    }
    let (models, _) = result.map_err(|e| Error::input(path, reader.describe(&e)))?;
    let materials = materials.into_inner();

    if with_materials {
        check_usemtl(&text, &materials).map_err(|e| Error::input(path, e))?;
    }

    let mut groups = Vec::new();
    for model in models {
        let m = model.mesh;
        if m.indices.is_empty() {
            continue;
        }
        let positions: Vec<Vec3> = m
            .positions
            .chunks_exact(3)
            .map(|p| Vec3::new(p[0], p[1], p[2]))
            .collect();
        let n = positions.len();
        let indices: Vec<[u32; 3]> = m
            .indices
            .chunks_exact(3)
            .map(|t| [t[0], t[1], t[2]])
            .collect();
        if let Some(bad) = indices.iter().flatten().find(|&&k| k as usize >= n) {
            return Err(Error::input(
                path,
                format!("object `{}`: vertex index {bad} out of range", model.name),
            ));
        }
        let normals = (m.normals.len() == 3 * n).then(|| {
            m.normals
                .chunks_exact(3)
                .map(|v| Vec3::new(v[0], v[1], v[2]).normalize_or_zero())
                .collect()
        });
        let uvs = (m.texcoords.len() == 2 * n).then(|| {
            m.texcoords
                .chunks_exact(2)
                .map(|v| Vec2::new(v[0], v[1]))
                .collect()
        });
        groups.push(ObjGroup {
            name: model.name,
            mesh: TriangleMesh {
                positions,
                normals,
                uvs,
                indices,
            },
            material: m.material_id,
        });
    }
    if groups.is_empty() {
        return Err(Error::input(path, "the file has no faces"));
    }
    Ok(ObjData { groups, materials })
}

fn read_text(
    path: &Path,
    what: &str,
    kind: &input_file::Kind,
    allowance: Option<&Allowance>,
) -> crate::error::Result<String> {
    let bytes = input_file::read(path, kind, allowance).map_err(|e| match e {
        Error::Io { source, .. } => {
            Error::input(path, format!("cannot read the {what} file: {source}"))
        }
        e => e,
    })?;
    String::from_utf8(bytes).map_err(|e| {
        let at = e.utf8_error().valid_up_to();
        let line = 1 + e.as_bytes()[..at].iter().filter(|&&b| b == b'\n').count();
        Error::input(
            path,
            format!("line {line}: not a text {what} file (invalid UTF-8)"),
        )
    })
}

/// Line-accurate checks tobj would make without a position (or not at all): vertices are
/// finite, faces have three or more corners and their indices exist.
fn prescan_obj(text: &str) -> Result<(), String> {
    let mut total = [0usize; 3];
    for line in text.lines() {
        match line.split_whitespace().next() {
            Some("v") => total[0] += 1,
            Some("vt") => total[1] += 1,
            Some("vn") => total[2] += 1,
            _ => {}
        }
    }
    let kinds = ["vertex", "texture coordinate", "normal"];
    let plural = ["vertices", "texture coordinates", "normals"];
    let mut seen = [0usize; 3];
    for (i, line) in text.lines().enumerate() {
        let at = i + 1;
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => {
                seen[0] += 1;
                let xyz: Vec<Option<f32>> = words.take(3).map(|w| w.parse().ok()).collect();
                if xyz.len() < 3 || xyz.iter().any(Option::is_none) {
                    return Err(format!("line {at}: `v` needs 3 numbers"));
                }
                if xyz.iter().flatten().any(|x| !x.is_finite()) {
                    return Err(format!("line {at}: vertex position is not finite"));
                }
            }
            Some("vt") => seen[1] += 1,
            Some("vn") => {
                seen[2] += 1;
                let xyz: Vec<Option<f32>> = words.take(3).map(|w| w.parse().ok()).collect();
                if xyz.len() < 3 || xyz.iter().any(|x| !x.is_some_and(f32::is_finite)) {
                    return Err(format!("line {at}: `vn` needs 3 finite numbers"));
                }
                let n = Vec3::from_array([0, 1, 2].map(|k| xyz[k].unwrap_or(0.0)));
                if let Err(e) = super::check_normal(n) {
                    return Err(format!("line {at}: the normal {e}"));
                }
            }
            Some("f") => {
                let corners: Vec<&str> = words.collect();
                if corners.len() < 3 {
                    return Err(format!(
                        "line {at}: a face needs at least 3 vertices, got {}",
                        corners.len()
                    ));
                }
                for corner in corners {
                    let parts: Vec<&str> = corner.split('/').collect();
                    if parts.len() > 3 || parts[0].is_empty() {
                        return Err(format!("line {at}: malformed face vertex `{corner}`"));
                    }
                    for (k, part) in parts.iter().enumerate() {
                        if part.is_empty() {
                            continue;
                        }
                        let Ok(index) = part.parse::<i64>() else {
                            return Err(format!("line {at}: malformed face vertex `{corner}`"));
                        };
                        let ok = match index {
                            0 => false,
                            i if i > 0 => i as u64 <= total[k] as u64,
                            i => i.unsigned_abs() <= seen[k] as u64,
                        };
                        if !ok {
                            return Err(format!(
                                "line {at}: face {} index {index} out of range (the file has {} \
                                 {})",
                                kinds[k], total[k], plural[k]
                            ));
                        }
                    }
                }
            }
            _ => {}
        }
    }
    Ok(())
}

/// Every `usemtl` must name a material of the MTL files.
fn check_usemtl(text: &str, materials: &[Material]) -> Result<(), String> {
    for (i, line) in text.lines().enumerate() {
        let line = line.trim();
        if let Some(rest) = line.strip_prefix("usemtl") {
            if !rest.starts_with(char::is_whitespace) {
                continue;
            }
            let name = rest.trim();
            if !materials.iter().any(|m| m.name == name) {
                let known = if materials.is_empty() {
                    "no MTL materials were loaded (is there an `mtllib` line?)".to_string()
                } else {
                    format!(
                        "known: {}",
                        materials
                            .iter()
                            .take(12)
                            .map(|m| m.name.as_str())
                            .collect::<Vec<_>>()
                            .join(", ")
                    )
                };
                return Err(format!(
                    "line {}: usemtl `{name}`: no such material ({known})",
                    i + 1
                ));
            }
        }
    }
    Ok(())
}

/// Reads one MTL file: tobj's materials (for its name map) and ours.
fn load_mtl(path: &Path) -> crate::error::Result<(Vec<tobj::Material>, Vec<Material>)> {
    let text = read_text(path, "MTL", &input_file::MTL, None)?;
    let text = normalise_mtl(&text).map_err(|e| Error::input(path, e))?;
    let mut reader = LineReader::new(text.as_bytes());
    let (raw, _) =
        tobj::load_mtl_buf(&mut reader).map_err(|e| Error::input(path, reader.describe(&e)))?;
    let ours = raw
        .iter()
        .map(|m| convert(m, path))
        .collect::<crate::error::Result<Vec<_>>>()?;
    Ok((raw, ours))
}

/// Colour statements take 1 or 3 numbers (one stands for grey); tobj wants exactly 3 and
/// panics on fewer, so expand or reject them here, keeping the line structure.
fn normalise_mtl(text: &str) -> Result<String, String> {
    let mut out = String::with_capacity(text.len() + 64);
    for (i, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        let key = words.next();
        if let Some(key @ ("Ka" | "Kd" | "Ks" | "Ke" | "Tf")) = key {
            let values: Vec<&str> = words.collect();
            let numbers: Vec<f32> = values.iter().filter_map(|w| w.parse().ok()).collect();
            match (values.len(), numbers.len()) {
                (1, 1) => {
                    let v = values[0];
                    out.push_str(&format!("{key} {v} {v} {v}"));
                }
                (3, 3) => out.push_str(line),
                _ => {
                    return Err(format!(
                        "line {}: `{key}` needs 1 or 3 numbers (spectral and xyz colours are \
                         not supported), got `{}`",
                        i + 1,
                        values.join(" ")
                    ))
                }
            }
        } else {
            out.push_str(line);
        }
        out.push('\n');
    }
    Ok(out)
}

/// MTL illumination models that refract, for which `Tf` is the transmission.
const REFRACTING_ILLUM: [u8; 4] = [4, 6, 7, 9];

/// Translates an MTL material (see docs/scene-format.md for the mapping).
fn convert(m: &tobj::Material, mtl: &Path) -> crate::error::Result<Material> {
    let fail =
        |key: &str, msg: String| Error::input(mtl, format!("material `{}`: {key} {msg}", m.name));
    let colour = |key: &str, c: Option<[f32; 3]>, default: Rgb| -> crate::error::Result<Rgb> {
        match c {
            None => Ok(default),
            Some(c) => {
                let c = Vec3::from_array(c);
                if !c.is_finite() || c.min_element() < 0.0 {
                    Err(fail(
                        key,
                        format!("must be finite and not negative, got {c}"),
                    ))
                } else {
                    Ok(c)
                }
            }
        }
    };
    let param3 = |key: &str| -> crate::error::Result<Option<[f32; 3]>> {
        let Some(v) = m.unknown_param.get(key) else {
            return Ok(None);
        };
        // normalise_mtl has made colour statements three numbers.
        let n: Vec<f32> = v
            .split_whitespace()
            .filter_map(|w| w.parse().ok())
            .collect();
        match n[..] {
            [r, g, b] => Ok(Some([r, g, b])),
            _ => Err(fail(key, format!("needs 3 numbers, got `{v}`"))),
        }
    };
    let d = Classic::default();
    let diffuse = colour("Kd", m.diffuse, d.diffuse.max_value())?;
    let ambient = match m.ambient {
        None => None,
        Some(c) => Some(colour("Ka", Some(c), Rgb::ZERO)?),
    };
    let specular = colour("Ks", m.specular, Rgb::ZERO)?;
    let emission = colour("Ke", m.emissive, Rgb::ZERO)?;
    let phong_exponent = match m.shininess {
        None => d.phong_exponent,
        Some(n) if n.is_finite() && n >= 0.0 => n,
        Some(n) => return Err(fail("Ns", format!("must not be negative, got {n}"))),
    };

    let dissolve = match (m.dissolve, m.unknown_param.get("Tr")) {
        (Some(d), _) => Some(d),
        (None, Some(tr)) => match tr.trim().parse::<f32>() {
            Ok(tr) => Some(1.0 - tr),
            Err(_) => return Err(fail("Tr", format!("must be a number, got `{tr}`"))),
        },
        (None, None) => None,
    };
    if let Some(d) = dissolve {
        if !(0.0..=1.0).contains(&d) {
            return Err(fail("d", format!("(dissolve) must be in [0, 1], got {d}")));
        }
    }
    let refracts = m
        .illumination_model
        .is_none_or(|i| REFRACTING_ILLUM.contains(&i));
    let tf = param3("Tf")?;
    let transmission = match (tf, dissolve) {
        (Some(tf), _) if refracts => colour("Tf", Some(tf), Rgb::ZERO)?,
        (_, Some(d)) => Rgb::splat(1.0 - d),
        _ => Rgb::ZERO,
    };
    let ior = match m.optical_density {
        None => d.ior,
        Some(n) if n.is_finite() && n > 0.0 => n,
        // Exporters write `Ni 0` for opaque materials; only a transmitting one needs it.
        Some(_) if transmission.max_element() <= 0.0 => d.ior,
        Some(n) => return Err(fail("Ni", format!("must be positive, got {n}"))),
    };
    let classic = Classic {
        diffuse: Texture::Constant(diffuse),
        ambient,
        specular,
        transmission,
        ior,
        phong_exponent,
        ..Classic::blank()
    };
    Ok(Material::classic(m.name.clone(), classic).emitting(emission))
}

/// A reader over text that knows which line tobj was reading when it failed.
struct LineReader<'a> {
    data: &'a [u8],
    pos: usize,
}

impl<'a> LineReader<'a> {
    fn new(data: &'a [u8]) -> Self {
        LineReader { data, pos: 0 }
    }

    /// The line last handed out (tobj reads whole lines and stops at the failing one).
    fn line(&self) -> usize {
        let end = self.pos.saturating_sub(1).min(self.data.len());
        1 + self.data[..end].iter().filter(|&&b| b == b'\n').count()
    }

    fn describe(&self, e: &tobj::LoadError) -> String {
        use tobj::LoadError as E;
        match e {
            // Found when an object is complete, not on its line.
            E::FaceVertexOutOfBounds
            | E::FaceTexCoordOutOfBounds
            | E::FaceNormalOutOfBounds
            | E::FaceColorOutOfBounds
            | E::GenericFailure
            | E::InvalidLoadOptionConfig => e.to_string(),
            _ => format!("line {}: {e}", self.line()),
        }
    }
}

impl Read for LineReader<'_> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let rest = self.data.get(self.pos..).unwrap_or(&[]);
        let n = rest.len().min(buf.len());
        buf[..n].copy_from_slice(&rest[..n]);
        self.pos += n;
        Ok(n)
    }
}

impl BufRead for LineReader<'_> {
    fn fill_buf(&mut self) -> std::io::Result<&[u8]> {
        // Hand out one line at a time so `pos` tells the line being parsed.
        let rest = self.data.get(self.pos..).unwrap_or(&[]);
        let end = rest
            .iter()
            .position(|&b| b == b'\n')
            .map_or(rest.len(), |i| i + 1);
        Ok(&rest[..end])
    }

    fn consume(&mut self, amt: usize) {
        self.pos = (self.pos + amt).min(self.data.len());
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(dir: &Path, name: &str, text: &str) -> std::path::PathBuf {
        let path = dir.join(name);
        std::fs::write(&path, text).unwrap();
        path
    }

    const TRIANGLE: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nvt 0 0\nvt 1 0\nvt 0 1\n";

    #[test]
    fn mtl_parameters_become_materials() {
        let dir = tempfile::tempdir().unwrap();
        write(
            dir.path(),
            "m.mtl",
            "newmtl glass\nKd 0.1\nKs 0.2 0.2 0.2\nTf 0.9 0.8 0.7\nNi 1.33\nNs 100\nillum 7\n\
             newmtl veil\nKd 0.5 0.5 0.5\nd 0.25\nTf 1 1 1\nillum 2\n\
             newmtl lamp\nKa 0 0 0\nKd 0 0 0\nKe 5 4 3\nNi 0\n",
        );
        let obj = write(
            dir.path(),
            "m.obj",
            &format!(
                "mtllib m.mtl\n{TRIANGLE}usemtl glass\nf 1/1/1 2/2/1 3/3/1\n\
                 usemtl veil\nf 1 2 3\nusemtl lamp\nf 3 2 1\n"
            ),
        );
        let data = load(&obj, true).unwrap();
        let [glass_m, veil_m, lamp_m] = &data.materials[..] else {
            panic!("{:?}", data.materials)
        };
        let (glass, veil, lamp) = (
            glass_m.approximation(),
            veil_m.approximation(),
            lamp_m.approximation(),
        );
        assert_eq!(glass.diffuse, Texture::Constant(Vec3::splat(0.1)));
        assert_eq!(glass.specular, Vec3::splat(0.2));
        assert_eq!(glass.transmission, Vec3::new(0.9, 0.8, 0.7));
        assert_eq!((glass.ior, glass.phong_exponent), (1.33, 100.0));
        // Tf is ignored for a non-refracting illum; 1 - d is the transmission.
        assert_eq!(veil.transmission, Vec3::splat(0.75));
        assert_eq!(lamp_m.emission, Vec3::new(5.0, 4.0, 3.0));
        // Exporters' `Ni 0` on an opaque material leaves the default.
        assert_eq!(lamp.ior, 1.5);
        assert_eq!(lamp.ambient, Some(Vec3::ZERO));
        assert!(veil.ambient.is_none());

        assert_eq!(data.groups.len(), 3);
        let first = &data.groups[0];
        assert_eq!(first.material, Some(0));
        assert_eq!(first.mesh.indices, vec![[0, 1, 2]]);
        assert_eq!(first.mesh.normals.as_ref().unwrap()[0], Vec3::Z);
        assert_eq!(first.mesh.uvs.as_ref().unwrap()[2], Vec2::new(0.0, 1.0));
        // The second group has neither normals nor uvs.
        assert!(data.groups[1].mesh.normals.is_none() && data.groups[1].mesh.uvs.is_none());
    }

    #[test]
    fn polygons_are_triangulated_and_materials_can_be_skipped() {
        let dir = tempfile::tempdir().unwrap();
        let obj = write(
            dir.path(),
            "q.obj",
            "mtllib absent.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv -1 0.5 0\nusemtl x\n\
             f 1 2 3 4 5\n",
        );
        let data = load(&obj, false).unwrap();
        assert!(data.materials.is_empty());
        assert_eq!(data.groups.len(), 1);
        assert_eq!(data.groups[0].mesh.indices.len(), 3);
        assert_eq!(data.groups[0].material, None);
        // With materials the missing library is an error naming it.
        let e = load(&obj, true).unwrap_err().to_string();
        assert!(e.contains("absent.mtl") && !e.contains('\n'), "{e}");
    }

    #[test]
    fn transmitting_material_needs_a_positive_ior() {
        let dir = tempfile::tempdir().unwrap();
        write(dir.path(), "g.mtl", "newmtl g\nd 0.1\nNi 0\n");
        let obj = write(
            dir.path(),
            "g.obj",
            &format!("mtllib g.mtl\n{TRIANGLE}usemtl g\nf 1 2 3\n"),
        );
        let e = load(&obj, true).unwrap_err().to_string();
        assert!(
            e.contains("g.mtl: material `g`: Ni must be positive, got 0"),
            "{e}"
        );
    }

    #[test]
    fn tobj_errors_carry_the_line() {
        let dir = tempfile::tempdir().unwrap();
        let obj = write(
            dir.path(),
            "t.obj",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt x y\nf 1 2 3\n",
        );
        let e = load(&obj, false).unwrap_err().to_string();
        assert!(e.ends_with("t.obj: line 4: texcoord parse error"), "{e}");
    }
}
