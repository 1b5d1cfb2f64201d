//! Lights: area lights attached to the shapes that follow, and point, distant and infinite
//! lights (an environment map or a constant background).

use super::params::Params;
use super::spectrum::Kind;
use super::state::AreaEmission;
use super::{Loader, Loc};
use crate::math::{Mat3, Rgb};
use crate::scene::environment::{Environment, Mapping};
use crate::scene::Light;
use glam::DVec3;
use std::path::PathBuf;
use std::sync::Arc;

impl Loader {
    pub(super) fn area_light(&mut self, ty: &str, p: &Params, loc: &Loc) -> crate::Result<()> {
        let st = format!("AreaLightSource \"{ty}\"");
        if ty != "diffuse" {
            self.warn(
                loc,
                format!("{st} is not supported; using a diffuse area light"),
            );
        }
        let l = self
            .spectrum(p, "L", Kind::Illuminant, &st, loc)?
            .unwrap_or(Rgb::ONE);
        let scale = p.float_or("scale", 1.0).map_err(Self::pe(loc))? as f32;
        if p.bool("twosided").map_err(Self::pe(loc))? == Some(true) {
            self.warn(
                loc,
                format!("{st}: two-sided emission is not supported; the light emits on the front side only"),
            );
        }
        let radiance = l * scale;
        if !radiance.is_finite() || radiance.min_element() < 0.0 {
            return Err(loc.error(format!(
                "{st}: the emitted radiance must be finite and not negative"
            )));
        }
        self.state.area = (radiance.max_element() > 0.0).then_some(AreaEmission { radiance });
        Ok(())
    }

    pub(super) fn light(&mut self, ty: &str, p: &Params, loc: &Loc) -> crate::Result<()> {
        let st = format!("LightSource \"{ty}\"");
        let st = st.as_str();
        let pe = Self::pe(loc);
        let m = self.mirror * self.state.ctm;
        let scale = p.float_or("scale", 1.0).map_err(&pe)? as f32;
        let point3 = |name: &str, default: DVec3| -> crate::Result<DVec3> {
            match p.floats(name, "point3").map_err(&pe)? {
                Some(v) if v.len() == 3 => Ok(DVec3::new(v[0], v[1], v[2])),
                Some(_) => Err(loc.error(format!("{st}: \"{name}\" takes one point"))),
                None => Ok(default),
            }
        };
        match ty {
            "point" | "spot" | "goniometric" | "projection" => {
                if ty != "point" {
                    self.warn(
                        loc,
                        format!("light \"{ty}\" is not supported; using a point light"),
                    );
                    for q in ["coneangle", "conedelta", "to", "filename", "fov"] {
                        p.ignore(q);
                    }
                }
                let from = point3("from", DVec3::ZERO)?;
                let i = self
                    .spectrum(p, "I", Kind::Illuminant, st, loc)?
                    .unwrap_or(Rgb::ONE);
                self.lights.push(Light::Point {
                    position: m.transform_point3(from).as_vec3(),
                    intensity: i * scale,
                });
            }
            "distant" => {
                let from = point3("from", DVec3::ZERO)?;
                let to = point3("to", DVec3::Z)?;
                let dir = m.transform_vector3(to - from).normalize_or_zero();
                if dir == DVec3::ZERO {
                    return Err(loc.error(format!("{st}: \"from\" and \"to\" must differ")));
                }
                let l = self
                    .spectrum(p, "L", Kind::Illuminant, st, loc)?
                    .unwrap_or(Rgb::ONE);
                self.lights.push(Light::Directional {
                    direction: dir.as_vec3(),
                    irradiance: l * scale,
                });
            }
            "infinite" => {
                let file = p.string("filename").map_err(&pe)?;
                let l = self.spectrum(p, "L", Kind::Illuminant, st, loc)?;
                match (file, l) {
                    (Some(_), Some(_)) => {
                        return Err(
                            loc.error(format!("{st}: give either \"L\" or \"filename\", not both"))
                        )
                    }
                    (Some(file), None) => {
                        if self.environment.is_some() {
                            self.warn(loc, format!("{st}: only one environment map is supported; the last one is used"));
                        }
                        let path = loc.dir().join(&file);
                        self.add_input(&path);
                        let transform = Mat3::from_cols(
                            m.x_axis.truncate().as_vec3(),
                            m.y_axis.truncate().as_vec3(),
                            m.z_axis.truncate().as_vec3(),
                        );
                        let (env, mapping) = Environment::load_with_mapping(
                            &path,
                            PathBuf::from(&file),
                            transform,
                            Rgb::splat(scale),
                        )
                        .map_err(|e| loc.error(format!("{st}: {e}")))?;
                        if mapping == Mapping::LatLong {
                            self.warn(loc, format!("{st}: \"{file}\" is a lat-long image, converted to the equal-area mapping (pbrt-v4 itself needs `imgtool makeequiarea`)"));
                        }
                        self.environment = Some(Arc::new(env));
                    }
                    (None, l) => self.background += l.unwrap_or(Rgb::ONE) * scale,
                }
            }
            _ => {
                for q in &p.list {
                    p.ignore(&q.name);
                }
                self.warn(loc, format!("light \"{ty}\" is not supported; ignored"));
            }
        }
        Ok(())
    }
}
