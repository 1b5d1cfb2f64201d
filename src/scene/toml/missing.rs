//! The files a scene names that are not there, found before the scene is built: a scene
//! missing several of them is refused with every one at once, not one per run.

use super::diagnostics::Ctx;
use crate::error::Error;
use std::path::Path;
use toml::de::{DeTable, DeValue};
use toml::Spanned;

/// Whether a string under `key` names a file the scene reads: a mesh's or an image's `file`,
/// a material's `normal_map` or tabulated `brdf`, a goniometric light's `image`.
fn names_a_file(key: &str) -> bool {
    matches!(key, "file" | "normal_map" | "brdf" | "image")
}

/// One [`Error::Input`] per file named in `root` that does not exist (relative names are
/// relative to `dir`), each naming the line and the field, in the file's order. The
/// `[render]` table is left out: the cache and network files it names are written when
/// they are not there; so are `[[instances]]`, which name no file (and may be hundreds of
/// thousands).
pub(super) fn missing_files(ctx: &Ctx, root: &DeTable, dir: &Path) -> Vec<Error> {
    let mut found = Vec::new();
    let mut at = Vec::new();
    for (key, value) in root {
        let key: &str = key.get_ref();
        if key != "render" && key != "instances" {
            at.push(Step::Key(key));
            walk(ctx, key, value, dir, &mut at, &mut found);
            at.pop();
        }
    }
    found
}

/// A step from the root to a value: a key of a table or an index of an array.
enum Step<'t> {
    Key(&'t str),
    Index(usize),
}

/// The dotted name of the value at `at` (`shapes[3].file`), made only for a file that is
/// missing: a scene of many instances walks many values and names few.
fn name_of(at: &[Step]) -> String {
    let mut name = String::new();
    for step in at {
        match step {
            Step::Key(k) if name.is_empty() => name.push_str(k),
            Step::Key(k) => {
                name.push('.');
                name.push_str(k);
            }
            Step::Index(i) => name.push_str(&format!("[{i}]")),
        }
    }
    name
}

fn walk<'t>(
    ctx: &Ctx,
    key: &str,
    value: &'t Spanned<DeValue>,
    dir: &Path,
    at: &mut Vec<Step<'t>>,
    found: &mut Vec<Error>,
) {
    match value.get_ref() {
        DeValue::String(file) if names_a_file(key) => {
            let path = dir.join(file.as_ref() as &str);
            if let Err(e) = std::fs::metadata(&path) {
                if e.kind() == std::io::ErrorKind::NotFound {
                    let line = ctx.line_at(value.span().start);
                    found.push(Error::input(
                        ctx.path,
                        format!("line {line}: {}: {file}: no such file", name_of(at)),
                    ));
                }
            }
        }
        DeValue::Table(table) => {
            for (k, v) in table {
                let k: &str = k.get_ref();
                at.push(Step::Key(k));
                walk(ctx, k, v, dir, at, found);
                at.pop();
            }
        }
        DeValue::Array(items) => {
            for (i, v) in items.iter().enumerate() {
                at.push(Step::Index(i));
                walk(ctx, key, v, dir, at, found);
                at.pop();
            }
        }
        _ => {}
    }
}
