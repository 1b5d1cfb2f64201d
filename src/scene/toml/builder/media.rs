//! The builder's media: `[media.NAME]` tables, and the names shapes and the camera give.

use super::super::diagnostics::Site;
use super::super::schema::{MediumDesc, ShapeMediaDesc};
use super::Builder;
use crate::math::{Rgb, Vec3};
use crate::scene::media::{
    Homogeneous, Medium, MediumInterface, MediumKind, MediumPoint, UniformGrid,
};

impl Builder<'_> {
    /// A `[media.NAME]` table.
    pub(super) fn medium(
        &self,
        site: &Site,
        name: String,
        desc: MediumDesc,
    ) -> crate::error::Result<Medium> {
        let ctx = self.ctx;
        let fail = |key: &'static str| move |m: String| ctx.fail(site, key, m);
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
        // The message names the key it is about.
        let key_of = |m: &str| match m.split_whitespace().next() {
            Some("sigma_a") => "sigma_a",
            Some("sigma_s") => "sigma_s",
            Some("Le") => "emission",
            Some("g") => "g",
            Some("density") => "density",
            Some("Lescale") => "emission_scale",
            _ => "",
        };
        let grid_keys = [
            ("resolution", desc.resolution.is_some()),
            ("density", desc.density.is_some()),
            ("emission_scale", desc.emission_scale.is_some()),
            ("bounds", desc.bounds.is_some()),
            ("transform", desc.transform.is_some()),
        ];
        let kind = match desc.kind.as_str() {
            "homogeneous" => {
                if let Some((key, _)) = grid_keys.iter().find(|(_, present)| *present) {
                    return Err(ctx.fail(
                        site,
                        key,
                        "a homogeneous medium does not take it (only a uniformgrid does)",
                    ));
                }
                MediumKind::Homogeneous(
                    Homogeneous::new(unit.sigma_a, unit.sigma_s, unit.le, unit.g)
                        .map_err(|m| ctx.fail(site, key_of(&m), m))?,
                )
            }
            "uniformgrid" => {
                let Some(res) = desc.resolution else {
                    return Err(fail("resolution")(
                        "a uniformgrid needs `resolution = [nx, ny, nz]`".into(),
                    ));
                };
                let res = res.0.map(|n| n as usize);
                let Some(density) = desc.density else {
                    return Err(fail("density")("a uniformgrid needs `density`".into()));
                };
                let [lo, hi] = desc
                    .bounds
                    .map_or([Vec3::ZERO, Vec3::ONE], |[a, b]| [a.0, b.0]);
                let xf = self.transform(site, desc.transform)?;
                MediumKind::UniformGrid(Box::new(
                    UniformGrid::new(unit, res, density, desc.emission_scale, (lo, hi), xf.m)
                        .map_err(|m| {
                            let key = match key_of(&m) {
                                "" if m.contains("box") => "bounds",
                                "" if m.contains("transform") => "transform",
                                "" if m.starts_with("a grid of") => "resolution",
                                "" => "resolution",
                                k => k,
                            };
                            ctx.fail(site, key, m)
                        })?,
                ))
            }
            other => {
                return Err(fail("type")(format!(
                    "unknown medium type \"{other}\" (expected homogeneous or uniformgrid)"
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
