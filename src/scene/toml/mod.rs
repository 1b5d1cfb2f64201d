//! The native scene format (documented in docs/scene-format.md).
//!
//! Reading happens in two steps: serde + toml turn the text into the `*Desc` structures of
//! `schema` (syntax, unknown keys and wrong types are caught there, with toml's line and
//! column), then the `builder` checks the values and bakes transforms into world-space
//! geometry. Every problem becomes an [`Error::input`](crate::error::Error::input) whose detail is
//! one line that starts with the line number and names the field, e.g.
//! `line 12: shapes[2].radius: must be positive, got -1`.
//!
//! - `schema.rs`: the serde structures that mirror the file (read here, written by
//!   [`convert`](super::convert)).
//! - `builder.rs` (and `builder/shapes.rs`): the schema turned into a [`Scene`].
//! - `checks.rs`: value checks, transforms and the geometry checks of polygons and meshes.
//! - `diagnostics.rs`: one-line messages with the file, line and field.
//! - `missing.rs`: the files the scene names that are not there, all found before building.

mod builder;
mod checks;
mod diagnostics;
mod missing;
pub(crate) mod schema;
mod schema_alpha;
mod schema_coating;
mod schema_instance;
mod schema_medium;
mod schema_metal;
mod schema_texture;
mod schema_values;

use super::Scene;
use builder::Builder;
use diagnostics::Ctx;
use schema::FileDesc;
use serde::Deserialize;
use std::path::Path;
use toml::de::DeTable;
use toml::Spanned;

/// Reads a native TOML scene.
pub fn read(path: &Path) -> crate::error::Result<Scene> {
    let text = crate::input_file::read_to_string(path, &crate::input_file::TOML_SCENE, None)?;
    from_str(&text, path)
}

/// Parses a native TOML scene; `path` names the file in messages and resolves relative paths.
pub fn from_str(text: &str, path: &Path) -> crate::error::Result<Scene> {
    Document::parse(text, path)?.build()
}

/// About the most memory toml's parse tree of `text` takes, from the text alone, before it
/// is parsed. The tree holds every key, value, table and array with its place in the file,
/// many times the text: a 300 000-instance scene of 22.7 MB peaks at 1.1 GB while it is
/// parsed (3.7 KB an instance), a 400 000-vertex inline mesh of 17.5 MB at 0.86 GB (about 220
/// bytes an array element). Counted from the characters that open them, with the
/// allocator's share: 320 bytes for an array or an element after a comma, 640 for a key or an
/// inline table (hash-map entries). A string holding such characters counts too, so this
/// errs high.
pub(crate) fn parse_tree_bytes(text: &str) -> u64 {
    let (mut small, mut large) = (0u64, 0u64);
    for b in text.bytes() {
        match b {
            b',' | b'[' => small += 1,
            b'=' | b'{' => large += 1,
            _ => {}
        }
    }
    small * 320 + large * 640
}

/// A scene file parsed as TOML (syntax checked, nothing else): what decides whether the file
/// is a static scene or an animation, then reads as either without parsing the text again.
pub(crate) struct Document<'a> {
    ctx: Ctx<'a>,
    root: Spanned<DeTable<'a>>,
}

impl<'a> Document<'a> {
    /// Parses `text`; `path` names the file in messages.
    pub(crate) fn parse(text: &'a str, path: &'a Path) -> crate::error::Result<Document<'a>> {
        Document::parse_with(text, path, None)
    }

    /// [`parse`](Self::parse), and a build under a job's controls: it stops between shapes
    /// once the control's token is cancelled, and is refused once the shapes read so far (with
    /// their intersection structures) would need more than its memory budget.
    pub(crate) fn parse_with(
        text: &'a str,
        path: &'a Path,
        control: Option<&'a crate::control::Control>,
    ) -> crate::error::Result<Document<'a>> {
        let ctx = Ctx {
            path,
            text,
            control,
        };
        let root = DeTable::parse(text).map_err(|e| ctx.toml_error(&e))?;
        Ok(Document { ctx, root })
    }

    /// The top-level table.
    pub(crate) fn root(&self) -> &DeTable<'a> {
        self.root.get_ref()
    }

    /// The file, as messages name it.
    pub(crate) fn path(&self) -> &'a Path {
        self.ctx.path
    }

    /// Reads the document as a static scene.
    pub(crate) fn build(self) -> crate::error::Result<Scene> {
        let ctx = self.ctx;
        // Several files missing are all reported; one is left to the builder, which says
        // what reading it found.
        let dir = ctx.path.parent().unwrap_or(Path::new(""));
        let missing = missing::missing_files(&ctx, self.root.get_ref(), dir);
        if missing.len() > 1 {
            return Err(crate::error::Error::Inputs(missing));
        }
        let file = FileDesc::deserialize(toml::de::Deserializer::from(self.root))
            .map_err(|e| ctx.toml_error(&e))?;
        Builder::new(ctx).build(file)
    }

    /// The document as a plain TOML table (values without their positions).
    pub(crate) fn into_table(self) -> crate::error::Result<toml::Table> {
        let ctx = self.ctx;
        toml::Table::deserialize(toml::de::Deserializer::from(self.root))
            .map_err(|e| ctx.toml_error(&e))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vec3;
    use crate::scene::{Geometry, Sphere, Texture};

    fn parse(text: &str) -> crate::error::Result<Scene> {
        from_str(text, Path::new("test.toml"))
    }

    const CAMERA: &str = "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\n";

    #[test]
    fn minimal_scene() {
        let s = parse(&format!(
            "{CAMERA}[materials.white]\ndiffuse = 0.8\n[[shapes]]\ntype = \"sphere\"\n\
             material = \"white\"\nradius = 2\n"
        ))
        .unwrap();
        assert_eq!(s.camera.width, 640);
        assert_eq!(s.camera.height, 480);
        assert_eq!(
            s.materials[0].approximation().diffuse,
            Texture::Constant(Vec3::splat(0.8))
        );
        assert_eq!(
            s.shapes[0].geometry,
            Geometry::Sphere(Sphere {
                center: Vec3::ZERO,
                radius: 2.0
            })
        );
    }

    #[test]
    fn semantic_errors_name_the_line_of_the_key() {
        let text = format!(
            "{CAMERA}[materials.white]\n\n[[shapes]]\ntype = \"sphere\"\nmaterial = \"white\"\n\
             radius = -1\n"
        );
        let e = parse(&text).unwrap_err().to_string();
        assert_eq!(
            e,
            "test.toml: line 9: shapes[0].radius: must be positive, got -1"
        );
    }

    #[test]
    fn toml_errors_are_one_line() {
        let e = parse(&format!("{CAMERA}fov = \"wide\"\n"))
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("test.toml: line 4, column 7: invalid type"),
            "{e}"
        );
        assert!(!e.contains('\n'));
        let e = parse(&format!(
            "{CAMERA}[[shapes]]\ntype = \"sphere\"\nradiu = 1\n"
        ))
        .unwrap_err()
        .to_string();
        assert!(e.contains("line 6, column 1: unknown field `radiu`"), "{e}");
    }

    #[test]
    fn inline_tables_and_transform_steps() {
        let s = parse(&format!(
            "{CAMERA}[materials.m]\n[[shapes]]\ntype = \"quad\"\nmaterial = \"m\"\n\
             vertices = [[0,0,0],[1,0,0],[1,1,0],[0,1,0]]\n\
             transform = [{{ scale = 2 }}, {{ rotate = {{ axis = [0,1,0], degrees = 90 }} }}, \
             {{ translate = [0, 0, 1] }}]\n"
        ))
        .unwrap();
        let Geometry::Quads(q) = &s.shapes[0].geometry else {
            panic!("not a quad")
        };
        // (1,0,0) scaled to (2,0,0), rotated 90 degrees about +y to (0,0,-2), moved to z=-1.
        assert!((q.positions[1] - Vec3::new(0.0, 0.0, -1.0)).length() < 1e-5);
    }
}
