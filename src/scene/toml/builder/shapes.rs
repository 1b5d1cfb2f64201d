//! The builder's shapes: spheres, quads, polygons, inline meshes, OBJ and PLY files.

use super::super::checks::{
    check_area, direction, finite3, geometry_is_finite, planar_convex, positive, Xform,
};
use super::super::diagnostics::Site;
use super::super::schema::{AlphaDesc, DiffuseDesc, Idx3, ShapeDesc, ShapeKind, V2, V3};
use super::Builder;
use crate::math::Vec3;
use crate::scene::{obj, Alpha, Geometry, QuadMesh, Shape, Sphere, Texture, TriangleMesh};

impl Builder<'_> {
    /// A shape's `alpha`: None when absent or 1 (opaque).
    pub(super) fn alpha(
        &self,
        site: &Site,
        desc: Option<AlphaDesc>,
    ) -> crate::error::Result<Option<Alpha>> {
        let ctx = self.ctx;
        match desc {
            None => Ok(None),
            Some(AlphaDesc::Constant(a)) if (0.0..=1.0).contains(&a) => {
                Ok((a < 1.0).then_some(Alpha::Constant(a as f32)))
            }
            Some(AlphaDesc::Constant(a)) => {
                Err(ctx.fail(site, "alpha", format!("must be in [0, 1], got {a}")))
            }
            Some(AlphaDesc::Texture(t)) if t.image.is_some() => {
                match self.texture(site, "alpha", DiffuseDesc::Texture(t))? {
                    Texture::Image(image) => Ok(Some(Alpha::Image(image))),
                    _ => Err(ctx.fail(site, "alpha", "takes one image table")),
                }
            }
            Some(AlphaDesc::Texture(_)) => Err(ctx.fail(
                site,
                "alpha",
                "takes a number in [0, 1] or { image = { file = \"..\" } }",
            )),
        }
    }

    pub(super) fn shape(
        &mut self,
        site: &Site,
        mut desc: ShapeDesc,
    ) -> crate::error::Result<Vec<Shape>> {
        let ctx = self.ctx;
        let kind = desc.kind;
        for p in desc.present() {
            if !kind.params().contains(&p) {
                return Err(ctx.fail(
                    site,
                    p,
                    format!(
                        "a {} does not take `{p}` (it takes {})",
                        kind.name(),
                        kind.params().join(", ")
                    ),
                ));
            }
        }
        let material = match (&desc.material, kind) {
            (Some(name), _) => Some(self.material_index(site, name)?),
            (None, ShapeKind::Obj) => None,
            (None, _) => {
                return Err(ctx.fail(
                    site,
                    "",
                    format!("a {} needs `material = \"NAME\"`", kind.name()),
                ))
            }
        };
        let required = |v: bool, key: &str| {
            if v {
                Ok(())
            } else {
                Err(ctx.fail(site, "", format!("a {} needs `{key}`", kind.name())))
            }
        };
        let xf = self.transform(site, desc.transform.take())?;
        let fail = |key: &'static str| move |m: String| ctx.fail(site, key, m);

        let geometry = match kind {
            ShapeKind::Sphere => {
                let center =
                    finite3(desc.center.map_or(Vec3::ZERO, |c| c.0)).map_err(fail("center"))?;
                let radius = positive(desc.radius.unwrap_or(1.0)).map_err(fail("radius"))?;
                let (center, radius) = xf
                    .sphere(center, radius)
                    .map_err(|m| ctx.fail(site, "transform", m))?;
                Geometry::Sphere(Sphere { center, radius })
            }
            ShapeKind::Quad => {
                required(desc.vertices.is_some(), "vertices")?;
                let vs = self.vertices(site, desc.vertices.unwrap_or_default(), &xf)?;
                if vs.len() != 4 {
                    return Err(ctx.fail(
                        site,
                        "vertices",
                        format!("a quad has exactly 4 vertices, got {}", vs.len()),
                    ));
                }
                planar_convex(&vs, "quad").map_err(fail("vertices"))?;
                Geometry::Quads(QuadMesh {
                    positions: vs,
                    indices: vec![[0, 1, 2, 3]],
                })
            }
            ShapeKind::Polygon => {
                required(desc.vertices.is_some(), "vertices")?;
                let vs = self.vertices(site, desc.vertices.unwrap_or_default(), &xf)?;
                if vs.len() < 3 {
                    return Err(ctx.fail(
                        site,
                        "vertices",
                        format!("a polygon has at least 3 vertices, got {}", vs.len()),
                    ));
                }
                planar_convex(&vs, "polygon").map_err(fail("vertices"))?;
                let indices = (1..vs.len() as u32 - 1).map(|i| [0, i, i + 1]).collect();
                Geometry::Triangles(TriangleMesh {
                    positions: vs,
                    normals: None,
                    uvs: None,
                    indices,
                })
            }
            ShapeKind::Mesh => {
                required(desc.positions.is_some(), "positions")?;
                required(desc.indices.is_some(), "indices")?;
                let mesh = self.mesh(site, desc, &xf)?;
                Geometry::Triangles(mesh)
            }
            ShapeKind::Obj => {
                required(desc.file.is_some(), "file")?;
                let file = desc.file.unwrap_or_default();
                return self.obj(site, &file, material, &xf);
            }
            ShapeKind::Ply => {
                required(desc.file.is_some(), "file")?;
                let file = desc.file.unwrap_or_default();
                return self.ply(site, &file, material.unwrap_or_default(), &xf);
            }
        };
        if !geometry_is_finite(&geometry) {
            return Err(ctx.fail(
                site,
                "transform",
                "overflows: it moves the shape out of the range of finite numbers",
            ));
        }
        Ok(vec![Shape {
            media: None,
            geometry,
            material: material.unwrap_or_default(),
            alpha: None,
            motion: None,
        }])
    }

    /// Checks and transforms a vertex list; keeps the order unless the transform mirrors.
    fn vertices(&self, site: &Site, vs: Vec<V3>, xf: &Xform) -> crate::error::Result<Vec<Vec3>> {
        let mut out = Vec::with_capacity(vs.len());
        for (i, v) in vs.into_iter().enumerate() {
            let v = finite3(v.0).map_err(|m| self.ctx.fail(site, &format!("vertices[{i}]"), m))?;
            out.push(xf.point(v));
        }
        if xf.flips && out.len() > 1 {
            // A mirror reverses the winding; reverse it back so faces keep their side.
            out[1..].reverse();
        }
        Ok(out)
    }

    fn mesh(&self, site: &Site, desc: ShapeDesc, xf: &Xform) -> crate::error::Result<TriangleMesh> {
        let ctx = self.ctx;
        let field = |name: &str, i: usize| format!("{name}[{i}]");
        let positions = desc.positions.unwrap_or_default();
        let indices = desc.indices.unwrap_or_default();
        let n = positions.len();
        let mut mesh = TriangleMesh::default();
        for (i, p) in positions.into_iter().enumerate() {
            let p = finite3(p.0).map_err(|m| ctx.fail(site, &field("positions", i), m))?;
            let p = xf.point(p);
            if !p.is_finite() {
                return Err(ctx.fail(
                    site,
                    "transform",
                    "overflows: it moves the shape out of the range of finite numbers",
                ));
            }
            mesh.positions.push(p);
        }
        if indices.is_empty() {
            return Err(ctx.fail(site, "indices", "the mesh has no triangles"));
        }
        for (i, Idx3(tri)) in indices.into_iter().enumerate() {
            if let Some(&k) = tri.iter().find(|&&k| k as usize >= n) {
                return Err(ctx.fail(
                    site,
                    &field("indices", i),
                    format!("vertex index {k} out of range (the mesh has {n} positions)"),
                ));
            }
            let [a, b, c] = tri;
            mesh.indices
                .push(if xf.flips { [a, c, b] } else { [a, b, c] });
        }
        if let Some(normals) = desc.normals {
            if normals.len() != n {
                return Err(ctx.fail(
                    site,
                    "normals",
                    format!("needs one normal per position ({n}), got {}", normals.len()),
                ));
            }
            let mut out = Vec::with_capacity(n);
            for (i, v) in normals.into_iter().enumerate() {
                let v = direction(v.0).map_err(|m| ctx.fail(site, &field("normals", i), m))?;
                out.push(xf.normal(v));
            }
            mesh.normals = Some(out);
        }
        if let Some(uvs) = desc.uvs {
            if uvs.len() != n {
                return Err(ctx.fail(
                    site,
                    "uvs",
                    format!("needs one uv per position ({n}), got {}", uvs.len()),
                ));
            }
            let mut out = Vec::with_capacity(n);
            for (i, V2(uv)) in uvs.into_iter().enumerate() {
                if !uv.is_finite() {
                    return Err(ctx.fail(
                        site,
                        &field("uvs", i),
                        format!("must be finite, got {uv}"),
                    ));
                }
                out.push(uv);
            }
            mesh.uvs = Some(out);
        }
        check_area(&mesh).map_err(|m| ctx.fail(site, "positions", m))?;
        Ok(mesh)
    }

    fn obj(
        &mut self,
        site: &Site,
        file: &str,
        material: Option<usize>,
        xf: &Xform,
    ) -> crate::error::Result<Vec<Shape>> {
        let ctx = self.ctx;
        let path = self.dir.join(file);
        self.inputs.borrow_mut().push(path.clone());
        let data = obj::load_within(&path, material.is_none(), Some(&self.allowance()))
            .map_err(|e| ctx.fail(site, "file", e))?;
        let mapping = match material {
            Some(_) => Vec::new(),
            None => match self.obj_materials.get(&path) {
                Some(m) => m.clone(),
                None => {
                    let mut m = Vec::new();
                    for mat in data.materials {
                        m.push(self.materials.len());
                        self.materials.push(mat);
                    }
                    self.obj_materials.insert(path.clone(), m.clone());
                    m
                }
            },
        };
        let mut shapes = Vec::new();
        for group in data.groups {
            let index = match material {
                Some(i) => i,
                None => group
                    .material
                    .and_then(|k| mapping.get(k).copied())
                    .ok_or_else(|| {
                        ctx.fail(
                            site,
                            "file",
                            format!(
                                "{}: object `{}` has faces without a material; give the shape \
                                 a `material`",
                                path.display(),
                                group.name
                            ),
                        )
                    })?,
            };
            let mut mesh = group.mesh;
            xf.place(&mut mesh.positions, &mut mesh.normals);
            if xf.flips {
                for t in &mut mesh.indices {
                    t.swap(1, 2);
                }
            }
            let geometry = Geometry::Triangles(mesh);
            if !geometry_is_finite(&geometry) {
                return Err(ctx.fail(
                    site,
                    "transform",
                    "overflows: it moves the shape out of the range of finite numbers",
                ));
            }
            shapes.push(Shape {
                media: None,
                geometry,
                material: index,
                alpha: None,
                motion: None,
            });
        }
        if shapes.iter().all(|s| s.geometry.area() <= 0.0) {
            return Err(ctx.fail(
                site,
                "file",
                format!("{}: the mesh has no triangles with area", path.display()),
            ));
        }
        Ok(shapes)
    }

    fn ply(
        &self,
        site: &Site,
        file: &str,
        material: usize,
        xf: &Xform,
    ) -> crate::error::Result<Vec<Shape>> {
        let ctx = self.ctx;
        let path = self.dir.join(file);
        self.inputs.borrow_mut().push(path.clone());
        let mut mesh = crate::scene::ply::read(&path).map_err(|e| ctx.fail(site, "file", e))?;
        xf.place(&mut mesh.positions, &mut mesh.normals);
        if xf.flips {
            for t in &mut mesh.triangles {
                t.swap(1, 2);
            }
            for q in &mut mesh.quads {
                q.swap(1, 3);
            }
        }
        let shapes: Vec<Shape> = mesh
            .into_geometry()
            .into_iter()
            .map(|geometry| Shape {
                media: None,
                geometry,
                material,
                alpha: None,
                motion: None,
            })
            .collect();
        if shapes.iter().any(|s| !geometry_is_finite(&s.geometry)) {
            return Err(ctx.fail(
                site,
                "transform",
                "overflows: it moves the shape out of the range of finite numbers",
            ));
        }
        if shapes.iter().all(|s| s.geometry.area() <= 0.0) {
            return Err(ctx.fail(
                site,
                "file",
                format!("{}: the mesh has no faces with area", path.display()),
            ));
        }
        Ok(shapes)
    }

    fn material_index(&self, site: &Site, name: &str) -> crate::error::Result<usize> {
        self.names.get(name).copied().ok_or_else(|| {
            let mut known: Vec<&str> = self.materials.iter().map(|m| m.name.as_str()).collect();
            known.truncate(12);
            let known = if known.is_empty() {
                "no [materials.NAME] tables are defined".to_string()
            } else {
                format!("defined: {}", known.join(", "))
            };
            self.ctx.fail(
                site,
                "material",
                format!("unknown material `{name}` ({known})"),
            )
        })
    }
}
