//! Running statements: each keyword against the loader, and included files read in place.

use super::cursor::Cursor;
use super::lexer::Tok;
use super::limits;
use super::params::Params;
use super::state::{look_at, Block};
use super::{Loader, Loc};
use crate::error::Error;
use glam::{DMat4, DVec3};
use std::path::Path;
use std::sync::Arc;

impl Loader {
    pub(super) fn run_file(
        &mut self,
        path: &Path,
        text: &str,
        from: Option<&Loc>,
    ) -> crate::error::Result<()> {
        let key = path.canonicalize().unwrap_or_else(|_| path.to_path_buf());
        if let Some(i) = self.include_stack.iter().position(|p| *p == key) {
            let chain: Vec<String> = self.include_stack[i..]
                .iter()
                .chain([&key])
                .map(|p| {
                    p.file_name()
                        .map_or(p.display().to_string(), |n| n.to_string_lossy().into())
                })
                .collect();
            let msg = format!("include cycle: {}", chain.join(" includes "));
            return Err(match from {
                Some(loc) => loc.error(msg),
                None => Error::input(path, msg),
            });
        }
        let file = Arc::new(path.to_path_buf());
        let (tokens, bytes) = self.open_file(path, text, from)?;
        self.include_stack.push(key);
        let depth = self.stack.len();
        let mut cursor = Cursor {
            file,
            tokens: &tokens,
            i: 0,
        };
        while cursor.i < tokens.len() {
            self.cancel.check("reading the scene")?;
            self.statement(&mut cursor)?;
        }
        self.include_stack.pop();
        drop(tokens);
        self.close_file(bytes);
        if from.is_none() && self.stack.len() > depth {
            let (block, _, loc) = self.stack.last().expect("non-empty");
            return Err(loc.error(format!(
                "{} is never closed: the file ends before its {}End (truncated file?)",
                block.begin(),
                &block.begin()[..block.begin().len() - 5]
            )));
        }
        Ok(())
    }

    fn statement(&mut self, c: &mut Cursor) -> crate::error::Result<()> {
        let t = &c.tokens[c.i];
        let loc = c.loc(t);
        let Tok::Word(keyword) = &t.tok else {
            return Err(loc.error(format!(
                "expected a statement keyword (such as Shape or WorldBegin), got {}",
                t.tok.describe()
            )));
        };
        let keyword = keyword.clone();
        c.i += 1;
        let kw = keyword.as_str();
        match kw {
            "AttributeBegin" => self.push(Block::Attribute, &loc),
            "AttributeEnd" => self.pop(Block::Attribute, &loc)?,
            "TransformBegin" => self.push(Block::Transform, &loc),
            "TransformEnd" => self.pop(Block::Transform, &loc)?,
            "ObjectBegin" => {
                let name = c.string(&loc, kw)?;
                if let Some((outer, _)) = &self.object {
                    return Err(loc.error(format!(
                        "ObjectBegin \"{name}\" inside the definition of \"{outer}\": \
                         object definitions cannot nest"
                    )));
                }
                self.require_world(&loc, kw)?;
                self.push(Block::Object, &loc);
                self.object = Some((name, Vec::new()));
            }
            "ObjectEnd" => {
                self.pop(Block::Object, &loc)?;
                if let Some((name, shapes)) = self.object.take() {
                    let object = limits::Object::new(shapes, |s| self.copied_when_placed(s));
                    self.objects.insert(name, object);
                }
            }
            "ObjectInstance" => {
                let name = c.string(&loc, kw)?;
                self.require_world(&loc, kw)?;
                if self.object.is_some() {
                    return Err(loc.error(
                        "ObjectInstance inside an object definition (pbrt does not nest instances)",
                    ));
                }
                let t = self.mirror * self.state.ctm;
                if !self.objects.contains_key(&name) {
                    return Err(loc.error(format!("ObjectInstance: no object named \"{name}\"")));
                }
                self.place_object(&name, &t, &loc)?;
            }
            "Identity" => self.set_ctm(&loc, kw, |_| DMat4::IDENTITY)?,
            "Translate" => {
                let v = c.numbers(&loc, kw, 3)?;
                self.set_ctm(&loc, kw, |m| {
                    m * DMat4::from_translation(DVec3::new(v[0], v[1], v[2]))
                })?;
            }
            "Scale" => {
                let v = c.numbers(&loc, kw, 3)?;
                self.set_ctm(&loc, kw, |m| {
                    m * DMat4::from_scale(DVec3::new(v[0], v[1], v[2]))
                })?;
            }
            "Rotate" => {
                let v = c.numbers(&loc, kw, 4)?;
                let axis = DVec3::new(v[1], v[2], v[3]);
                if axis.length() == 0.0 {
                    return Err(loc.error("Rotate: the axis must not be zero"));
                }
                let r = DMat4::from_axis_angle(axis.normalize(), v[0].to_radians());
                self.set_ctm(&loc, kw, |m| m * r)?;
            }
            "LookAt" => {
                let v = c.numbers(&loc, kw, 9)?;
                let look = look_at(
                    DVec3::new(v[0], v[1], v[2]),
                    DVec3::new(v[3], v[4], v[5]),
                    DVec3::new(v[6], v[7], v[8]),
                )
                .map_err(|m| loc.error(format!("LookAt: {m}")))?;
                self.set_ctm(&loc, kw, |m| m * look)?;
            }
            "Transform" | "ConcatTransform" => {
                let v = c.matrix(&loc, kw)?;
                // pbrt lists the matrix column by column.
                let m = DMat4::from_cols_array(&v);
                if kw == "Transform" {
                    self.set_ctm(&loc, kw, |_| m)?;
                } else {
                    self.set_ctm(&loc, kw, |ctm| ctm * m)?;
                }
            }
            "CoordinateSystem" => {
                let name = c.string(&loc, kw)?;
                self.coordinate_systems.insert(name, self.state.ctm);
            }
            "CoordSysTransform" => {
                let name = c.string(&loc, kw)?;
                match self.coordinate_systems.get(&name) {
                    Some(&m) => {
                        self.state.ctm = m;
                        self.state.end_ctm = m;
                    }
                    None => self.warn(
                        &loc,
                        format!("CoordSysTransform: unknown coordinate system \"{name}\"; ignored"),
                    ),
                }
            }
            "ActiveTransform" => {
                let Some(Tok::Word(which)) = c.peek().map(|t| t.tok.clone()) else {
                    return Err(loc.error("ActiveTransform takes StartTime, EndTime or All"));
                };
                c.i += 1;
                match which.as_str() {
                    "All" => {
                        self.state.end_time_only = false;
                        self.state.start_time_only = false;
                    }
                    "StartTime" => {
                        self.state.end_time_only = false;
                        self.state.start_time_only = true;
                    }
                    "EndTime" => {
                        self.state.end_time_only = true;
                        self.state.start_time_only = false;
                    }
                    other => {
                        return Err(loc.error(format!(
                            "ActiveTransform takes StartTime, EndTime or All, got `{other}`"
                        )))
                    }
                }
            }
            "TransformTimes" => {
                let t = c.numbers(&loc, kw, 2)?;
                if !(t[0].is_finite() && t[1].is_finite() && t[0] <= t[1]) {
                    return Err(loc.error(format!(
                        "TransformTimes takes a start and an end time, start <= end, got {} {}",
                        t[0], t[1]
                    )));
                }
                self.timing.transform = (t[0], t[1]);
            }
            "ReverseOrientation" => {
                self.state.reverse_orientation = !self.state.reverse_orientation
            }
            "Camera" | "Film" | "Sampler" | "PixelFilter" | "Integrator" | "Accelerator"
            | "ColorSpace" | "Option" => {
                let ty = c.string(&loc, kw)?;
                let value = if kw == "Option" {
                    c.option_value()
                } else {
                    None
                };
                let p = c.params(&loc)?;
                if self.world {
                    return Err(loc.error(format!(
                        "{kw} must come before WorldBegin (it sets a rendering option)"
                    )));
                }
                self.option(kw, &ty, value, &p, &loc)?;
                self.report_unused(kw, &ty, &p, &loc);
            }
            "MakeNamedMedium" => {
                let name = c.string(&loc, kw)?;
                let _ = c.params(&loc)?;
                self.warn(
                    &loc,
                    format!("MakeNamedMedium \"{name}\": participating media are not supported; ignored"),
                );
            }
            "MediumInterface" => {
                c.string(&loc, kw)?;
                if matches!(c.peek().map(|t| &t.tok), Some(Tok::Str(_))) {
                    c.string(&loc, kw)?;
                }
                self.warn(
                    &loc,
                    "MediumInterface: participating media are not supported; ignored",
                );
            }
            "Attribute" => {
                let target = c.string(&loc, kw)?;
                let _ = c.params(&loc)?;
                self.warn(
                    &loc,
                    format!(
                        "Attribute \"{target}\": default parameters are not supported; ignored"
                    ),
                );
            }
            "WorldBegin" => {
                if self.world {
                    return Err(loc.error("WorldBegin appears twice"));
                }
                self.world = true;
                self.begin_world(&loc)?;
            }
            "WorldEnd" => {}
            "MakeNamedMaterial" => {
                let name = c.string(&loc, kw)?;
                let p = c.params(&loc)?;
                self.require_world(&loc, kw)?;
                let ty = p
                    .string("type")
                    .map_err(|e| loc.param_error(e))?
                    .ok_or_else(|| {
                        loc.error(format!(
                            "MakeNamedMaterial \"{name}\" needs a \"string type\" parameter"
                        ))
                    })?;
                let m = self.material(&ty, &name, &p, &loc)?;
                self.report_unused("MakeNamedMaterial", &ty, &p, &loc);
                self.named_materials.insert(name, self.materials.len());
                self.materials.push(m);
            }
            "Material" => {
                let ty = c.string(&loc, kw)?;
                let p = c.params(&loc)?;
                self.require_world(&loc, kw)?;
                let m = self.material(&ty, "", &p, &loc)?;
                self.report_unused(kw, &ty, &p, &loc);
                self.state.material = Some(self.materials.len());
                self.materials.push(m);
            }
            "NamedMaterial" => {
                let name = c.string(&loc, kw)?;
                self.require_world(&loc, kw)?;
                match self.named_materials.get(&name) {
                    Some(&i) => self.state.material = Some(i),
                    None => {
                        return Err(loc.error(format!(
                            "NamedMaterial: no material named \"{name}\" (define it with \
                             MakeNamedMaterial first)"
                        )))
                    }
                }
            }
            "Texture" => {
                let name = c.string(&loc, kw)?;
                let ty = c.string(&loc, kw)?;
                let class = c.string(&loc, kw)?;
                let p = c.params(&loc)?;
                self.require_world(&loc, kw)?;
                self.texture(&name, &ty, &class, &p, &loc)?;
                self.report_unused(kw, &class, &p, &loc);
            }
            "Shape" | "LightSource" | "AreaLightSource" => {
                let ty = c.string(&loc, kw)?;
                let p = c.params(&loc)?;
                self.require_world(&loc, kw)?;
                match kw {
                    "Shape" => self.shape(&ty, &p, &loc)?,
                    "LightSource" => self.light(&ty, &p, &loc)?,
                    _ => self.area_light(&ty, &p, &loc)?,
                }
                self.report_unused(kw, &ty, &p, &loc);
            }
            "Include" | "Import" => {
                let name = c.string(&loc, kw)?;
                let path = loc.dir().join(&name);
                self.count_include(&loc, kw)?;
                self.add_input(&path);
                let text = self.read_text(&path, Some((&loc, &format!("{kw} \"{name}\""))))?;
                self.run_file(&path, &text, Some(&loc))?;
            }
            other => {
                return Err(loc.error(format!("unknown statement `{other}`")));
            }
        }
        Ok(())
    }

    fn require_world(&self, loc: &Loc, what: &str) -> crate::error::Result<()> {
        if self.world {
            Ok(())
        } else {
            Err(loc.error(format!("{what} must come after WorldBegin")))
        }
    }

    fn report_unused(&mut self, statement: &str, ty: &str, p: &Params, loc: &Loc) {
        let unused: Vec<(String, u32)> = p.unused().map(|q| (q.name.clone(), q.line)).collect();
        for (name, line) in unused {
            self.warn(
                &loc.at(line, 1),
                format!("{statement} \"{ty}\": parameter \"{name}\" is not supported; ignored"),
            );
        }
    }
}
