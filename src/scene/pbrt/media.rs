//! Participating media: `MakeNamedMedium` (homogeneous, uniform-grid, RGB-grid and NanoVDB
//! media), the
//! `MediumInterface` that the shapes and the camera after it take, and the camera's medium
//! (the outside medium when `Camera` is given, as pbrt-v4 has it).

use super::builder::Builder;
use super::params::Params;
use super::spectrum::Kind;
use super::Loc;
use crate::math::{Mat4, Rgb, Vec3};
use crate::scene::media::{nanovdb, presets, SparseSource};
use crate::scene::media::{
    Homogeneous, Medium, MediumInterface, MediumKind, MediumPoint, RgbGrid, RgbGrids, UniformGrid,
    MAX_GRID_SAMPLES,
};

impl Builder {
    /// `MakeNamedMedium "name" "string type" "..."`.
    pub(super) fn named_medium(
        &mut self,
        name: String,
        p: &Params,
        loc: &Loc,
    ) -> crate::error::Result<()> {
        let ty = p
            .string("type")
            .map_err(Self::pe(loc))?
            .ok_or_else(|| loc.error(format!("MakeNamedMedium \"{name}\": no \"type\" given")))?;
        let st = format!("MakeNamedMedium \"{name}\"");
        let kind = match ty.as_str() {
            "homogeneous" => {
                let le_scale = p.float_or("Lescale", 1.0).map_err(Self::pe(loc))? as f32;
                let unit = self.medium_point(p, le_scale, true, &st, loc)?;
                MediumKind::Homogeneous(
                    Homogeneous::new(unit.sigma_a, unit.sigma_s, unit.le, unit.g)
                        .map_err(|e| loc.error(format!("{st}: {e}")))?,
                )
            }
            "uniformgrid" => MediumKind::UniformGrid(Box::new(self.uniform_grid(p, &st, loc)?)),
            "nanovdb" => self.nanovdb(p, &st, loc)?,
            "rgbgrid" => MediumKind::RgbGrid(Box::new(self.rgb_grid(p, &st, loc)?)),
            _ => {
                for q in p.list.iter() {
                    p.ignore(&q.name);
                }
                self.warn(
                    loc,
                    format!("{st}: medium type \"{ty}\" is not supported; the medium is left out"),
                );
                self.medium_names.insert(name, None);
                return Ok(());
            }
        };
        self.report_unused("MakeNamedMedium", &ty, p, loc);
        let index = self.media.len() as u32;
        self.media.push(Medium {
            name: name.clone(),
            kind,
        });
        self.medium_names.insert(name, Some(index));
        Ok(())
    }

    /// The coefficients every pbrt-v4 medium takes: `sigma_a`, `sigma_s` (default 1) and
    /// `scale`, `Le` (times `le_scale`), `g`; with `preset` (a homogeneous medium's), the
    /// measured medium it names replaces `sigma_a` and `sigma_s`.
    fn medium_point(
        &mut self,
        p: &Params,
        le_scale: f32,
        preset: bool,
        st: &str,
        loc: &Loc,
    ) -> crate::error::Result<MediumPoint> {
        let name = match preset {
            true => p.string("preset").map_err(Self::pe(loc))?,
            false => None,
        };
        let measured = match name {
            Some(name) => {
                let found = presets::measured(&name);
                if found.is_none() {
                    // pbrt-v4 warns the same way and goes on.
                    self.warn(
                        loc,
                        format!(
                            "{st}: no measured medium is called \"{name}\"; using sigma_a and \
                             sigma_s"
                        ),
                    );
                }
                found
            }
            None => None,
        };
        let scale = p.float_or("scale", 1.0).map_err(Self::pe(loc))? as f32;
        let (sigma_a, sigma_s) = match measured {
            Some(m) => m,
            None => (
                self.spectrum(p, "sigma_a", Kind::Unbounded, st, loc)?
                    .unwrap_or(Rgb::ONE),
                self.spectrum(p, "sigma_s", Kind::Unbounded, st, loc)?
                    .unwrap_or(Rgb::ONE),
            ),
        };
        let le = self
            .spectrum(p, "Le", Kind::Illuminant, st, loc)?
            .unwrap_or(Rgb::ZERO);
        let g = p.float_or("g", 0.0).map_err(Self::pe(loc))? as f32;
        if !(scale.is_finite() && scale >= 0.0) {
            return Err(loc.error(format!(
                "{st}: scale must be finite and not negative, got {scale}"
            )));
        }
        Ok(MediumPoint {
            sigma_a: sigma_a * scale,
            sigma_s: sigma_s * scale,
            le: le * le_scale,
            g,
        })
    }

    /// pbrt-v4's `uniformgrid`: `density` (nx·ny·nz values, x fastest) over the box `p0`–`p1`
    /// of the medium's space, an optional `Lescale` grid beside it.
    fn uniform_grid(
        &mut self,
        p: &Params,
        st: &str,
        loc: &Loc,
    ) -> crate::error::Result<UniformGrid> {
        let pe = Self::pe(loc);
        let res = Self::grid_resolution(p, st, loc)?;
        let floats = |name: &str| -> crate::error::Result<Option<Vec<f32>>> {
            Ok(p.floats(name, "float")
                .map_err(&pe)?
                .map(|v| v.iter().map(|&x| x as f32).collect()))
        };
        let Some(density) = floats("density")? else {
            return Err(loc.error(format!("{st}: no \"density\" values given")));
        };
        for q in [
            "temperature",
            "temperaturescale",
            "temperatureoffset",
            "temperaturecutoff",
        ] {
            if p.find(q, &["float"]).map_err(&pe)?.is_some() {
                self.warn(
                    loc,
                    format!("{st}: \"{q}\" (blackbody emission) is not supported; ignored"),
                );
            }
        }
        // `Lescale` is a grid here (or one number for the whole grid).
        let le_scale = floats("Lescale")?;
        let le_grid = le_scale.as_ref().is_some_and(|v| v.len() != 1);
        let one_scale = match &le_scale {
            Some(v) if v.len() == 1 => v[0],
            _ => 1.0,
        };
        let unit = self.medium_point(p, one_scale, false, st, loc)?;
        let bounds = Self::grid_box(p, st, loc)?;
        let to_world: Mat4 = self.state.ctm.as_mat4();
        UniformGrid::new(
            unit,
            res,
            density,
            le_scale.filter(|_| le_grid),
            bounds,
            to_world,
        )
        .map_err(|e| loc.error(format!("{st}: {e}")))
    }

    /// A grid's `nx`, `ny`, `nz` (default 1).
    fn grid_resolution(p: &Params, st: &str, loc: &Loc) -> crate::error::Result<[usize; 3]> {
        let mut res = [0usize; 3];
        for (r, name) in res.iter_mut().zip(["nx", "ny", "nz"]) {
            let n = p.int(name).map_err(Self::pe(loc))?.unwrap_or(1);
            if !(1..=MAX_GRID_SAMPLES as i64).contains(&n) {
                return Err(loc.error(format!(
                    "{st}: {name} must be between 1 and {MAX_GRID_SAMPLES}, got {n}"
                )));
            }
            *r = n as usize;
        }
        Ok(res)
    }

    /// A grid's box `p0`–`p1` in its own space (default the unit cube).
    fn grid_box(p: &Params, st: &str, loc: &Loc) -> crate::error::Result<(Vec3, Vec3)> {
        let point3 = |name: &str, default: Vec3| -> crate::error::Result<Vec3> {
            match p.floats(name, "point3").map_err(Self::pe(loc))? {
                Some(v) if v.len() == 3 => Ok(Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32)),
                Some(_) => Err(loc.error(format!("{st}: \"{name}\" takes one point"))),
                None => Ok(default),
            }
        };
        Ok((point3("p0", Vec3::ZERO)?, point3("p1", Vec3::ONE)?))
    }

    /// pbrt-v4's `rgbgrid`: `sigma_a`, `sigma_s` and `Le` as RGB values, one a sample (nx·ny·nz,
    /// x fastest) over the box `p0`–`p1`, σa and σs times `scale`, Le times `Lescale`.
    fn rgb_grid(&mut self, p: &Params, st: &str, loc: &Loc) -> crate::error::Result<RgbGrid> {
        let pe = Self::pe(loc);
        let res = Self::grid_resolution(p, st, loc)?;
        let le_scale = p.float_or("Lescale", 1.0).map_err(&pe)? as f32;
        if !(le_scale.is_finite() && le_scale >= 0.0) {
            return Err(loc.error(format!(
                "{st}: Lescale must be finite and not negative, got {le_scale}"
            )));
        }
        let colours = |name: &str, times: f32| -> crate::error::Result<Option<Vec<Rgb>>> {
            let Some(v) = p.floats(name, "rgb").map_err(&pe)? else {
                return Ok(None);
            };
            if v.len() % 3 != 0 {
                return Err(loc.error(format!(
                    "{st}: \"{name}\" takes three numbers an rgb value, got {}",
                    v.len()
                )));
            }
            Ok(Some(
                v.chunks_exact(3)
                    .map(|c| Rgb::new(c[0] as f32, c[1] as f32, c[2] as f32) * times)
                    .collect(),
            ))
        };
        let grids = RgbGrids {
            sigma_a: colours("sigma_a", 1.0)?,
            sigma_s: colours("sigma_s", 1.0)?,
            le: colours("Le", le_scale)?,
        };
        let scale = p.float_or("scale", 1.0).map_err(&pe)? as f32;
        let g = p.float_or("g", 0.0).map_err(&pe)? as f32;
        let bounds = Self::grid_box(p, st, loc)?;
        RgbGrid::new(grids, scale, g, res, bounds, self.state.ctm.as_mat4())
            .map_err(|e| loc.error(format!("{st}: {e}")))
    }

    /// pbrt-v4's `nanovdb`: the float grid `gridname` ("density") of the NanoVDB file
    /// `filename`, dense (a `uniformgrid`) or, when too large for that, sparse, placed by its
    /// index-to-world map and the transform current at the statement.
    fn nanovdb(&mut self, p: &Params, st: &str, loc: &Loc) -> crate::error::Result<MediumKind> {
        let pe = Self::pe(loc);
        let file = p.string("filename").map_err(&pe)?.ok_or_else(|| {
            loc.error(format!("{st}: a nanovdb medium needs \"string filename\""))
        })?;
        let density = p
            .string("gridname")
            .map_err(&pe)?
            .unwrap_or("density".into());
        let temperature = p
            .string("temperaturename")
            .map_err(&pe)?
            .unwrap_or("temperature".into());
        let path = loc.dir().join(&file);
        self.add_input(&path);
        let mut grids = nanovdb::read(&path, &[&density, &temperature], &self.allowance())
            .map_err(|e| loc.error(format!("{st}: {e}")))?;
        let Some(grid) = grids[0].take() else {
            return Err(loc.error(format!(
                "{st}: {}: has no grid named \"{density}\"",
                path.display()
            )));
        };
        for q in ["temperatureoffset", "temperaturecutoff", "temperaturescale"] {
            p.ignore(q);
        }
        if grids[1].is_some() {
            self.warn(
                loc,
                format!(
                    "{st}: the grid \"{temperature}\" (blackbody emission) is not supported; \
                     the medium does not emit"
                ),
            );
        }
        let le_scale = p.float_or("Lescale", 1.0).map_err(&pe)? as f32;
        let unit = self.medium_point(p, le_scale, false, st, loc)?;
        self.held.add_medium(grid.bytes());
        let source = SparseSource {
            file: path.clone(),
            grid: density,
            transform: self.state.ctm.as_mat4(),
        };
        nanovdb::medium(grid, unit, source)
            .map_err(|e| loc.error(format!("{st}: {}: {e}", path.display())))
    }

    /// `MediumInterface "inside" "outside"` (one name: both sides), for the shapes and the
    /// camera that follow; "" is vacuum.
    pub(super) fn set_medium_interface(
        &mut self,
        inside: String,
        outside: Option<String>,
        _loc: &Loc,
    ) -> crate::error::Result<()> {
        let outside = outside.unwrap_or_else(|| inside.clone());
        self.state.media = (inside, outside);
        Ok(())
    }

    /// The medium a name refers to (`None`: vacuum, or a medium left out); an error for a
    /// name no `MakeNamedMedium` gave before.
    pub(super) fn medium_named(&self, name: &str, loc: &Loc) -> crate::error::Result<Option<u32>> {
        if name.is_empty() {
            return Ok(None);
        }
        match self.medium_names.get(name) {
            Some(m) => Ok(*m),
            None => Err(loc.error(format!(
                "MediumInterface: no medium named \"{name}\" was made before (MakeNamedMedium)"
            ))),
        }
    }

    /// The medium interface of the shapes made now, from the graphics state.
    pub(super) fn shape_media(&self, loc: &Loc) -> crate::error::Result<Option<MediumInterface>> {
        let (inside, outside) = &self.state.media;
        Ok(MediumInterface::between(
            self.medium_named(inside, loc)?,
            self.medium_named(outside, loc)?,
        ))
    }
}
