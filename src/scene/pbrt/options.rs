//! The rendering options before WorldBegin (camera, film, sampler, filter, integrator), and
//! raylink's camera made from pbrt's at WorldBegin.

use super::builder::Builder;
use super::params::Params;
use super::Loc;
use crate::image::filter::Filter;
use crate::scene::{Camera, Projection, SettingSource, MAX_RESOLUTION};
use crate::settings::{TechniqueKind, MAX_SPP};
use crate::spectrum::ColorSpace;
use glam::{DMat3, DMat4, DVec3};

pub(super) struct CameraDef {
    camera_to_world: DMat4,
    fov: f64,
    /// `lensradius`, `focaldistance` (perspective).
    lens: (f64, f64),
    /// `screenwindow` of an orthographic camera (x0, x1, y0, y1); `None` for perspective.
    /// An empty window stands for pbrt's default, set from the film's aspect at WorldBegin.
    orthographic: Option<Vec<f64>>,
    loc: Loc,
}

impl Builder {
    /// Records that the statement at `loc` (`key`, as the file writes it) gives `setting`.
    fn given(&mut self, setting: &'static str, key: &str, loc: &Loc) {
        let file = (*loc.file != self.source).then(|| loc.file.to_path_buf());
        self.setting_sources.retain(|s| s.setting != setting);
        self.setting_sources.push(SettingSource {
            setting,
            key: key.to_string(),
            line: loc.line as usize,
            file,
        });
    }

    /// pbrt-v4's SPPM parameters: `photonsperiteration` (-1, pbrt's default, is the pixel
    /// count) and `radius`.
    fn sppm_options(&mut self, p: &Params, loc: &Loc) -> crate::error::Result<()> {
        let pe = |e| loc.param_error(e);
        if let Some(n) = p.int("photonsperiteration").map_err(pe)? {
            if n != -1 {
                if !(1..=u32::MAX as i64).contains(&n) {
                    return Err(loc.error(format!(
                        "Integrator \"sppm\": photonsperiteration must be positive (or -1 for \
                         the pixel count), got {n}"
                    )));
                }
                self.settings.photons_per_iteration = Some(n as u32);
                self.given(
                    "photons_per_iteration",
                    "Integrator \"photonsperiteration\"",
                    loc,
                );
            }
        }
        if let Some(r) = p.float("radius").map_err(pe)? {
            if !(r.is_finite() && r > 0.0 && r <= f32::MAX as f64) {
                return Err(loc.error(format!(
                    "Integrator \"sppm\": radius must be a positive number, got {r}"
                )));
            }
            self.settings.sppm_radius = Some(r as f32);
            self.given("sppm_radius", "Integrator \"radius\"", loc);
        }
        Ok(())
    }

    pub(super) fn set_option(
        &mut self,
        kw: &str,
        ty: &str,
        _value: Option<String>,
        p: &Params,
        loc: &Loc,
    ) -> crate::error::Result<()> {
        let pe = |e| loc.param_error(e);
        match kw {
            "Camera" => {
                let orthographic = ty == "orthographic";
                if !orthographic && ty != "perspective" {
                    self.warn(
                        loc,
                        format!("Camera \"{ty}\" is not supported; using a perspective camera"),
                    );
                }
                let fov = p.float_or("fov", 90.0).map_err(pe)?;
                if !(fov > 0.0 && fov < 180.0) {
                    return Err(loc.error(format!(
                        "Camera: fov must be in (0, 180) degrees, got {fov}"
                    )));
                }
                let open = p.float_or("shutteropen", 0.0).map_err(pe)?;
                let close = p.float_or("shutterclose", 1.0).map_err(pe)?;
                if !(open.is_finite() && close.is_finite() && open <= close) {
                    return Err(loc.error(format!(
                        "Camera: shutteropen must not be after shutterclose, got {open} and {close}"
                    )));
                }
                self.timing.shutter = (open, close);
                self.camera_medium = self.state.media.1.clone();
                if self.state.end_ctm != self.state.ctm {
                    self.warn(
                        loc,
                        "Camera: a moving camera is not supported; it stays where it is at the \
                         start time",
                    );
                }
                let lens_radius = p.float_or("lensradius", 0.0).map_err(pe)?;
                let focal_distance = p.float_or("focaldistance", 1e6).map_err(pe)?;
                if !(lens_radius >= 0.0 && lens_radius.is_finite()) {
                    return Err(loc.error(format!(
                        "Camera: lensradius must be finite and not negative, got {lens_radius}"
                    )));
                }
                if !(focal_distance > 0.0 && focal_distance.is_finite()) {
                    return Err(loc.error(format!(
                        "Camera: focaldistance must be positive, got {focal_distance}"
                    )));
                }
                if orthographic && lens_radius > 0.0 {
                    self.warn(
                        loc,
                        "Camera \"orthographic\": depth of field (lensradius) is not supported; all in focus",
                    );
                }
                let window = p
                    .floats("screenwindow", "float")
                    .map_err(pe)?
                    .map(<[f64]>::to_vec);
                let orthographic = if orthographic {
                    let window = window.unwrap_or_default();
                    if !window.is_empty()
                        && (window.len() != 4
                            || !window.iter().all(|v| v.is_finite())
                            || window[1] <= window[0]
                            || window[3] <= window[2])
                    {
                        return Err(loc.error(
                            "Camera: screenwindow must be 4 finite numbers [x0 x1 y0 y1] with x0 < x1 and y0 < y1",
                        ));
                    }
                    Some(window)
                } else {
                    if window.is_some() {
                        self.warn(
                            loc,
                            "Camera \"perspective\": \"screenwindow\" is not supported; ignored",
                        );
                    }
                    None
                };
                let ctm = self.state.ctm;
                if !ctm.is_finite() || !ctm.determinant().is_finite() {
                    return Err(loc.error("Camera: the camera transform overflows (not finite)"));
                }
                if ctm.determinant().abs() < 1e-12 {
                    return Err(loc.error("Camera: the camera transform is singular"));
                }
                let camera_to_world = ctm.inverse();
                self.coordinate_systems
                    .insert("camera".into(), camera_to_world);
                self.camera = Some(CameraDef {
                    camera_to_world,
                    fov,
                    lens: (lens_radius, focal_distance),
                    orthographic,
                    loc: loc.clone(),
                });
            }
            "Film" => {
                let space = self.state.color_space;
                self.film_color_space = (space != ColorSpace::srgb()).then_some(space);
                if !matches!(ty, "rgb" | "gbuffer" | "spectral") {
                    self.warn(
                        loc,
                        format!("Film \"{ty}\" is not supported; using an RGB film"),
                    );
                }
                let res = |name: &str, default: u32| -> crate::error::Result<u32> {
                    let v = p.int(name).map_err(|e| loc.param_error(e))?;
                    match v {
                        None => Ok(default),
                        Some(v) if (1..=MAX_RESOLUTION as i64).contains(&v) => Ok(v as u32),
                        Some(v) => Err(loc.error(format!(
                            "Film: {name} must be between 1 and {MAX_RESOLUTION}, got {v}"
                        ))),
                    }
                };
                self.resolution = (res("xresolution", 1280)?, res("yresolution", 720)?);
                // pbrt-v4 clamps every sample to this (infinite: no clamping).
                if let Some(m) = p.float("maxcomponentvalue").map_err(pe)? {
                    if m.is_nan() || m <= 0.0 {
                        return Err(
                            loc.error(format!("Film: maxcomponentvalue must be positive, got {m}"))
                        );
                    }
                    if m < f32::MAX as f64 {
                        self.settings.max_component_value = Some(m as f32);
                        self.given("max_component_value", "Film \"maxcomponentvalue\"", loc);
                    }
                }
                // The output when the command line names none.
                if let Some(f) = p.string("filename").map_err(pe)? {
                    if f.is_empty() {
                        return Err(loc.error("Film: filename is empty"));
                    }
                    self.output = Some(std::path::PathBuf::from(f));
                }
            }
            "Sampler" => {
                // raylink has its own sample patterns; the sample count carries over.
                if let Some(n) = p.int("pixelsamples").map_err(pe)? {
                    if !(1..=MAX_SPP as i64).contains(&n) {
                        return Err(loc.error(format!(
                            "Sampler: pixelsamples must be between 1 and {MAX_SPP}, got {n}"
                        )));
                    }
                    self.settings.spp = Some(n as u32);
                    self.given("spp", "Sampler \"pixelsamples\"", loc);
                }
            }
            "PixelFilter" => {
                let x = p.float("xradius").map_err(pe)?;
                let y = p.float("yradius").map_err(pe)?;
                let r = |default: f64| x.unwrap_or(default).max(y.unwrap_or(default)) as f32;
                let filter = match ty {
                    "box" => Filter::Box { radius: r(0.5) },
                    "triangle" => Filter::Triangle { radius: r(2.0) },
                    "gaussian" => Filter::Gaussian {
                        radius: r(1.5),
                        sigma: p.float_or("sigma", 0.5).map_err(pe)? as f32,
                    },
                    _ => {
                        for name in ["B", "C", "tau"] {
                            p.ignore(name);
                        }
                        self.warn(
                            loc,
                            format!(
                                "PixelFilter \"{ty}\" is not supported; using the default \
                                 Gaussian (radius 1.5, sigma 0.5)"
                            ),
                        );
                        Filter::default()
                    }
                };
                filter
                    .validate()
                    .map_err(|m| loc.error(format!("PixelFilter: {m}")))?;
                self.settings.filter = Some(filter);
                self.given("filter", "PixelFilter", loc);
            }
            "Integrator" => {
                let name = match ty {
                    "volpath" | "path" | "simplepath" => TechniqueKind::Path,
                    "bdpt" => TechniqueKind::Bdpt,
                    "lighttracer" => TechniqueKind::Light,
                    "sppm" => TechniqueKind::Sppm,
                    _ => {
                        self.warn(
                            loc,
                            format!("Integrator \"{ty}\" is not supported; using the path tracer"),
                        );
                        TechniqueKind::Path
                    }
                };
                self.settings.integrator = Some(name);
                self.given("integrator", "Integrator", loc);
                if let Some(d) = p.int("maxdepth").map_err(pe)? {
                    if d < 0 {
                        return Err(loc.error(format!(
                            "Integrator: maxdepth must not be negative, got {d}"
                        )));
                    }
                    self.settings.max_depth = Some(d.min(u32::MAX as i64) as u32);
                    self.given("max_depth", "Integrator \"maxdepth\"", loc);
                } else {
                    self.settings.max_depth = Some(5);
                }
                if ty == "sppm" {
                    self.sppm_options(p, loc)?;
                }
            }
            "Accelerator" => {
                for q in &p.list {
                    p.ignore(&q.name);
                }
            }
            "ColorSpace" => {
                self.state.color_space = crate::image::output::color_space_named(ty)
                    .map_err(|why| loc.error(format!("ColorSpace: {why}")))?;
            }
            "Option" => {
                self.warn(loc, format!("Option \"{ty}\" is not supported; ignored"));
            }
            _ => {}
        }
        Ok(())
    }

    /// raylink's camera from pbrt's camera transform. pbrt's camera space is left-handed
    /// (x right, y up, z forward); raylink's image right is forward × up. When pbrt's right
    /// is the opposite (a camera-to-world without a reflection, as a plain `LookAt` gives),
    /// no rotation of raylink's camera shows the same image, so the whole world is mirrored
    /// across the plane through the eye spanned by forward and up instead: the camera then
    /// sees exactly pbrt's image.
    pub(super) fn begin_world(&mut self, loc: &Loc) -> crate::error::Result<()> {
        self.state.ctm = DMat4::IDENTITY;
        self.state.end_ctm = DMat4::IDENTITY;
        self.coordinate_systems
            .insert("world".into(), DMat4::IDENTITY);
        let (c2w, fov, cam_loc) = match &self.camera {
            Some(c) => (c.camera_to_world, c.fov, c.loc.clone()),
            None => (DMat4::IDENTITY, 90.0, loc.clone()),
        };
        let projection = self.projection(&cam_loc);
        let pos = c2w.transform_point3(DVec3::ZERO);
        let forward = c2w.transform_vector3(DVec3::Z).normalize_or_zero();
        let up = c2w.transform_vector3(DVec3::Y);
        let up = (up - forward * up.dot(forward)).normalize_or_zero();
        let right = c2w.transform_vector3(DVec3::X);
        if forward == DVec3::ZERO || up == DVec3::ZERO || !pos.is_finite() {
            return Err(cam_loc.error("Camera: the camera transform is degenerate"));
        }
        let raylink_right = forward.cross(up);
        if right.dot(raylink_right) < 0.0 {
            let n = raylink_right.normalize();
            let reflect = DMat4::from_mat3(DMat3::IDENTITY - 2.0 * outer(n, n));
            self.mirror = DMat4::from_translation(pos) * reflect * DMat4::from_translation(-pos);
        }
        self.camera_value = Some(Camera {
            position: pos.as_vec3(),
            look_at: (pos + forward).as_vec3(),
            up: up.as_vec3(),
            fov_deg: fov as f32,
            width: self.resolution.0,
            height: self.resolution.1,
            projection,
        });
        if let Some(Err(p)) = self.camera_value.as_ref().map(Camera::check) {
            return Err(cam_loc.error(format!(
                "Camera: the camera's {} (from its transform and parameters) {}",
                p.field, p.message
            )));
        }
        Ok(())
    }

    /// raylink's projection for pbrt's camera: a thin lens for `lensradius` > 0; for an
    /// orthographic camera, the screen window's width (pbrt's default window spans 2 units
    /// along the shorter image axis). A window off the centre or of another aspect than the
    /// film warns: raylink's orthographic film is centred and has square pixels.
    fn projection(&mut self, loc: &Loc) -> Projection {
        let Some(c) = &self.camera else {
            return Projection::Pinhole;
        };
        let (lens, window) = (c.lens, c.orthographic.clone());
        let (w, h) = (self.resolution.0 as f64, self.resolution.1 as f64);
        match window {
            None if lens.0 > 0.0 => Projection::ThinLens {
                radius: lens.0 as f32,
                focal_distance: lens.1 as f32,
            },
            None => Projection::Pinhole,
            Some(win) if win.is_empty() => {
                let aspect = w / h;
                Projection::Orthographic {
                    size: (2.0 * aspect.max(1.0)) as f32,
                }
            }
            Some(win) => {
                let (wx, wy) = (win[1] - win[0], win[3] - win[2]);
                let centred =
                    (win[0] + win[1]).abs() <= 1e-6 * wx && (win[2] + win[3]).abs() <= 1e-6 * wy;
                if !centred || (wx / wy - w / h).abs() > 1e-3 * (w / h) {
                    self.warn(
                        loc,
                        "Camera \"orthographic\": a screenwindow off the centre or of another aspect than the film is not supported; using a centred window of its width",
                    );
                }
                Projection::Orthographic { size: wx as f32 }
            }
        }
    }
}

fn outer(a: DVec3, b: DVec3) -> DMat3 {
    DMat3::from_cols(a * b.x, a * b.y, a * b.z)
}
