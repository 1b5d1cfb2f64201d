//! The pbrt-v4 scene format (<https://pbrt.org/fileformat-v4>), read into a [`Scene`].
//!
//! As in pbrt-v4, reading is split in two: a parser that knows the statements and their
//! syntax only, and calls a `Target` (`target.rs`) method for each; and the builder, the
//! target that runs them against pbrt's graphics state (CTM, material, area light,
//! orientation, the attribute stack), baking every shape into world space. Object instances
//! are flattened into world-space copies, or placed as instances of a shared prototype.
//!
//! Syntax errors and invalid values are errors naming the file, line and column. What pbrt
//! has and raylink does not (other shape, material, light or texture types, parameters
//! raylink ignores) is reported once as a warning in [`Scene::warnings`] and replaced by the
//! closest substitute; docs/scene-format.md lists the mapping.
//!
//! The parser: `parser.rs` reads the statements (and included files in place) and calls
//! the `target.rs` trait, `lexer.rs` splits a file into tokens with positions, `cursor.rs`
//! reads a statement's arguments and parameter lists (checked by `params.rs`), and
//! `limits.rs` bounds the text read, the includes and the memory the text takes.
//!
//! The builder: `builder.rs` holds the scene being made and finishes it, `statements.rs`
//! implements the target, `state.rs` holds the graphics state and its stack, `options.rs`
//! the rendering options and the camera, `motion.rs` the animated transforms, and
//! `cost.rs` counts the geometry against the memory budget (object instances before they
//! are copied, `instances.rs` places them). The world block: `materials.rs`,
//! `textures.rs`, `lights.rs`, `media.rs` and `shape_statement.rs` (the geometry itself from
//! `shapes.rs`, cut-outs from `alpha.rs`), their spectrum and texture parameters from
//! `param_values.rs` and `spectrum.rs`.

mod alpha;
mod builder;
mod cost;
mod cursor;
mod instances;
mod lexer;
mod lights;
mod limits;
mod materials;
mod media;
mod motion;
mod options;
mod param_values;
mod params;
mod parser;
mod shape_statement;
mod shapes;
mod spectrum;
mod state;
mod statements;
mod target;
mod textures;

use crate::control::Control;
use crate::error::Error;
use crate::scene::Scene;
use builder::Builder;
use params::ParamError;
use parser::Parser;
use std::path::{Path, PathBuf};
use std::sync::Arc;

pub(crate) use cost::Cost as GeometryCost;
pub use limits::{MAX_INCLUDES, MAX_INCLUDE_DEPTH, MAX_SCENE_TEXT};
pub(crate) use shapes::instance as placed_copies;

/// Reads a pbrt-v4 scene file (and the files it includes).
pub fn read(path: &Path, control: &Control) -> crate::error::Result<Scene> {
    let mut parser = Parser::new(path, control);
    let mut builder = Builder::new(path, control.budget, parser.held());
    if let Err(e) = parser.read(path, &mut builder) {
        return Err(builder.failed(e));
    }
    builder.finish()
}

/// Reads pbrt-v4 scene text; `path` names it in messages and anchors relative paths.
pub fn from_str(text: &str, path: &Path) -> crate::error::Result<Scene> {
    from_str_with(text, path, &Control::default())
}

/// [`from_str`] under a job's controls: stopped between statements once the control's token
/// is cancelled, and refused (before the memory is taken) once the text being read and the
/// geometry read so far would need more than its memory budget.
pub(crate) fn from_str_with(
    text: &str,
    path: &Path,
    control: &Control,
) -> crate::error::Result<Scene> {
    let mut parser = Parser::new(path, control);
    let mut builder = Builder::new(path, control.budget, parser.held());
    if let Err(e) = parser.parse(path, text, &mut builder) {
        return Err(builder.failed(e));
    }
    builder.finish()
}

/// Where a statement is: its file, line and column.
#[derive(Clone, Debug)]
struct Loc {
    file: Arc<PathBuf>,
    line: u32,
    col: u32,
}

impl Loc {
    fn error(&self, msg: impl std::fmt::Display) -> Error {
        Error::input(
            self.file.as_path(),
            format!("line {}, column {}: {msg}", self.line, self.col),
        )
    }

    fn at(&self, line: u32, col: u32) -> Loc {
        Loc {
            file: self.file.clone(),
            line,
            col,
        }
    }

    fn param_error(&self, e: ParamError) -> Error {
        self.at(e.line, e.col).error(e.msg)
    }

    fn dir(&self) -> PathBuf {
        self.file
            .parent()
            .map(Path::to_path_buf)
            .unwrap_or_default()
    }
}
