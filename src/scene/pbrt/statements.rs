//! The builder's side of each statement: the graphics state changed, the rendering options
//! set, and the world's materials, textures, lights, shapes and objects made.

use super::builder::Builder;
use super::cost;
use super::params::Params;
use super::state::{look_at, Block};
use super::target::{ActiveTransform, Target};
use super::Loc;
use glam::{DMat4, DVec3};
use std::path::Path;

impl Target for Builder {
    fn identity(&mut self, loc: &Loc) -> crate::error::Result<()> {
        self.set_ctm(loc, "Identity", |_| DMat4::IDENTITY)
    }

    fn translate(&mut self, v: [f64; 3], loc: &Loc) -> crate::error::Result<()> {
        let t = DMat4::from_translation(DVec3::from_array(v));
        self.set_ctm(loc, "Translate", |m| m * t)
    }

    fn scale(&mut self, v: [f64; 3], loc: &Loc) -> crate::error::Result<()> {
        let s = DMat4::from_scale(DVec3::from_array(v));
        self.set_ctm(loc, "Scale", |m| m * s)
    }

    fn rotate(&mut self, angle: f64, axis: [f64; 3], loc: &Loc) -> crate::error::Result<()> {
        let axis = DVec3::from_array(axis);
        if axis.length() == 0.0 {
            return Err(loc.error("Rotate: the axis must not be zero"));
        }
        let r = DMat4::from_axis_angle(axis.normalize(), angle.to_radians());
        self.set_ctm(loc, "Rotate", |m| m * r)
    }

    fn look_at(
        &mut self,
        eye: [f64; 3],
        target: [f64; 3],
        up: [f64; 3],
        loc: &Loc,
    ) -> crate::error::Result<()> {
        let look = look_at(
            DVec3::from_array(eye),
            DVec3::from_array(target),
            DVec3::from_array(up),
        )
        .map_err(|m| loc.error(format!("LookAt: {m}")))?;
        self.set_ctm(loc, "LookAt", |m| m * look)
    }

    fn transform(&mut self, m: [f64; 16], loc: &Loc) -> crate::error::Result<()> {
        let m = matrix(m, loc, "Transform")?;
        self.set_ctm(loc, "Transform", |_| m)
    }

    fn concat_transform(&mut self, m: [f64; 16], loc: &Loc) -> crate::error::Result<()> {
        let m = matrix(m, loc, "ConcatTransform")?;
        self.set_ctm(loc, "ConcatTransform", |ctm| ctm * m)
    }

    fn coordinate_system(&mut self, name: String, _loc: &Loc) -> crate::error::Result<()> {
        self.coordinate_systems.insert(name, self.state.ctm);
        Ok(())
    }

    fn coord_sys_transform(&mut self, name: String, loc: &Loc) -> crate::error::Result<()> {
        match self.coordinate_systems.get(&name) {
            Some(&m) => {
                self.state.ctm = m;
                self.state.end_ctm = m;
            }
            None => self.warn(
                loc,
                format!("CoordSysTransform: unknown coordinate system \"{name}\"; ignored"),
            ),
        }
        Ok(())
    }

    fn active_transform(&mut self, which: ActiveTransform, _loc: &Loc) -> crate::error::Result<()> {
        let (start_only, end_only) = match which {
            ActiveTransform::All => (false, false),
            ActiveTransform::StartTime => (true, false),
            ActiveTransform::EndTime => (false, true),
        };
        self.state.start_time_only = start_only;
        self.state.end_time_only = end_only;
        Ok(())
    }

    fn transform_times(&mut self, start: f64, end: f64, loc: &Loc) -> crate::error::Result<()> {
        if !(start.is_finite() && end.is_finite() && start <= end) {
            return Err(loc.error(format!(
                "TransformTimes takes a start and an end time, start <= end, got {start} {end}"
            )));
        }
        self.timing.transform = (start, end);
        Ok(())
    }

    fn reverse_orientation(&mut self, _loc: &Loc) -> crate::error::Result<()> {
        self.state.reverse_orientation = !self.state.reverse_orientation;
        Ok(())
    }

    fn attribute_begin(&mut self, loc: &Loc) -> crate::error::Result<()> {
        self.push(Block::Attribute, loc);
        Ok(())
    }

    fn attribute_end(&mut self, loc: &Loc) -> crate::error::Result<()> {
        self.pop(Block::Attribute, loc)
    }

    fn transform_begin(&mut self, loc: &Loc) -> crate::error::Result<()> {
        self.push(Block::Transform, loc);
        Ok(())
    }

    fn transform_end(&mut self, loc: &Loc) -> crate::error::Result<()> {
        self.pop(Block::Transform, loc)
    }

    fn object_begin(&mut self, name: String, loc: &Loc) -> crate::error::Result<()> {
        if let Some((outer, _)) = &self.object {
            return Err(loc.error(format!(
                "ObjectBegin \"{name}\" inside the definition of \"{outer}\": \
                 object definitions cannot nest"
            )));
        }
        self.require_world(loc, "ObjectBegin")?;
        self.push(Block::Object, loc);
        self.object = Some((name, Vec::new()));
        Ok(())
    }

    fn object_end(&mut self, loc: &Loc) -> crate::error::Result<()> {
        self.pop(Block::Object, loc)?;
        if let Some((name, shapes)) = self.object.take() {
            let object = cost::Object::new(shapes, |s| self.copied_when_placed(s));
            self.objects.insert(name, object);
        }
        Ok(())
    }

    fn object_instance(&mut self, name: String, loc: &Loc) -> crate::error::Result<()> {
        self.require_world(loc, "ObjectInstance")?;
        if self.object.is_some() {
            return Err(loc.error(
                "ObjectInstance inside an object definition (pbrt does not nest instances)",
            ));
        }
        let t = self.mirror * self.state.ctm;
        if !self.objects.contains_key(&name) {
            return Err(loc.error(format!("ObjectInstance: no object named \"{name}\"")));
        }
        self.place_object(&name, &t, loc)
    }

    fn camera(&mut self, ty: String, p: Params, loc: &Loc) -> crate::error::Result<()> {
        self.option_statement("Camera", &ty, None, &p, loc)
    }

    fn film(&mut self, ty: String, p: Params, loc: &Loc) -> crate::error::Result<()> {
        self.option_statement("Film", &ty, None, &p, loc)
    }

    fn sampler(&mut self, ty: String, p: Params, loc: &Loc) -> crate::error::Result<()> {
        self.option_statement("Sampler", &ty, None, &p, loc)
    }

    fn pixel_filter(&mut self, ty: String, p: Params, loc: &Loc) -> crate::error::Result<()> {
        self.option_statement("PixelFilter", &ty, None, &p, loc)
    }

    fn integrator(&mut self, ty: String, p: Params, loc: &Loc) -> crate::error::Result<()> {
        self.option_statement("Integrator", &ty, None, &p, loc)
    }

    fn accelerator(&mut self, ty: String, p: Params, loc: &Loc) -> crate::error::Result<()> {
        self.option_statement("Accelerator", &ty, None, &p, loc)
    }

    /// `ColorSpace`: part of the graphics state (pbrt-v4), so allowed in the world too.
    fn color_space(&mut self, name: String, p: Params, loc: &Loc) -> crate::error::Result<()> {
        self.set_option("ColorSpace", &name, None, &p, loc)?;
        self.report_unused("ColorSpace", &name, &p, loc);
        Ok(())
    }

    fn option(
        &mut self,
        name: String,
        value: Option<String>,
        p: Params,
        loc: &Loc,
    ) -> crate::error::Result<()> {
        self.option_statement("Option", &name, value, &p, loc)
    }

    fn world_begin(&mut self, loc: &Loc) -> crate::error::Result<()> {
        if self.world {
            return Err(loc.error("WorldBegin appears twice"));
        }
        self.world = true;
        self.begin_world(loc)
    }

    fn world_end(&mut self, _loc: &Loc) -> crate::error::Result<()> {
        Ok(())
    }

    fn attribute(&mut self, target: String, _p: Params, loc: &Loc) -> crate::error::Result<()> {
        self.warn(
            loc,
            format!("Attribute \"{target}\": default parameters are not supported; ignored"),
        );
        Ok(())
    }

    fn make_named_medium(
        &mut self,
        name: String,
        p: Params,
        loc: &Loc,
    ) -> crate::error::Result<()> {
        self.named_medium(name, &p, loc)
    }

    fn medium_interface(
        &mut self,
        inside: String,
        outside: Option<String>,
        loc: &Loc,
    ) -> crate::error::Result<()> {
        self.set_medium_interface(inside, outside, loc)
    }

    fn material(&mut self, ty: String, p: Params, loc: &Loc) -> crate::error::Result<()> {
        self.require_world(loc, "Material")?;
        let m = self.make_material(&ty, "", &p, loc)?;
        self.report_unused("Material", &ty, &p, loc);
        self.state.material = Some(self.materials.len());
        self.materials.push(m);
        Ok(())
    }

    fn make_named_material(
        &mut self,
        name: String,
        p: Params,
        loc: &Loc,
    ) -> crate::error::Result<()> {
        self.require_world(loc, "MakeNamedMaterial")?;
        let ty = p
            .string("type")
            .map_err(|e| loc.param_error(e))?
            .ok_or_else(|| {
                loc.error(format!(
                    "MakeNamedMaterial \"{name}\" needs a \"string type\" parameter"
                ))
            })?;
        let m = self.make_material(&ty, &name, &p, loc)?;
        self.report_unused("MakeNamedMaterial", &ty, &p, loc);
        self.named_materials.insert(name, self.materials.len());
        self.materials.push(m);
        Ok(())
    }

    fn named_material(&mut self, name: String, loc: &Loc) -> crate::error::Result<()> {
        self.require_world(loc, "NamedMaterial")?;
        match self.named_materials.get(&name) {
            Some(&i) => {
                self.state.material = Some(i);
                Ok(())
            }
            None => Err(loc.error(format!(
                "NamedMaterial: no material named \"{name}\" (define it with \
                 MakeNamedMaterial first)"
            ))),
        }
    }

    fn texture(
        &mut self,
        name: String,
        ty: String,
        class: String,
        p: Params,
        loc: &Loc,
    ) -> crate::error::Result<()> {
        self.require_world(loc, "Texture")?;
        self.make_texture(&name, &ty, &class, &p, loc)?;
        self.report_unused("Texture", &class, &p, loc);
        Ok(())
    }

    fn shape(&mut self, ty: String, p: Params, loc: &Loc) -> crate::error::Result<()> {
        self.require_world(loc, "Shape")?;
        self.make_shape(&ty, &p, loc)?;
        self.report_unused("Shape", &ty, &p, loc);
        Ok(())
    }

    fn light_source(&mut self, ty: String, p: Params, loc: &Loc) -> crate::error::Result<()> {
        self.require_world(loc, "LightSource")?;
        self.light(&ty, &p, loc)?;
        self.report_unused("LightSource", &ty, &p, loc);
        Ok(())
    }

    fn area_light_source(&mut self, ty: String, p: Params, loc: &Loc) -> crate::error::Result<()> {
        self.require_world(loc, "AreaLightSource")?;
        self.area_light(&ty, &p, loc)?;
        self.report_unused("AreaLightSource", &ty, &p, loc);
        Ok(())
    }

    fn include(&mut self, path: &Path, _loc: &Loc) {
        self.add_input(path);
    }

    fn end_of_files(&mut self) -> crate::error::Result<()> {
        let Some((block, _, loc)) = self.stack.last() else {
            return Ok(());
        };
        Err(loc.error(format!(
            "{} is never closed: the file ends before its {}End (truncated file?)",
            block.begin(),
            &block.begin()[..block.begin().len() - 5]
        )))
    }
}

/// A `Transform` or `ConcatTransform` matrix, listed column by column; a singular one is
/// refused.
fn matrix(v: [f64; 16], loc: &Loc, kw: &str) -> crate::error::Result<DMat4> {
    let m = DMat4::from_cols_array(&v);
    if m.determinant().abs() < 1e-300 {
        return Err(loc.error(format!("{kw}: the matrix is singular")));
    }
    Ok(m)
}

impl Builder {
    /// A statement setting a rendering option (before WorldBegin only).
    fn option_statement(
        &mut self,
        kw: &str,
        ty: &str,
        value: Option<String>,
        p: &Params,
        loc: &Loc,
    ) -> crate::error::Result<()> {
        if self.world {
            return Err(loc.error(format!(
                "{kw} must come before WorldBegin (it sets a rendering option)"
            )));
        }
        self.set_option(kw, ty, value, p, loc)?;
        self.report_unused(kw, ty, p, loc);
        Ok(())
    }

    fn require_world(&self, loc: &Loc, what: &str) -> crate::error::Result<()> {
        if self.world {
            Ok(())
        } else {
            Err(loc.error(format!("{what} must come after WorldBegin")))
        }
    }

    pub(super) fn report_unused(&mut self, statement: &str, ty: &str, p: &Params, loc: &Loc) {
        let unused: Vec<(String, u32)> = p.unused().map(|q| (q.name.clone(), q.line)).collect();
        for (name, line) in unused {
            self.warn(
                &loc.at(line, 1),
                format!("{statement} \"{ty}\": parameter \"{name}\" is not supported; ignored"),
            );
        }
    }
}
