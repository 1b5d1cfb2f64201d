//! Lights: area lights attached to the shapes that follow, and point, spot, goniometric,
//! distant and infinite lights (an environment map or a constant background).

use super::builder::Builder;
use super::params::Params;
use super::spectrum::Kind;
use super::state::AreaEmission;
use super::Loc;
use crate::image::Image;
use crate::math::{Mat3, Rgb};
use crate::scene::camera::show;
use crate::scene::environment::{Environment, Mapping};
use crate::scene::lights::{
    check_cone_width, spot_cosines, spot_solid_angle, DirectionalLight, GoniometricLight,
    GoniometricMap, PointLight, ProjectionLight, SpotLight,
};
use crate::scene::texture::{Encoding, ImageTexture, UvMapping};
use crate::scene::{Light, Portal, Texture, MAX_COORDINATE};
use glam::DVec3;
use std::path::PathBuf;
use std::sync::Arc;

impl Builder {
    pub(super) fn area_light(
        &mut self,
        ty: &str,
        p: &Params,
        loc: &Loc,
    ) -> crate::error::Result<()> {
        let st = format!("AreaLightSource \"{ty}\"");
        if ty != "diffuse" {
            self.warn(
                loc,
                format!("{st} is not supported; using a diffuse area light"),
            );
        }
        let scale = p.float_or("scale", 1.0).map_err(Self::pe(loc))? as f32;
        let two_sided = p.bool("twosided").map_err(Self::pe(loc))? == Some(true);
        let l = self.spectrum(p, "L", Kind::Illuminant, &st, loc)?;
        let file = p.string("filename").map_err(Self::pe(loc))?;
        // pbrt-v4's image-textured emitter: Le(uv) = scale × the image at uv.
        let texture = match (file, l) {
            (Some(_), Some(_)) => {
                return Err(loc.error(format!("{st}: give either \"L\" or \"filename\", not both")))
            }
            (Some(file), None) if !self.find_input(&loc.dir().join(&file), &st, &file, loc) => None,
            (Some(file), None) => {
                let path = loc.dir().join(&file);
                let image = ImageTexture::load_within(
                    &path,
                    PathBuf::from(&file),
                    Encoding::default_for(&path),
                    scale,
                    false,
                    UvMapping::default(),
                    &self.allowance(),
                )
                .map_err(|e| loc.error(format!("{st}: {e}")))?;
                self.held.add_image(image.image());
                Some(Texture::Image(Arc::new(image)))
            }
            (None, _) => None,
        };
        let radiance = match &texture {
            Some(t) => t.mean_value(),
            None => l.unwrap_or(Rgb::ONE) * scale,
        };
        if !radiance.is_finite() || radiance.min_element() < 0.0 {
            return Err(loc.error(format!(
                "{st}: the emitted radiance must be finite and not negative"
            )));
        }
        let radiance = self.area_key(radiance, two_sided, texture);
        self.state.area = (radiance.max_element() > 0.0).then_some(AreaEmission {
            radiance,
            two_sided,
            spectrum: self.blackbody(p, "L", loc)?,
        });
        Ok(())
    }

    /// The radiance that names an area light among those of the file: its own, moved by
    /// the least amount needed to tell a textured light from every other, plain or
    /// textured (the graphics state carries the radiance, emissive copies are shared by
    /// it, and the texture is found by it in `area_textures`).
    fn area_key(&mut self, mut radiance: Rgb, two_sided: bool, texture: Option<Texture>) -> Rgb {
        let key = |r: Rgb| (r.to_array().map(f32::to_bits), two_sided);
        while let Some(t) = self.area_textures.get(&key(radiance)) {
            if *t == texture {
                return radiance;
            }
            radiance.z = f32::from_bits(radiance.z.to_bits() + 1);
        }
        self.area_textures.insert(key(radiance), texture);
        radiance
    }

    /// The image a light's `filename` names (goniometric, projection), read and recorded
    /// as an input; the name as the file gives it.
    fn light_image(
        &mut self,
        p: &Params,
        st: &str,
        loc: &Loc,
    ) -> crate::error::Result<(String, Image)> {
        let file = p
            .string("filename")
            .map_err(Self::pe(loc))?
            .ok_or_else(|| loc.error(format!("{st} needs a \"string filename\"")))?;
        let path = loc.dir().join(&file);
        if !self.find_input(&path, st, &file, loc) {
            // Reading goes on to find the other missing files; the scene is refused.
            return Ok((file, Image::new(1, 1)));
        }
        let (image, _) = crate::image::output::read_image_within(&path, &self.allowance())
            .map_err(|e| loc.error(format!("{st}: {e}")))?;
        self.held.add_image(&image);
        Ok((file, image))
    }

    /// An infinite light's `"point3 portal"`: four corners in world space (pbrt-v4 does not
    /// apply the light's transform to them).
    fn portal(&self, p: &Params, st: &str, loc: &Loc) -> crate::error::Result<Option<Portal>> {
        let Some(v) = p.floats("portal", "point3").map_err(Self::pe(loc))? else {
            return Ok(None);
        };
        if v.len() != 12 {
            return Err(loc.error(format!(
                "{st}: \"portal\" takes four points, got {} numbers",
                v.len()
            )));
        }
        let mut corners = [0, 1, 2, 3].map(|k| {
            self.mirror
                .transform_point3(DVec3::from_slice(&v[3 * k..]))
                .as_vec3()
        });
        // A mirrored world turns the corners' order around; keep the portal facing out.
        if self.mirror.determinant() < 0.0 {
            corners.swap(1, 3);
        }
        Portal::new(corners)
            .map(Some)
            .map_err(|m| loc.error(format!("{st}: \"portal\": {m}")))
    }

    pub(super) fn light(&mut self, ty: &str, p: &Params, loc: &Loc) -> crate::error::Result<()> {
        let st = format!("LightSource \"{ty}\"");
        let st = st.as_str();
        let pe = Self::pe(loc);
        let m = self.mirror * self.state.ctm;
        let scale = p.float_or("scale", 1.0).map_err(&pe)? as f32;
        // The light's frame: its directions to the world's.
        let frame = Mat3::from_cols(
            m.x_axis.truncate().as_vec3(),
            m.y_axis.truncate().as_vec3(),
            m.z_axis.truncate().as_vec3(),
        );
        let point3 = |name: &str, default: DVec3| -> crate::error::Result<DVec3> {
            match p.floats(name, "point3").map_err(&pe)? {
                Some(v) if v.len() == 3 => Ok(DVec3::new(v[0], v[1], v[2])),
                Some(_) => Err(loc.error(format!("{st}: \"{name}\" takes one point"))),
                None => Ok(default),
            }
        };
        // Every quantity the light is made of, checked where it is made, naming the field.
        let place = |field: &str, local: DVec3| -> crate::error::Result<crate::math::Vec3> {
            let p = m.transform_point3(local).as_vec3();
            if p.is_finite() && p.abs().max_element() <= MAX_COORDINATE {
                return Ok(p);
            }
            Err(loc.error(format!(
                "{st}: {field} puts the light at {}, outside the range raylink traces \
                 ({MAX_COORDINATE:e} units of the origin)",
                show(p)
            )))
        };
        let aim = |from: DVec3, to: DVec3| -> crate::error::Result<crate::math::Vec3> {
            let d = m.transform_vector3(to - from);
            let length = d.length();
            if !length.is_finite() {
                return Err(loc.error(format!(
                    "{st}: \"from\" and \"to\" are too far apart: the direction between \
                     them overflows"
                )));
            }
            let dir = (d / length).as_vec3();
            if length == 0.0 || !dir.is_finite() {
                return Err(loc.error(format!("{st}: \"from\" and \"to\" must differ")));
            }
            Ok(dir)
        };
        let emitted = |fields: &str, v: Rgb| -> crate::error::Result<Rgb> {
            if v.is_finite() {
                Ok(v)
            } else {
                Err(loc.error(format!(
                    "{st}: the emitted power ({fields}) overflows single precision"
                )))
            }
        };
        match ty {
            "goniometric" => {
                // pbrt-v4's GoniometricLight: at the origin of the light's space, its
                // intensity I × scale × the image's value, the image's pole the light's +y.
                let (file, image) = self.light_image(p, st, loc)?;
                let map = GoniometricMap::new(PathBuf::from(&file), &image, frame)
                    .map_err(|e| loc.error(format!("{st}: \"{file}\": {e}")))?;
                let i = self
                    .spectrum(p, "I", Kind::Illuminant, st, loc)?
                    .unwrap_or(Rgb::ONE);
                // pbrt-v4: `power` divides by k_e = 4π × the image's mean.
                let power = p.float_or("power", -1.0).map_err(&pe)? as f32;
                let k = if power > 0.0 && map.mean() > 0.0 {
                    power / (4.0 * std::f32::consts::PI * map.mean())
                } else {
                    1.0
                };
                self.lights.push(Light::Goniometric(GoniometricLight {
                    position: place("the transform", DVec3::ZERO)?,
                    intensity: emitted("\"I\" × \"scale\" × \"power\"", i * scale * k)?,
                    map: Arc::new(map),
                }));
            }
            "projection" => {
                // pbrt-v4's ProjectionLight: the image over `fov` degrees down the light's
                // +z, at the origin of its transform, times `scale` (or rescaled to `power`).
                let (file, image) = self.light_image(p, st, loc)?;
                let fov = p.float_or("fov", 90.0).map_err(&pe)? as f32;
                let position = place("the transform", DVec3::ZERO)?;
                emitted("\"scale\"", Rgb::splat(scale))?;
                let light =
                    ProjectionLight::new(position, frame, PathBuf::from(&file), &image, scale, fov)
                        .map_err(|e| loc.error(format!("{st}: \"{file}\": {e}")))?;
                let power = p.float_or("power", -1.0).map_err(&pe)? as f32;
                let light = if power > 0.0 {
                    light.with_power(power)
                } else {
                    light
                };
                emitted("\"scale\" × \"power\"", Rgb::splat(light.scale))?;
                self.lights.push(Light::Projection(light));
            }
            "point" => {
                let from = point3("from", DVec3::ZERO)?;
                let i = self
                    .spectrum(p, "I", Kind::Illuminant, st, loc)?
                    .unwrap_or(Rgb::ONE);
                // pbrt-v4: `power` sets the intensity to power / 4π (times I's colour).
                let power = p.float_or("power", -1.0).map_err(&pe)? as f32;
                let k = if power > 0.0 {
                    power / (4.0 * std::f32::consts::PI)
                } else {
                    1.0
                };
                self.lights.push(Light::Point(PointLight {
                    position: place("\"from\"", from)?,
                    intensity: emitted("\"I\" × \"scale\" × \"power\"", i * scale * k)?,
                    spectrum: self.blackbody(p, "I", loc)?,
                }));
            }
            "spot" => {
                let from = point3("from", DVec3::ZERO)?;
                let to = point3("to", DVec3::Z)?;
                let dir = aim(from, to)?;
                let position = place("\"from\"", from)?;
                let cone_angle = p.float_or("coneangle", 30.0).map_err(&pe)? as f32;
                let cone_delta = p.float_or("conedelta", 5.0).map_err(&pe)? as f32;
                let valid = cone_angle > 0.0
                    && cone_angle <= 180.0
                    && (0.0..=cone_angle).contains(&cone_delta);
                if !valid {
                    return Err(loc.error(format!(
                        "{st}: coneangle must be in (0, 180] and conedelta in [0, coneangle], got {cone_angle} and {cone_delta}"
                    )));
                }
                check_cone_width(cone_angle)
                    .map_err(|e| loc.error(format!("{st}: coneangle {e}")))?;
                let i = self
                    .spectrum(p, "I", Kind::Illuminant, st, loc)?
                    .unwrap_or(Rgb::ONE);
                // pbrt-v4: `power` sets the intensity to power / k_e with k_e the cone's
                // falloff-weighted solid angle.
                let power = p.float_or("power", -1.0).map_err(&pe)? as f32;
                let k = if power > 0.0 {
                    let (cos_start, cos_end) = spot_cosines(cone_angle, cone_delta);
                    power / spot_solid_angle(cos_start, cos_end)
                } else {
                    1.0
                };
                let mut spot = SpotLight::new(
                    position,
                    dir,
                    emitted("\"I\" × \"scale\" × \"power\"", i * scale * k)?,
                    cone_angle,
                    cone_delta,
                );
                spot.spectrum = self.blackbody(p, "I", loc)?;
                self.lights.push(Light::Spot(spot));
            }
            "distant" => {
                let from = point3("from", DVec3::ZERO)?;
                let to = point3("to", DVec3::Z)?;
                let dir = aim(from, to)?;
                let l = self
                    .spectrum(p, "L", Kind::Illuminant, st, loc)?
                    .unwrap_or(Rgb::ONE);
                let mut distant =
                    DirectionalLight::new(dir, emitted("\"L\" × \"scale\"", l * scale)?);
                distant.spectrum = self.blackbody(p, "L", loc)?;
                self.lights.push(Light::Directional(distant));
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
                        if !self.find_input(&path, st, &file, loc) {
                            return Ok(());
                        }
                        let (mut env, mapping) = Environment::load_with_mapping(
                            &path,
                            PathBuf::from(&file),
                            frame,
                            Rgb::splat(scale),
                            &self.allowance(),
                        )
                        .map_err(|e| loc.error(format!("{st}: {e}")))?;
                        env.portal = self.portal(p, st, loc)?;
                        self.held.add_image(&env.image);
                        if mapping == Mapping::LatLong {
                            self.warn(loc, format!("{st}: \"{file}\" is a lat-long image, converted to the equal-area mapping (pbrt-v4 itself needs `imgtool makeequiarea`)"));
                        }
                        self.environment = Some(Arc::new(env));
                    }
                    (None, l) => {
                        if p.floats("portal", "point3").map_err(&pe)?.is_some() {
                            return Err(loc.error(format!(
                                "{st}: a \"portal\" needs an environment map (\"filename\")"
                            )));
                        }
                        let l = emitted("\"L\" × \"scale\"", l.unwrap_or(Rgb::ONE) * scale)?;
                        self.background =
                            emitted("the sum of the infinite lights", self.background + l)?;
                    }
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
