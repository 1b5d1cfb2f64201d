//! PLY meshes (ASCII, binary little and big endian) through `ply-rs-bw`: positions, normals
//! (`nx ny nz`), uvs (`u v`, `s t`, `texture_u texture_v` or `texture_s texture_t`) and faces
//! (`vertex_indices` or `vertex_index`) of three or four vertices. [`write()`] writes binary
//! little-endian files for `raylink convert`.

use super::{Geometry, QuadMesh, TriangleMesh};
use crate::error::Error;
use crate::math::{Vec2, Vec3};
use ply_rs_bw::parser::{Parser, Reader};
use ply_rs_bw::ply::{DefaultElement, PropertyAccess, PropertyAccessResult};
use std::io::BufReader;
use std::path::Path;

/// A mesh as read from a PLY file, in the file's own space.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PlyMesh {
    pub positions: Vec<Vec3>,
    pub normals: Option<Vec<Vec3>>,
    pub uvs: Option<Vec<Vec2>>,
    pub triangles: Vec<[u32; 3]>,
    /// Quads in polygon order (a, b, c, d).
    pub quads: Vec<[u32; 4]>,
    /// Faces with other than 3 or 4 vertices, left out (as pbrt-v4 does).
    pub skipped_faces: usize,
}

#[derive(Default)]
struct Vertex {
    p: [f64; 3],
    n: [f64; 3],
    uv: [f64; 2],
}

impl Vertex {
    fn set(&mut self, name: &str, v: f64) -> PropertyAccessResult {
        let slot = match name {
            "x" => &mut self.p[0],
            "y" => &mut self.p[1],
            "z" => &mut self.p[2],
            "nx" => &mut self.n[0],
            "ny" => &mut self.n[1],
            "nz" => &mut self.n[2],
            "u" | "s" | "texture_u" | "texture_s" => &mut self.uv[0],
            "v" | "t" | "texture_v" | "texture_t" => &mut self.uv[1],
            _ => return PropertyAccessResult::Ignored,
        };
        *slot = v;
        PropertyAccessResult::Set
    }
}

impl PropertyAccess for Vertex {
    fn new() -> Self {
        Vertex::default()
    }
    fn set_char(&mut self, n: &str, v: i8) -> PropertyAccessResult {
        self.set(n, v.into())
    }
    fn set_uchar(&mut self, n: &str, v: u8) -> PropertyAccessResult {
        self.set(n, v.into())
    }
    fn set_short(&mut self, n: &str, v: i16) -> PropertyAccessResult {
        self.set(n, v.into())
    }
    fn set_ushort(&mut self, n: &str, v: u16) -> PropertyAccessResult {
        self.set(n, v.into())
    }
    fn set_int(&mut self, n: &str, v: i32) -> PropertyAccessResult {
        self.set(n, v.into())
    }
    fn set_uint(&mut self, n: &str, v: u32) -> PropertyAccessResult {
        self.set(n, v.into())
    }
    fn set_float(&mut self, n: &str, v: f32) -> PropertyAccessResult {
        self.set(n, v.into())
    }
    fn set_double(&mut self, n: &str, v: f64) -> PropertyAccessResult {
        self.set(n, v)
    }
}

#[derive(Default)]
struct Face {
    indices: Vec<i64>,
}

impl Face {
    fn set<T: Into<i64>>(&mut self, name: &str, v: Vec<T>) -> PropertyAccessResult {
        if name == "vertex_indices" || name == "vertex_index" {
            self.indices = v.into_iter().map(Into::into).collect();
            PropertyAccessResult::Set
        } else {
            PropertyAccessResult::Ignored
        }
    }
}

impl PropertyAccess for Face {
    fn new() -> Self {
        Face::default()
    }
    fn set_list_char(&mut self, n: &str, v: Vec<i8>) -> PropertyAccessResult {
        self.set(n, v)
    }
    fn set_list_uchar(&mut self, n: &str, v: Vec<u8>) -> PropertyAccessResult {
        self.set(n, v)
    }
    fn set_list_short(&mut self, n: &str, v: Vec<i16>) -> PropertyAccessResult {
        self.set(n, v)
    }
    fn set_list_ushort(&mut self, n: &str, v: Vec<u16>) -> PropertyAccessResult {
        self.set(n, v)
    }
    fn set_list_int(&mut self, n: &str, v: Vec<i32>) -> PropertyAccessResult {
        self.set(n, v)
    }
    fn set_list_uint(&mut self, n: &str, v: Vec<u32>) -> PropertyAccessResult {
        self.set(n, v)
    }
}

/// Reads a PLY mesh. Every problem is an [`Error::input`] naming the file (and the line,
/// for ASCII files and headers).
pub fn read(path: &Path) -> crate::error::Result<PlyMesh> {
    let (file, _) =
        crate::input_file::open(path, &crate::input_file::PLY).map_err(|e| match e {
            Error::Io { source, .. } => {
                Error::input(path, format!("cannot read the PLY file: {source}"))
            }
            e => e,
        })?;
    let mut reader = Reader::new(BufReader::new(file));
    let fail = |e: ply_rs_bw::parser::ParseError| {
        // ply-rs appends tab-separated internals (the parser's expected-token sets): keep
        // the message and the offending text.
        let msg = e.to_string().replace(['\n', '\r'], " ");
        let mut parts = msg.split('\t').map(str::trim);
        let mut msg = parts.next().unwrap_or_default().to_string();
        if let Some(text) = parts.find(|p| p.starts_with("String:")) {
            msg = format!("{msg} ({})", text.trim_end());
        }
        let msg = match msg.strip_prefix("Line ") {
            Some(rest) => format!("line {rest}"),
            None => msg,
        };
        Error::input(path, format!("malformed PLY file: {msg}"))
    };
    let vertex_parser = Parser::<Vertex>::new();
    let face_parser = Parser::<Face>::new();
    let other_parser = Parser::<DefaultElement>::new();
    let header = vertex_parser.read_header(&mut reader).map_err(fail)?;

    let mut vertices = None;
    let mut faces = None;
    let mut has_normals = false;
    let mut has_uvs = false;
    for (name, def) in &header.elements {
        let has = |p: &str| def.properties.contains_key(p);
        match name.as_str() {
            "vertex" => {
                if !(has("x") && has("y") && has("z")) {
                    return Err(Error::input(path, "the PLY file's vertices lack x, y or z"));
                }
                has_normals = has("nx") && has("ny") && has("nz");
                has_uvs = [("u", "v"), ("s", "t"), ("texture_u", "texture_v")]
                    .iter()
                    .chain(&[("texture_s", "texture_t")])
                    .any(|(a, b)| has(a) && has(b));
                vertices = Some(
                    vertex_parser
                        .read_payload_for_element(&mut reader, def, &header)
                        .map_err(fail)?,
                );
            }
            "face" => {
                if !(has("vertex_indices") || has("vertex_index")) {
                    return Err(Error::input(
                        path,
                        "the PLY file's faces have no vertex_indices property",
                    ));
                }
                faces = Some(
                    face_parser
                        .read_payload_for_element(&mut reader, def, &header)
                        .map_err(fail)?,
                );
            }
            _ => {
                other_parser
                    .read_payload_for_element(&mut reader, def, &header)
                    .map_err(fail)?;
            }
        }
    }
    let (Some(vertices), Some(faces)) = (vertices, faces) else {
        return Err(Error::input(
            path,
            "the PLY file needs a vertex and a face element",
        ));
    };
    let n = vertices.len();
    let mut mesh = PlyMesh::default();
    for (i, v) in vertices.iter().enumerate() {
        let p = Vec3::new(v.p[0] as f32, v.p[1] as f32, v.p[2] as f32);
        if !p.is_finite() {
            return Err(Error::input(
                path,
                format!("vertex {i}: position is not finite"),
            ));
        }
        mesh.positions.push(p);
    }
    if has_normals {
        let mut normals = Vec::with_capacity(n);
        for (i, v) in vertices.iter().enumerate() {
            let normal = Vec3::new(v.n[0] as f32, v.n[1] as f32, v.n[2] as f32);
            super::check_normal(normal)
                .map_err(|e| Error::input(path, format!("vertex {i}: the normal {e}")))?;
            normals.push(normal);
        }
        mesh.normals = Some(normals);
    }
    if has_uvs {
        mesh.uvs = Some(
            vertices
                .iter()
                .map(|v| Vec2::new(v.uv[0] as f32, v.uv[1] as f32))
                .collect(),
        );
    }
    for (f, face) in faces.iter().enumerate() {
        if let Some(&k) = face.indices.iter().find(|&&k| k < 0 || k as usize >= n) {
            return Err(Error::input(
                path,
                format!("face {f}: vertex index {k} out of range (the mesh has {n} vertices)"),
            ));
        }
        let ix: Vec<u32> = face.indices.iter().map(|&k| k as u32).collect();
        match ix[..] {
            [a, b, c] => mesh.triangles.push([a, b, c]),
            [a, b, c, d] => mesh.quads.push([a, b, c, d]),
            _ => mesh.skipped_faces += 1,
        }
    }
    if mesh.triangles.is_empty() && mesh.quads.is_empty() {
        return Err(Error::input(path, "the PLY file has no triangles or quads"));
    }
    Ok(mesh)
}

impl PlyMesh {
    /// The mesh as raylink geometry (in whatever space its positions are): quads become a
    /// [`QuadMesh`] when the mesh has no normals or uvs and every quad is planar and convex,
    /// otherwise two triangles each (a, b, c) and (a, c, d).
    pub fn into_geometry(self) -> Vec<Geometry> {
        let quads_ok = self.normals.is_none()
            && self.uvs.is_none()
            && !self.quads.is_empty()
            && self
                .quads
                .iter()
                .all(|q| planar_convex(&q.map(|k| self.positions[k as usize])));
        let mut out = Vec::new();
        let mut triangles = self.triangles;
        if quads_ok {
            out.push(Geometry::Quads(QuadMesh {
                positions: self.positions.clone(),
                indices: self.quads,
            }));
        } else {
            for [a, b, c, d] in self.quads {
                triangles.push([a, b, c]);
                triangles.push([a, c, d]);
            }
        }
        if !triangles.is_empty() {
            out.insert(
                0,
                Geometry::Triangles(TriangleMesh {
                    positions: self.positions,
                    normals: self.normals,
                    uvs: self.uvs,
                    indices: triangles,
                }),
            );
        }
        out
    }
}

/// Whether four points make a planar, convex quad with area (relative tolerances).
pub(crate) fn planar_convex(q: &[Vec3; 4]) -> bool {
    let n = (q[2] - q[0]).cross(q[3] - q[1]);
    let size = (q[2] - q[0]).length().max((q[3] - q[1]).length());
    if n.length().is_nan() || n.length() <= 1e-8 * size * size {
        return false;
    }
    let n = n.normalize();
    let c = (q[0] + q[1] + q[2] + q[3]) * 0.25;
    if q.iter().any(|p| (*p - c).dot(n).abs() > 1e-5 * size) {
        return false;
    }
    (0..4).all(|i| {
        let (a, b, c) = (q[i], q[(i + 1) % 4], q[(i + 2) % 4]);
        (b - a).cross(c - b).dot(n) > 0.0
    })
}

/// Writes a binary little-endian PLY file (atomically: a temporary file renamed into place).
pub fn write(
    path: &Path,
    positions: &[Vec3],
    normals: Option<&[Vec3]>,
    uvs: Option<&[Vec2]>,
    triangles: &[[u32; 3]],
    quads: &[[u32; 4]],
) -> crate::error::Result<()> {
    let mut header = format!(
        "ply\nformat binary_little_endian 1.0\ncomment written by raylink\n\
         element vertex {}\nproperty float x\nproperty float y\nproperty float z\n",
        positions.len()
    );
    if normals.is_some() {
        header.push_str("property float nx\nproperty float ny\nproperty float nz\n");
    }
    if uvs.is_some() {
        header.push_str("property float u\nproperty float v\n");
    }
    header.push_str(&format!(
        "element face {}\nproperty list uchar int vertex_indices\nend_header\n",
        triangles.len() + quads.len()
    ));
    let mut bytes = header.into_bytes();
    for (i, p) in positions.iter().enumerate() {
        let mut vals = p.to_array().to_vec();
        if let Some(n) = normals {
            vals.extend(n[i].to_array());
        }
        if let Some(t) = uvs {
            vals.extend(t[i].to_array());
        }
        for v in vals {
            bytes.extend(v.to_le_bytes());
        }
    }
    for face in triangles
        .iter()
        .map(|t| &t[..])
        .chain(quads.iter().map(|q| &q[..]))
    {
        bytes.push(face.len() as u8);
        for &k in face {
            bytes.extend((k as i32).to_le_bytes());
        }
    }
    crate::atomic_file::write(path, &bytes)
}
