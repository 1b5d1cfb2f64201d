//! A material's `coating`: the coat's values checked, and the material's other keys made to
//! agree with it (the coat's mirror as Fresnel-weighted specular over a diffuse base, for
//! the techniques that approximate the layers).

use super::super::checks::{colour, non_negative, positive};
use super::super::diagnostics::Site;
use super::super::schema::{CoatingDesc, MaterialDesc, RoughnessDesc};
use super::Builder;
use crate::scene::materials::{Classic, CoatedConductor, CoatedDiffuse, Surface};
use crate::scene::Coating;

impl Builder<'_> {
    /// Rejects the keys a coated material cannot have, before it is built.
    pub(super) fn check_coated_keys(
        &self,
        site: &Site,
        desc: &MaterialDesc,
    ) -> crate::error::Result<()> {
        let conflicts = [
            ("transmission", desc.transmission.is_some()),
            ("diffuse_transmission", desc.diffuse_transmission.is_some()),
            ("ior", desc.ior.is_some()),
            ("fresnel", desc.fresnel.is_some()),
            ("thin", desc.thin.is_some()),
            // Over a diffuse base, the only roughness is the coat's.
            (
                "roughness",
                desc.roughness.is_some() && desc.conductor.is_none(),
            ),
        ];
        match conflicts.iter().find(|k| k.1) {
            Some((key, _)) => Err(self.ctx.fail(
                site,
                key,
                "a coated material takes no such key; set it in `coating` \
                 (ior, roughness) or use an uncoated material",
            )),
            None => Ok(()),
        }
    }

    /// The coating of `desc` over `m` (built from the other keys): a coated diffuse
    /// surface, or a coated metal when `m` has a conductor.
    pub(super) fn coated(
        &self,
        site: &Site,
        desc: CoatingDesc,
        m: Classic,
    ) -> crate::error::Result<Surface> {
        let fail = |key: &'static str| move |msg: String| self.ctx.fail(site, key, msg);
        let d = Coating::default();
        let (roughness, roughness_v) = match desc.roughness {
            None => (d.roughness, None),
            Some(RoughnessDesc::Isotropic(a)) => (a, None),
            Some(RoughnessDesc::Anisotropic(u, v)) => (u, Some(v)),
            Some(RoughnessDesc::Texture(_)) => {
                return Err(fail("coating.roughness")(
                    "takes a number or [u, v]: a coat's roughness cannot vary by texture".into(),
                ))
            }
        };
        let roughness = non_negative(roughness).map_err(fail("coating.roughness"))?;
        let roughness_v = match roughness_v {
            Some(v) => Some(non_negative(v).map_err(fail("coating.roughness"))?),
            None => None,
        };
        let albedo = match desc.albedo {
            None => d.albedo,
            Some(a) => colour(a.0).map_err(fail("coating.albedo"))?,
        };
        if albedo.max_element() > 1.0 {
            return Err(fail("coating.albedo")(format!(
                "must be at most 1, got {albedo}"
            )));
        }
        let g = desc.g.unwrap_or(d.g);
        if !(g > -1.0 && g < 1.0) {
            return Err(fail("coating.g")(format!(
                "must be within (-1, 1), got {g}"
            )));
        }
        let count = |v: Option<u32>, default: u32, key: &'static str| match v {
            None => Ok(default),
            Some(n) if (1..=1_000_000).contains(&n) => Ok(n),
            Some(n) => Err(fail(key)(format!("must be within 1..=1000000, got {n}"))),
        };
        let coating = Coating {
            ior: positive(desc.ior.unwrap_or(d.ior)).map_err(fail("coating.ior"))?,
            roughness,
            roughness_v,
            thickness: non_negative(desc.thickness.unwrap_or(d.thickness))
                .map_err(fail("coating.thickness"))?,
            albedo,
            g,
            max_depth: count(desc.max_depth, d.max_depth, "coating.max_depth")?,
            samples: count(desc.samples, d.samples, "coating.samples")?,
        };
        Ok(match m.conductor {
            None => Surface::CoatedDiffuse(CoatedDiffuse::new(m, coating)),
            // The metal's own roughness; its index is the coat's, as the reader always set.
            Some(_) => Surface::CoatedConductor(CoatedConductor::new(
                Classic {
                    ior: coating.ior,
                    fresnel: false,
                    ..m
                },
                coating,
            )),
        })
    }
}
