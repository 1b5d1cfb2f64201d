//! The parser: reads a file's statements (and included files in place) and calls the
//! [`Target`] method of each with its arguments and parameter list. It knows the syntax
//! only; what a statement does is the target's.

use super::cursor::Cursor;
use super::lexer::Tok;
use super::limits::Held;
use super::target::{ActiveTransform, Target};
use super::Loc;
use crate::control::{CancelToken, Control, MemoryBudget};
use crate::error::Error;
use std::path::{Path, PathBuf};
use std::sync::Arc;

pub(super) struct Parser {
    /// The scene file, named by the limit on includes.
    pub(super) source: PathBuf,
    /// Files being read, outermost first (for include cycles).
    pub(super) include_stack: Vec<PathBuf>,
    /// Scene text read in all (files counted each time they are read).
    pub(super) text: u64,
    /// `Include` and `Import` statements run.
    pub(super) includes: u64,
    /// The memory the reading may take (see `limits.rs`).
    pub(super) budget: MemoryBudget,
    /// What the reading holds against it, shared with the target that keeps the geometry.
    pub(super) held: Held,
    /// Stops the reading between statements.
    cancel: CancelToken,
}

impl Parser {
    /// A parser for the scene file `source` under a job's controls.
    pub(super) fn new(source: &Path, control: &Control) -> Parser {
        Parser {
            source: source.to_path_buf(),
            include_stack: Vec::new(),
            text: 0,
            includes: 0,
            budget: control.budget,
            held: Held::default(),
            cancel: control.cancel.clone(),
        }
    }

    /// What the reading holds against the memory budget, for the target to add to.
    pub(super) fn held(&self) -> Held {
        self.held.clone()
    }

    /// Reads the scene file at `path` into `target`.
    pub(super) fn read(
        &mut self,
        path: &Path,
        target: &mut impl Target,
    ) -> crate::error::Result<()> {
        let text = self.read_text(path, None)?;
        self.parse(path, &text, target)
    }

    /// Reads scene text into `target`; `path` names it in messages and anchors includes.
    pub(super) fn parse(
        &mut self,
        path: &Path,
        text: &str,
        target: &mut impl Target,
    ) -> crate::error::Result<()> {
        self.run_file(path, text, None, target)?;
        target.end_of_files()
    }

    /// Runs a file's statements; `from`, an `Include` or `Import` of it.
    fn run_file(
        &mut self,
        path: &Path,
        text: &str,
        from: Option<&Loc>,
        target: &mut impl Target,
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
        let mut cursor = Cursor {
            file,
            tokens: &tokens,
            i: 0,
        };
        while cursor.i < tokens.len() {
            self.cancel.check("reading the scene")?;
            self.statement(&mut cursor, target)?;
        }
        self.include_stack.pop();
        drop(tokens);
        self.close_file(bytes);
        Ok(())
    }

    fn statement(&mut self, c: &mut Cursor, target: &mut impl Target) -> crate::error::Result<()> {
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
        let loc = &loc;
        match kw {
            "AttributeBegin" => target.attribute_begin(loc),
            "AttributeEnd" => target.attribute_end(loc),
            "TransformBegin" => target.transform_begin(loc),
            "TransformEnd" => target.transform_end(loc),
            "ObjectBegin" => target.object_begin(c.string(loc, kw)?, loc),
            "ObjectEnd" => target.object_end(loc),
            "ObjectInstance" => target.object_instance(c.string(loc, kw)?, loc),
            "Identity" => target.identity(loc),
            "Translate" => target.translate(c.array(loc, kw)?, loc),
            "Scale" => target.scale(c.array(loc, kw)?, loc),
            "Rotate" => {
                let [angle, x, y, z] = c.array(loc, kw)?;
                target.rotate(angle, [x, y, z], loc)
            }
            "LookAt" => {
                let [ex, ey, ez, tx, ty, tz, ux, uy, uz] = c.array(loc, kw)?;
                target.look_at([ex, ey, ez], [tx, ty, tz], [ux, uy, uz], loc)
            }
            "Transform" => target.transform(c.array(loc, kw)?, loc),
            "ConcatTransform" => target.concat_transform(c.array(loc, kw)?, loc),
            "CoordinateSystem" => target.coordinate_system(c.string(loc, kw)?, loc),
            "CoordSysTransform" => target.coord_sys_transform(c.string(loc, kw)?, loc),
            "ActiveTransform" => {
                let Some(Tok::Word(which)) = c.peek().map(|t| t.tok.clone()) else {
                    return Err(loc.error("ActiveTransform takes StartTime, EndTime or All"));
                };
                c.i += 1;
                let which = match which.as_str() {
                    "All" => ActiveTransform::All,
                    "StartTime" => ActiveTransform::StartTime,
                    "EndTime" => ActiveTransform::EndTime,
                    other => {
                        return Err(loc.error(format!(
                            "ActiveTransform takes StartTime, EndTime or All, got `{other}`"
                        )))
                    }
                };
                target.active_transform(which, loc)
            }
            "TransformTimes" => {
                let [start, end] = c.array(loc, kw)?;
                target.transform_times(start, end, loc)
            }
            "ReverseOrientation" => target.reverse_orientation(loc),
            "Camera" | "Film" | "Sampler" | "PixelFilter" | "Integrator" | "Accelerator"
            | "ColorSpace" => {
                let ty = c.string(loc, kw)?;
                let p = c.params(loc)?;
                match kw {
                    "Camera" => target.camera(ty, p, loc),
                    "Film" => target.film(ty, p, loc),
                    "Sampler" => target.sampler(ty, p, loc),
                    "PixelFilter" => target.pixel_filter(ty, p, loc),
                    "Integrator" => target.integrator(ty, p, loc),
                    "Accelerator" => target.accelerator(ty, p, loc),
                    _ => target.color_space(ty, p, loc),
                }
            }
            "Option" => {
                let name = c.string(loc, kw)?;
                let value = c.option_value();
                let p = c.params(loc)?;
                target.option(name, value, p, loc)
            }
            "MakeNamedMedium" => {
                let name = c.string(loc, kw)?;
                let p = c.params(loc)?;
                target.make_named_medium(name, p, loc)
            }
            "MediumInterface" => {
                let inside = c.string(loc, kw)?;
                let outside = match c.peek().map(|t| &t.tok) {
                    Some(Tok::Str(_)) => Some(c.string(loc, kw)?),
                    _ => None,
                };
                target.medium_interface(inside, outside, loc)
            }
            "Attribute" => {
                let which = c.string(loc, kw)?;
                let p = c.params(loc)?;
                target.attribute(which, p, loc)
            }
            "WorldBegin" => target.world_begin(loc),
            "WorldEnd" => target.world_end(loc),
            "MakeNamedMaterial" => {
                let name = c.string(loc, kw)?;
                let p = c.params(loc)?;
                target.make_named_material(name, p, loc)
            }
            "Material" => {
                let ty = c.string(loc, kw)?;
                let p = c.params(loc)?;
                target.material(ty, p, loc)
            }
            "NamedMaterial" => target.named_material(c.string(loc, kw)?, loc),
            "Texture" => {
                let name = c.string(loc, kw)?;
                let ty = c.string(loc, kw)?;
                let class = c.string(loc, kw)?;
                let p = c.params(loc)?;
                target.texture(name, ty, class, p, loc)
            }
            "Shape" | "LightSource" | "AreaLightSource" => {
                let ty = c.string(loc, kw)?;
                let p = c.params(loc)?;
                match kw {
                    "Shape" => target.shape(ty, p, loc),
                    "LightSource" => target.light_source(ty, p, loc),
                    _ => target.area_light_source(ty, p, loc),
                }
            }
            "Include" | "Import" => {
                let name = c.string(loc, kw)?;
                let path = loc.dir().join(&name);
                self.count_include(loc, kw)?;
                target.include(&path, loc);
                let text = self.read_text(&path, Some((loc, &format!("{kw} \"{name}\""))))?;
                self.run_file(&path, &text, Some(loc), target)
            }
            other => Err(loc.error(format!("unknown statement `{other}`"))),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::pbrt::params::{Params, Values};

    /// A target that writes down each call: the statement's place, name and arguments.
    #[derive(Default)]
    struct Recorder {
        calls: Vec<String>,
    }

    impl Recorder {
        fn note(&mut self, loc: &Loc, call: impl std::fmt::Display) -> crate::error::Result<()> {
            let file = loc.file.file_name().unwrap().to_string_lossy();
            let at = format!("{file}:{}:{}", loc.line, loc.col);
            self.calls.push(format!("{at} {call}"));
            Ok(())
        }
    }

    /// A parameter list as written, one `"type name" [values]` after another.
    fn list(p: &Params) -> String {
        let values = |v: &Values| match v {
            Values::Nums(v) => format!("{v:?}"),
            Values::Strs(v) => format!("{v:?}"),
            Values::Bools(v) => format!("{v:?}"),
        };
        let list: Vec<String> = p
            .list
            .iter()
            .map(|q| format!("\"{} {}\" {}", q.ty, q.name, values(&q.values)))
            .collect();
        list.join(" ")
    }

    impl Target for Recorder {
        fn identity(&mut self, loc: &Loc) -> crate::error::Result<()> {
            self.note(loc, "identity")
        }
        fn translate(&mut self, v: [f64; 3], loc: &Loc) -> crate::error::Result<()> {
            self.note(loc, format!("translate {v:?}"))
        }
        fn scale(&mut self, v: [f64; 3], loc: &Loc) -> crate::error::Result<()> {
            self.note(loc, format!("scale {v:?}"))
        }
        fn rotate(&mut self, angle: f64, axis: [f64; 3], loc: &Loc) -> crate::error::Result<()> {
            self.note(loc, format!("rotate {angle} {axis:?}"))
        }
        fn look_at(
            &mut self,
            e: [f64; 3],
            t: [f64; 3],
            u: [f64; 3],
            loc: &Loc,
        ) -> crate::error::Result<()> {
            self.note(loc, format!("look_at {e:?} {t:?} {u:?}"))
        }
        fn transform(&mut self, m: [f64; 16], loc: &Loc) -> crate::error::Result<()> {
            self.note(loc, format!("transform {m:?}"))
        }
        fn concat_transform(&mut self, m: [f64; 16], loc: &Loc) -> crate::error::Result<()> {
            self.note(loc, format!("concat_transform {m:?}"))
        }
        fn coordinate_system(&mut self, name: String, loc: &Loc) -> crate::error::Result<()> {
            self.note(loc, format!("coordinate_system {name}"))
        }
        fn coord_sys_transform(&mut self, name: String, loc: &Loc) -> crate::error::Result<()> {
            self.note(loc, format!("coord_sys_transform {name}"))
        }
        fn active_transform(
            &mut self,
            which: ActiveTransform,
            loc: &Loc,
        ) -> crate::error::Result<()> {
            self.note(loc, format!("active_transform {which:?}"))
        }
        fn transform_times(&mut self, start: f64, end: f64, loc: &Loc) -> crate::error::Result<()> {
            self.note(loc, format!("transform_times {start} {end}"))
        }
        fn reverse_orientation(&mut self, loc: &Loc) -> crate::error::Result<()> {
            self.note(loc, "reverse_orientation")
        }
        fn attribute_begin(&mut self, loc: &Loc) -> crate::error::Result<()> {
            self.note(loc, "attribute_begin")
        }
        fn attribute_end(&mut self, loc: &Loc) -> crate::error::Result<()> {
            self.note(loc, "attribute_end")
        }
        fn transform_begin(&mut self, loc: &Loc) -> crate::error::Result<()> {
            self.note(loc, "transform_begin")
        }
        fn transform_end(&mut self, loc: &Loc) -> crate::error::Result<()> {
            self.note(loc, "transform_end")
        }
        fn object_begin(&mut self, name: String, loc: &Loc) -> crate::error::Result<()> {
            self.note(loc, format!("object_begin {name}"))
        }
        fn object_end(&mut self, loc: &Loc) -> crate::error::Result<()> {
            self.note(loc, "object_end")
        }
        fn object_instance(&mut self, name: String, loc: &Loc) -> crate::error::Result<()> {
            self.note(loc, format!("object_instance {name}"))
        }
        fn camera(&mut self, ty: String, p: Params, loc: &Loc) -> crate::error::Result<()> {
            self.note(loc, format!("camera {ty} {}", list(&p)))
        }
        fn film(&mut self, ty: String, p: Params, loc: &Loc) -> crate::error::Result<()> {
            self.note(loc, format!("film {ty} {}", list(&p)))
        }
        fn sampler(&mut self, ty: String, p: Params, loc: &Loc) -> crate::error::Result<()> {
            self.note(loc, format!("sampler {ty} {}", list(&p)))
        }
        fn pixel_filter(&mut self, ty: String, p: Params, loc: &Loc) -> crate::error::Result<()> {
            self.note(loc, format!("pixel_filter {ty} {}", list(&p)))
        }
        fn integrator(&mut self, ty: String, p: Params, loc: &Loc) -> crate::error::Result<()> {
            self.note(loc, format!("integrator {ty} {}", list(&p)))
        }
        fn accelerator(&mut self, ty: String, p: Params, loc: &Loc) -> crate::error::Result<()> {
            self.note(loc, format!("accelerator {ty} {}", list(&p)))
        }
        fn color_space(&mut self, name: String, p: Params, loc: &Loc) -> crate::error::Result<()> {
            self.note(loc, format!("color_space {name} {}", list(&p)))
        }
        fn option(
            &mut self,
            name: String,
            value: Option<String>,
            p: Params,
            loc: &Loc,
        ) -> crate::error::Result<()> {
            self.note(loc, format!("option {name} {value:?} {}", list(&p)))
        }
        fn world_begin(&mut self, loc: &Loc) -> crate::error::Result<()> {
            self.note(loc, "world_begin")
        }
        fn world_end(&mut self, loc: &Loc) -> crate::error::Result<()> {
            self.note(loc, "world_end")
        }
        fn attribute(&mut self, target: String, p: Params, loc: &Loc) -> crate::error::Result<()> {
            self.note(loc, format!("attribute {target} {}", list(&p)))
        }
        fn make_named_medium(
            &mut self,
            name: String,
            p: Params,
            loc: &Loc,
        ) -> crate::error::Result<()> {
            self.note(loc, format!("make_named_medium {name} {}", list(&p)))
        }
        fn medium_interface(
            &mut self,
            inside: String,
            outside: Option<String>,
            loc: &Loc,
        ) -> crate::error::Result<()> {
            self.note(loc, format!("medium_interface {inside} {outside:?}"))
        }
        fn material(&mut self, ty: String, p: Params, loc: &Loc) -> crate::error::Result<()> {
            self.note(loc, format!("material {ty} {}", list(&p)))
        }
        fn make_named_material(
            &mut self,
            name: String,
            p: Params,
            loc: &Loc,
        ) -> crate::error::Result<()> {
            self.note(loc, format!("make_named_material {name} {}", list(&p)))
        }
        fn named_material(&mut self, name: String, loc: &Loc) -> crate::error::Result<()> {
            self.note(loc, format!("named_material {name}"))
        }
        fn texture(
            &mut self,
            name: String,
            ty: String,
            class: String,
            p: Params,
            loc: &Loc,
        ) -> crate::error::Result<()> {
            self.note(loc, format!("texture {name} {ty} {class} {}", list(&p)))
        }
        fn shape(&mut self, ty: String, p: Params, loc: &Loc) -> crate::error::Result<()> {
            self.note(loc, format!("shape {ty} {}", list(&p)))
        }
        fn light_source(&mut self, ty: String, p: Params, loc: &Loc) -> crate::error::Result<()> {
            self.note(loc, format!("light_source {ty} {}", list(&p)))
        }
        fn area_light_source(
            &mut self,
            ty: String,
            p: Params,
            loc: &Loc,
        ) -> crate::error::Result<()> {
            self.note(loc, format!("area_light_source {ty} {}", list(&p)))
        }
        fn include(&mut self, path: &Path, loc: &Loc) {
            let name = path.file_name().unwrap().to_string_lossy();
            self.note(loc, format!("include {name}")).unwrap();
        }
        fn end_of_files(&mut self) -> crate::error::Result<()> {
            self.calls.push("end_of_files".into());
            Ok(())
        }
    }

    /// Reads `main` (beside `part`, which it may include) with a recorder: the calls made,
    /// and the error if the reading failed.
    fn record(main: &str, part: &str) -> (Vec<String>, Option<String>, PathBuf) {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("part.pbrt"), part).unwrap();
        let path = dir.path().join("main.pbrt");
        std::fs::write(&path, main).unwrap();
        let mut recorder = Recorder::default();
        let mut parser = Parser::new(&path, &Control::default());
        let error = parser
            .read(&path, &mut recorder)
            .err()
            .map(|e| e.to_string());
        (recorder.calls, error, dir.path().to_path_buf())
    }

    #[test]
    fn the_parser_calls_the_target_once_per_statement_with_includes_in_place() {
        let main = "LookAt 0 0 5  0 0 0  0 1 0\n\
                    Camera \"perspective\" \"float fov\" [ 45 ]\n\
                    WorldBegin\n\
                    AttributeBegin\n\
                    \x20 Include \"part.pbrt\"\n\
                    \x20 Shape \"sphere\" \"float radius\" 2\n\
                    AttributeEnd # the parser checks no blocks: the target does\n\
                    AttributeEnd\n";
        let part = "ActiveTransform EndTime Rotate [ 90 0 0 1 ]\n\
                    Material \"diffuse\" \"rgb reflectance\" [ .5 .5 .5 ] \"bool x\" \"true\"\n";
        let (calls, error, _dir) = record(main, part);
        assert_eq!(error, None);
        assert_eq!(
            calls,
            [
                "main.pbrt:1:1 look_at [0.0, 0.0, 5.0] [0.0, 0.0, 0.0] [0.0, 1.0, 0.0]",
                "main.pbrt:2:1 camera perspective \"float fov\" [45.0]",
                "main.pbrt:3:1 world_begin",
                "main.pbrt:4:1 attribute_begin",
                "main.pbrt:5:3 include part.pbrt",
                "part.pbrt:1:1 active_transform EndTime",
                "part.pbrt:1:25 rotate 90 [0.0, 0.0, 1.0]",
                "part.pbrt:2:1 material diffuse \"rgb reflectance\" [0.5, 0.5, 0.5] \
                 \"bool x\" [true]",
                "main.pbrt:6:3 shape sphere \"float radius\" [2.0]",
                "main.pbrt:7:1 attribute_end",
                "main.pbrt:8:1 attribute_end",
                "end_of_files",
            ]
        );
    }

    #[test]
    fn a_syntax_error_stops_the_reading_at_its_file_line_and_column() {
        let main = "WorldBegin\nInclude \"part.pbrt\"\nShape \"sphere\"\n";
        let part = "Translate 1 2 3\n# a comment\nScale 1 1\n  Shape \"sphere\"\n";
        let (calls, error, dir) = record(main, part);
        assert_eq!(
            calls,
            [
                "main.pbrt:1:1 world_begin",
                "main.pbrt:2:1 include part.pbrt",
                "part.pbrt:1:1 translate [1.0, 2.0, 3.0]",
            ]
        );
        let part = dir.join("part.pbrt");
        assert_eq!(
            error.as_deref(),
            Some(
                format!(
                    "{}: line 4, column 3: Scale takes 3 numbers, got `Shape` after 2",
                    part.display()
                )
                .as_str()
            )
        );
        // A token the lexer refuses is an error before any statement of its file runs.
        let (calls, error, _dir) = record("Include \"part.pbrt\"", "Identity\n  \"open");
        assert_eq!(calls, ["main.pbrt:1:1 include part.pbrt"]);
        let error = error.unwrap();
        assert!(
            error.ends_with(
                "part.pbrt: line 2, column 3: unterminated string at the end of the file"
            ),
            "{error}"
        );
    }
}
