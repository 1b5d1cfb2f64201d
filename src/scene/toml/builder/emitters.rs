//! Emitters' spectra: a material's emission and a light's colour given as a blackbody's
//! temperature (`emission_temperature`, `temperature`), its luminance the number the scene
//! gives.

use super::Builder;
use crate::math::Rgb;
use crate::scene::toml::diagnostics::Site;
use crate::scene::toml::schema::DiffuseDesc;
use crate::scene::{Light, Texture};
use crate::spectrum::BlackbodyEmission;

impl Builder<'_> {
    /// A material's emission: its RGB, its texture if it varies, and its blackbody spectrum
    /// if it has a temperature (then `emission` is a number, the luminance).
    pub(super) fn emission(
        &self,
        site: &Site,
        desc: Option<DiffuseDesc>,
        temperature: Option<f32>,
    ) -> crate::error::Result<(Rgb, Option<Texture>, Option<BlackbodyEmission>)> {
        let emission = match desc {
            None => (Rgb::ZERO, None),
            Some(t) => match self.texture(site, "emission", t)? {
                Texture::Constant(c) => (c, None),
                t => (t.mean_value(), Some(t)),
            },
        };
        let Some(kelvin) = temperature else {
            return Ok((emission.0, emission.1, None));
        };
        let fail = |m: String| self.ctx.fail(site, "emission_temperature", m);
        let body = BlackbodyEmission::new(kelvin as f64).map_err(fail)?;
        match emission {
            (c, None) if c.x == c.y && c.y == c.z => Ok((c.x * body.rgb(), None, Some(body))),
            _ => Err(fail(
                "needs `emission` to be one number (the luminance), not a colour or texture".into(),
            )),
        }
    }

    /// `light` with the blackbody of `temperature`, if given: its intensity (irradiance)
    /// must be one number, the luminance, and becomes the blackbody's colour times it.
    pub(super) fn with_temperature(
        &self,
        site: &Site,
        mut light: Light,
        temperature: Option<f32>,
    ) -> crate::error::Result<Light> {
        let Some(kelvin) = temperature else {
            return Ok(light);
        };
        let fail = |m: String| self.ctx.fail(site, "temperature", m);
        let body = BlackbodyEmission::new(kelvin as f64).map_err(fail)?;
        let (value, spectrum, key) = match &mut light {
            Light::Point(l) => (&mut l.intensity, &mut l.spectrum, "intensity"),
            Light::Spot(l) => (&mut l.intensity, &mut l.spectrum, "intensity"),
            Light::Directional(l) => (&mut l.irradiance, &mut l.spectrum, "irradiance"),
            _ => {
                return Err(fail(
                    "applies to point, spot and directional lights (a goniometric light's \
                     colour is its image's)"
                        .into(),
                ))
            }
        };
        if value.x != value.y || value.y != value.z {
            return Err(fail(format!(
                "needs `{key}` to be one number (the luminance), not a colour"
            )));
        }
        *value = value.x * body.rgb();
        *spectrum = Some(body);
        Ok(light)
    }
}
