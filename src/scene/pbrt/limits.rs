//! What bounds the reading of a pbrt scene, so that a file cannot make raylink read, run or
//! allocate without end:
//!
//! - fixed limits on the scene text: [`MAX_SCENE_TEXT`] bytes read in all (the scene file and
//!   every file it includes, counted each time it is included), [`MAX_INCLUDES`] `Include` and
//!   `Import` statements run, [`MAX_INCLUDE_DEPTH`] files open inside one another;
//! - the job's memory budget, checked before the memory is taken: the text and tokens of the
//!   files being read, and the geometry read so far (object instances counted as the copies
//!   they become) with its share of the intersection structures. An `ObjectInstance` is
//!   checked before it is copied, so a scene that instances a big object many times is
//!   refused after copying at most the budget's worth.

use super::lexer::{self, Token};
use super::shapes;
use super::{Loader, Loc};
use crate::error::Error;
use crate::scene::{Geometry, Shape, Sphere};
use glam::DMat4;
use std::io::Read;
use std::path::Path;
use std::sync::OnceLock;

/// The most scene text read while reading one scene: the scene file and every file it
/// includes, each counted every time it is included. A fixed limit (1 GiB).
pub const MAX_SCENE_TEXT: u64 = 1 << 30;

/// The most `Include` and `Import` statements run while reading one scene. A fixed limit.
pub const MAX_INCLUDES: u64 = 100_000;

/// How deep `Include` and `Import` may nest.
pub const MAX_INCLUDE_DEPTH: usize = 64;

/// Bytes per primitive of the intersection structures, as `accel::build` assumes (Embree's
/// BVH with its build-time copies, or obvhs's CWBVH, and the shading data).
const ACCEL_BYTES_PER_PRIMITIVE: u64 = 256;

/// Bytes a token takes while its file is being read: the token and a small string.
const TOKEN_BYTES: u64 = std::mem::size_of::<Token>() as u64 + 32;

/// What geometry costs: the bytes of its data, and its primitives (each of which costs
/// [`ACCEL_BYTES_PER_PRIMITIVE`] more once the intersection structures are built). The TOML
/// reader counts its shapes with it too.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct Cost {
    pub(crate) data: u64,
    pub(crate) primitives: u64,
}

impl Cost {
    pub(crate) fn of(g: &Geometry) -> Cost {
        let shape = std::mem::size_of::<Shape>() as u64;
        match g {
            Geometry::Sphere(Sphere { .. }) => Cost {
                data: shape,
                primitives: 1,
            },
            Geometry::Triangles(m) => Cost {
                data: shape
                    + 12 * m.positions.len() as u64
                    + m.normals.as_ref().map_or(0, |n| 12 * n.len() as u64)
                    + m.uvs.as_ref().map_or(0, |u| 8 * u.len() as u64)
                    + 12 * m.indices.len() as u64,
                primitives: m.indices.len() as u64,
            },
            Geometry::Quads(q) => Cost {
                data: shape + 12 * q.positions.len() as u64 + 16 * q.indices.len() as u64,
                primitives: 2 * q.indices.len() as u64,
            },
        }
    }

    /// The bytes in the scene and in the intersection structures.
    pub(crate) fn bytes(self) -> u64 {
        self.data
            .saturating_add(self.primitives.saturating_mul(ACCEL_BYTES_PER_PRIMITIVE))
    }

    pub(crate) fn add(self, other: Cost) -> Cost {
        Cost {
            data: self.data.saturating_add(other.data),
            primitives: self.primitives.saturating_add(other.primitives),
        }
    }

    fn times(self, n: u64) -> Cost {
        Cost {
            data: self.data.saturating_mul(n),
            primitives: self.primitives.saturating_mul(n),
        }
    }
}

/// What one sphere of an object costs in an instance that tessellates it.
fn tessellated_sphere_cost() -> Cost {
    static COST: OnceLock<Cost> = OnceLock::new();
    *COST.get_or_init(|| {
        shapes::unit_sphere(&DMat4::IDENTITY)
            .iter()
            .fold(Cost::default(), |c, g| c.add(Cost::of(g)))
    })
}

/// An object defined by `ObjectBegin`/`ObjectEnd`: the shapes an instance shares (stored
/// once, as a prototype, when first placed), the shapes each placement copies into world
/// space, and what one placement's copies cost, with their spheres kept as spheres (a
/// transform that scales uniformly) or tessellated (one that does not).
pub(super) struct Object {
    pub(super) shapes: Vec<Shape>,
    pub(super) shared: Vec<Shape>,
    /// The prototype made of `shared`, once placed.
    pub(super) prototype: Option<u32>,
    uniform: Cost,
    tessellated: Cost,
}

impl Object {
    /// The object of `shapes`, of which those for which `copied` holds are copied into
    /// world space at each placement.
    pub(super) fn new(shapes: Vec<Shape>, copied: impl Fn(&Shape) -> bool) -> Object {
        let (shapes, shared): (Vec<Shape>, Vec<Shape>) = shapes.into_iter().partition(copied);
        let spheres = shapes
            .iter()
            .filter(|s| matches!(s.geometry, Geometry::Sphere(Sphere { .. })))
            .count() as u64;
        let uniform = shapes
            .iter()
            .fold(Cost::default(), |c, s| c.add(Cost::of(&s.geometry)));
        let sphere = Cost::of(&Geometry::Sphere(Sphere {
            center: Default::default(),
            radius: 1.0,
        }));
        let tessellated = Cost {
            data: uniform.data - spheres * sphere.data,
            primitives: uniform.primitives - spheres * sphere.primitives,
        }
        .add(tessellated_sphere_cost().times(spheres));
        Object {
            shapes,
            shared,
            prototype: None,
            uniform,
            tessellated,
        }
    }

    /// The intersection structure's share of the prototype (its data is counted as read).
    pub(super) fn prototype_cost(&self) -> Cost {
        let data = self
            .shared
            .iter()
            .fold(Cost::default(), |c, s| c.add(Cost::of(&s.geometry)));
        Cost {
            data: 0,
            primitives: data.primitives,
        }
    }

    /// What one instance costs with its spheres tessellated or not.
    pub(super) fn instance_cost(&self, uniform_scale: bool) -> Cost {
        if uniform_scale {
            self.uniform
        } else {
            self.tessellated
        }
    }
}

/// What reading the scene has taken so far, against its limits.
#[derive(Debug, Default)]
pub(super) struct Usage {
    /// Scene text read in all (files counted each time they are read).
    pub(super) text: u64,
    /// `Include` and `Import` statements run.
    pub(super) includes: u64,
    /// The geometry kept: the world's shapes and the object definitions.
    pub(super) geometry: Cost,
    /// The text and tokens of the files being read now.
    pub(super) open_files: u64,
}

impl Usage {
    /// The memory the reading holds.
    fn held(&self) -> u64 {
        self.geometry.bytes().saturating_add(self.open_files)
    }
}

/// Where a memory error happened: the statement's position, or the scene file.
fn place(at: Option<&Loc>, path: &Path) -> String {
    match at {
        Some(loc) => format!(
            "{}: line {}, column {}",
            loc.file.display(),
            loc.line,
            loc.col
        ),
        None => path.display().to_string(),
    }
}

impl Loader {
    /// Counts an `Include` or `Import` at `loc` against the include limits.
    pub(super) fn count_include(&mut self, loc: &Loc, kw: &str) -> crate::error::Result<()> {
        if self.include_stack.len() > MAX_INCLUDE_DEPTH {
            return Err(loc.error(format!(
                "{kw}: includes nest more than {MAX_INCLUDE_DEPTH} deep (a fixed limit)"
            )));
        }
        self.usage.includes += 1;
        if self.usage.includes > MAX_INCLUDES {
            return Err(loc.error(format!(
                "{kw}: the scene {} runs more than {MAX_INCLUDES} Include and Import \
                 statements, raylink's fixed limit (do its files include the same files over \
                 and over?)",
                self.source.display()
            )));
        }
        Ok(())
    }

    /// Reads a scene file within the limit on the scene text and the memory budget. `at`: the
    /// statement that includes it and its words (`Include "name"`), for messages.
    pub(super) fn read_text(
        &mut self,
        path: &Path,
        at: Option<(&Loc, &str)>,
    ) -> crate::error::Result<String> {
        let fail = |msg: String| match at {
            Some((loc, statement)) => loc.error(format!("{statement}: {msg}")),
            None => Error::input(path, msg),
        };
        let io = |e: std::io::Error| match at {
            Some(_) => fail(format!("cannot read {}: {e}", path.display())),
            None => Error::io(path, e),
        };
        let file = std::fs::File::open(path).map_err(io)?;
        let size = file.metadata().map_err(io)?.len();
        let room = MAX_SCENE_TEXT.saturating_sub(self.usage.text);
        let too_much = || {
            fail(format!(
                "{}: the scene's text would pass {} in all (every file counted each time it \
                 is included), raylink's fixed limit",
                path.display(),
                crate::control::human_size(MAX_SCENE_TEXT)
            ))
        };
        if size > room {
            return Err(too_much());
        }
        self.budget.check(
            &format!(
                "{}: the text of {}",
                place(at.map(|(loc, _)| loc), path),
                path.display()
            ),
            self.usage.held().saturating_add(size),
        )?;
        // Not trusting the size: a file may grow, or be a pipe or a device.
        let mut bytes = Vec::new();
        file.take(room + 1).read_to_end(&mut bytes).map_err(io)?;
        if bytes.len() as u64 > room {
            return Err(too_much());
        }
        String::from_utf8(bytes).map_err(|_| {
            io(std::io::Error::new(
                std::io::ErrorKind::InvalidData,
                "stream did not contain valid UTF-8",
            ))
        })
    }

    /// Splits a file's text into tokens within the memory budget, and counts the text against
    /// the limit on the scene text; [`Loader::close_file`] gives the memory back.
    pub(super) fn open_file(
        &mut self,
        path: &Path,
        text: &str,
        at: Option<&Loc>,
    ) -> crate::error::Result<(Vec<Token>, u64)> {
        self.usage.text = self.usage.text.saturating_add(text.len() as u64);
        if self.usage.text > MAX_SCENE_TEXT {
            let msg = format!(
                "the scene's text would pass {} in all (every file counted each time it is \
                 included), raylink's fixed limit",
                crate::control::human_size(MAX_SCENE_TEXT)
            );
            return Err(match at {
                Some(loc) => loc.error(msg),
                None => Error::input(path, msg),
            });
        }
        let base = self.usage.held().saturating_add(text.len() as u64);
        let room = self.budget.limit().saturating_sub(base) / TOKEN_BYTES;
        let max = usize::try_from(room).unwrap_or(usize::MAX);
        let (tokens, total) = lexer::tokenize_within(text, max).map_err(|e| {
            Error::input(
                path,
                format!("line {}, column {}: {}", e.line, e.col, e.msg),
            )
        })?;
        let bytes = (text.len() as u64).saturating_add((total as u64).saturating_mul(TOKEN_BYTES));
        self.budget.check(
            &format!(
                "{}: the text of {} ({total} tokens)",
                place(at, path),
                path.display()
            ),
            self.usage.held().saturating_add(bytes),
        )?;
        self.usage.open_files += bytes;
        Ok((tokens, bytes))
    }

    /// The memory of a file read (what [`Loader::open_file`] returned) given back.
    pub(super) fn close_file(&mut self, bytes: u64) {
        self.usage.open_files = self.usage.open_files.saturating_sub(bytes);
    }

    /// Counts geometry about to be kept against the memory budget: `cost` in the world, or in
    /// an object definition (`in_world` false: no intersection structures are built for it).
    /// `what` names the statement in the message.
    pub(super) fn reserve(
        &mut self,
        loc: &Loc,
        what: &str,
        cost: Cost,
        in_world: bool,
    ) -> crate::error::Result<()> {
        let cost = if in_world {
            cost
        } else {
            Cost {
                data: cost.data,
                primitives: 0,
            }
        };
        let geometry = self.usage.geometry.add(cost);
        let needed = geometry.bytes().saturating_add(self.usage.open_files);
        self.budget.check(
            &format!(
                "{}: {what}: the scene's geometry ({} primitives so far) and its intersection \
                 structures",
                place(Some(loc), &self.source),
                geometry.primitives
            ),
            needed,
        )?;
        self.usage.geometry = geometry;
        Ok(())
    }

    /// Records a file the scene reads (once, however often it is read).
    pub(super) fn add_input(&mut self, path: &Path) {
        if self.input_set.insert(path.to_path_buf()) {
            self.inputs.push(path.to_path_buf());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vec3;
    use crate::scene::TriangleMesh;

    #[test]
    fn costs_count_the_data_and_the_primitives() {
        let mesh = Geometry::Triangles(TriangleMesh {
            positions: vec![Vec3::ZERO; 4],
            normals: Some(vec![Vec3::Z; 4]),
            uvs: None,
            indices: vec![[0, 1, 2], [0, 2, 3]],
        });
        let c = Cost::of(&mesh);
        let shape = std::mem::size_of::<Shape>() as u64;
        assert_eq!(c.data, shape + 48 + 48 + 24);
        assert_eq!(c.primitives, 2);
        assert_eq!(c.bytes(), c.data + 512);
        let ball = Shape {
            geometry: Geometry::Sphere(Sphere {
                center: Vec3::ZERO,
                radius: 1.0,
            }),
            material: 0,
            alpha: None,
            motion: None,
        };
        let object = Object::new(vec![ball.clone(), ball], |_| true);
        assert_eq!(object.instance_cost(true).primitives, 2);
        let t = tessellated_sphere_cost();
        assert!(t.primitives > 1000, "{t:?}");
        assert_eq!(object.instance_cost(false), t.times(2));
    }
}
