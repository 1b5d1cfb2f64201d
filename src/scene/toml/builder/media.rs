//! The builder's media: `[media.NAME]` tables, and the names shapes and the camera give.

use super::super::diagnostics::Site;
use super::super::schema::{MediumDesc, ShapeMediaDesc};
use super::Builder;
use crate::math::{Rgb, Vec3};
use crate::scene::media::{nanovdb, SparseSource};
use crate::scene::media::{
    Homogeneous, Medium, MediumInterface, MediumKind, MediumPoint, MediumProblem, RgbGrid,
    RgbGrids, UniformGrid,
};

/// The kinds of medium, and those that take each kind-specific key.
const KINDS: &[&str] = &["homogeneous", "uniformgrid", "rgbgrid", "nanovdb"];
const GRIDS: &[&str] = &["uniformgrid", "rgbgrid"];
const PLACED: &[&str] = &["uniformgrid", "rgbgrid", "nanovdb"];
const UNIFORM: &[&str] = &["uniformgrid"];
const RGB: &[&str] = &["rgbgrid"];
const NANO: &[&str] = &["nanovdb"];
const PLAIN: &[&str] = &["homogeneous", "uniformgrid", "nanovdb"];

impl Builder<'_> {
    /// A `[media.NAME]` table.
    pub(super) fn medium(
        &self,
        site: &Site,
        name: String,
        mut desc: MediumDesc,
    ) -> crate::error::Result<Medium> {
        let ctx = self.ctx;
        let fail = |key: &'static str| move |m: String| ctx.fail(site, key, m);
        // The constructors name the field their problem is about.
        let blame = |p: MediumProblem| ctx.fail(site, p.field, p.message);
        let scale = desc.scale.unwrap_or(1.0);
        if !(scale.is_finite() && scale >= 0.0) {
            return Err(fail("scale")(format!(
                "must be finite and not negative, got {scale}"
            )));
        }
        let unit = MediumPoint {
            sigma_a: desc.sigma_a.map_or(Rgb::ONE, |c| c.0) * scale,
            sigma_s: desc.sigma_s.map_or(Rgb::ONE, |c| c.0) * scale,
            le: desc.emission.map_or(Rgb::ZERO, |c| c.0),
            g: desc.g.unwrap_or(0.0),
        };
        let transform = desc.transform.take();
        // Keys that only some kinds take.
        let present = [
            ("resolution", desc.resolution.is_some(), GRIDS),
            ("density", desc.density.is_some(), UNIFORM),
            ("emission_scale", desc.emission_scale.is_some(), UNIFORM),
            ("bounds", desc.bounds.is_some(), GRIDS),
            ("transform", transform.is_some(), PLACED),
            ("file", desc.file.is_some(), NANO),
            ("grid", desc.grid.is_some(), NANO),
            ("sigma_a_grid", desc.sigma_a_grid.is_some(), RGB),
            ("sigma_s_grid", desc.sigma_s_grid.is_some(), RGB),
            ("emission_grid", desc.emission_grid.is_some(), RGB),
            ("sigma_a", desc.sigma_a.is_some(), PLAIN),
            ("sigma_s", desc.sigma_s.is_some(), PLAIN),
            ("emission", desc.emission.is_some(), PLAIN),
        ];
        let kind = desc.kind.as_str();
        if let Some((key, _, takers)) = present
            .iter()
            .find(|(_, given, takers)| *given && KINDS.contains(&kind) && !takers.contains(&kind))
        {
            let a = |k: &str| if k == "rgbgrid" { "an" } else { "a" };
            return Err(ctx.fail(
                site,
                key,
                format!(
                    "{} {kind} medium does not take it (only {} {} does)",
                    a(kind),
                    a(takers[0]),
                    takers.join(" or ")
                ),
            ));
        }
        let grid_place = |desc: &MediumDesc, transform| -> crate::error::Result<_> {
            let Some(res) = desc.resolution else {
                return Err(fail("resolution")(format!(
                    "a {kind} needs `resolution = [nx, ny, nz]`"
                )));
            };
            let [lo, hi] = desc
                .bounds
                .map_or([Vec3::ZERO, Vec3::ONE], |[a, b]| [a.0, b.0]);
            let xf = self.transform(site, transform)?;
            Ok((res.0.map(|n| n as usize), (lo, hi), xf.m))
        };
        let kind = match kind {
            "homogeneous" => MediumKind::Homogeneous(
                Homogeneous::new(unit.sigma_a, unit.sigma_s, unit.le, unit.g).map_err(blame)?,
            ),
            "uniformgrid" => {
                let (res, bounds, to_world) = grid_place(&desc, transform)?;
                let Some(density) = desc.density else {
                    return Err(fail("density")("a uniformgrid needs `density`".into()));
                };
                MediumKind::UniformGrid(Box::new(
                    UniformGrid::new(unit, res, density, desc.emission_scale, bounds, to_world)
                        .map_err(blame)?,
                ))
            }
            "rgbgrid" => {
                let (res, bounds, to_world) = grid_place(&desc, transform)?;
                let colours = |key: &'static str, v: Option<Vec<f32>>| match v {
                    Some(v) if v.len() % 3 != 0 => Err(fail(key)(format!(
                        "takes three numbers a sample, got {} numbers",
                        v.len()
                    ))),
                    Some(v) => Ok(Some(
                        v.chunks_exact(3)
                            .map(|c| Rgb::new(c[0], c[1], c[2]))
                            .collect(),
                    )),
                    None => Ok(None),
                };
                let grids = RgbGrids {
                    sigma_a: colours("sigma_a_grid", desc.sigma_a_grid)?,
                    sigma_s: colours("sigma_s_grid", desc.sigma_s_grid)?,
                    le: colours("emission_grid", desc.emission_grid)?,
                };
                MediumKind::RgbGrid(Box::new(
                    RgbGrid::new(grids, scale, unit.g, res, bounds, to_world).map_err(blame)?,
                ))
            }
            "nanovdb" => {
                let Some(file) = &desc.file else {
                    return Err(fail("file")("a nanovdb medium needs `file`".into()));
                };
                let grid = desc.grid.as_deref().unwrap_or("density");
                let path = self.dir.join(file);
                self.inputs.borrow_mut().push(path.clone());
                let read = nanovdb::read(&path, &[grid], &self.allowance())
                    .map_err(|e| fail("file")(e.to_string()))?;
                let Some(g) = read.into_iter().next().flatten() else {
                    return Err(fail("grid")(format!(
                        "{}: has no grid named \"{grid}\"",
                        path.display()
                    )));
                };
                self.hold_bytes(g.bytes());
                let xf = self.transform(site, transform)?;
                let source = SparseSource {
                    file: path.clone(),
                    grid: grid.to_string(),
                    transform: xf.m,
                };
                nanovdb::medium(g, unit, source).map_err(blame)?
            }
            other => {
                return Err(fail("type")(format!(
                    "unknown medium type \"{other}\" (expected homogeneous, uniformgrid, \
                     rgbgrid or nanovdb)"
                )))
            }
        };
        Ok(Medium { name, kind })
    }

    /// The medium a name gives (`""`: vacuum), at `key` of `site`.
    pub(super) fn medium_index(
        &self,
        site: &Site,
        key: &str,
        name: &str,
    ) -> crate::error::Result<Option<u32>> {
        if name.is_empty() {
            return Ok(None);
        }
        match self.medium_names.get(name) {
            Some(&i) => Ok(Some(i)),
            None => Err(self
                .ctx
                .fail(site, key, format!("no medium named \"{name}\" in [media]"))),
        }
    }

    /// A shape's `media = { inside = "..", outside = ".." }`.
    pub(super) fn shape_media(
        &self,
        site: &Site,
        desc: Option<ShapeMediaDesc>,
    ) -> crate::error::Result<Option<MediumInterface>> {
        let Some(desc) = desc else {
            return Ok(None);
        };
        let inside = self.medium_index(site, "media", desc.inside.as_deref().unwrap_or(""))?;
        let outside = self.medium_index(site, "media", desc.outside.as_deref().unwrap_or(""))?;
        Ok(MediumInterface::between(inside, outside))
    }
}
