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
/// they are not there.
pub(super) fn missing_files(ctx: &Ctx, root: &DeTable, dir: &Path) -> Vec<Error> {
    let mut found = Vec::new();
    for (key, value) in root {
        let key: &str = key.get_ref();
        if key != "render" {
            walk(ctx, key, key, value, dir, &mut found);
        }
    }
    found
}

fn walk(
    ctx: &Ctx,
    name: &str,
    key: &str,
    value: &Spanned<DeValue>,
    dir: &Path,
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
                        format!("line {line}: {name}: {file}: no such file"),
                    ));
                }
            }
        }
        DeValue::Table(table) => {
            for (k, v) in table {
                let k: &str = k.get_ref();
                walk(ctx, &format!("{name}.{k}"), k, v, dir, found);
            }
        }
        DeValue::Array(items) => {
            for (i, v) in items.iter().enumerate() {
                walk(ctx, &format!("{name}[{i}]"), key, v, dir, found);
            }
        }
        _ => {}
    }
}
