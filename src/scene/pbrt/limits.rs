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
//!
//! The parser holds the text to the limits here; the builder counts the geometry
//! (`cost.rs`). Both count against one budget, so they share what is [`Held`].

use super::lexer::{self, Token};
use super::parser::Parser;
use super::Loc;
use crate::error::Error;
use std::cell::Cell;
use std::io::Read;
use std::path::Path;
use std::rc::Rc;

/// The most scene text read while reading one scene: the scene file and every file it
/// includes, each counted every time it is included. A fixed limit (1 GiB).
pub const MAX_SCENE_TEXT: u64 = 1 << 30;

/// The most `Include` and `Import` statements run while reading one scene. A fixed limit.
pub const MAX_INCLUDES: u64 = 100_000;

/// How deep `Include` and `Import` may nest.
pub const MAX_INCLUDE_DEPTH: usize = 64;

/// Bytes a token takes while its file is being read: the token and a small string.
const TOKEN_BYTES: u64 = std::mem::size_of::<Token>() as u64 + 32;

/// The memory the reading holds against the job's budget: the text and tokens of the files
/// being read (the parser's) and the geometry kept (the builder's). Clones share it.
#[derive(Clone, Debug, Default)]
pub(super) struct Held(Rc<HeldBytes>);

#[derive(Debug, Default)]
struct HeldBytes {
    open_files: Cell<u64>,
    geometry: Cell<u64>,
    images: Cell<u64>,
    media: Cell<u64>,
}

impl Held {
    /// The memory the reading holds.
    pub(super) fn total(&self) -> u64 {
        self.0
            .geometry
            .get()
            .saturating_add(self.0.open_files.get())
            .saturating_add(self.0.images.get())
            .saturating_add(self.0.media.get())
    }

    /// The text and tokens of the files being read now.
    pub(super) fn open_files(&self) -> u64 {
        self.0.open_files.get()
    }

    fn open(&self, bytes: u64) {
        self.0.open_files.set(self.0.open_files.get() + bytes);
    }

    fn close(&self, bytes: u64) {
        let open = self.0.open_files.get();
        self.0.open_files.set(open.saturating_sub(bytes));
    }

    /// The geometry kept (the world's shapes and the object definitions) and its share of
    /// the intersection structures.
    pub(super) fn set_geometry(&self, bytes: u64) {
        self.0.geometry.set(bytes);
    }

    /// Counts an image kept (a texture, an environment or goniometric map).
    pub(super) fn add_image(&self, image: &crate::image::Image) {
        let bytes = std::mem::size_of_val(image.pixels.as_slice()) as u64;
        self.0.images.set(self.0.images.get().saturating_add(bytes));
    }
}

impl Held {
    /// Counts the samples of a medium's grid kept.
    pub(super) fn add_medium(&self, bytes: u64) {
        self.0.media.set(self.0.media.get().saturating_add(bytes));
    }
}

impl super::builder::Builder {
    /// What reading an image may take of the budget, beside what the reading holds.
    pub(super) fn allowance(&self) -> crate::input_file::Allowance {
        crate::input_file::Allowance::new(self.budget, self.held.total())
    }
}

/// Where a memory error happened: the statement's position, or the scene file.
pub(super) fn place(at: Option<&Loc>, path: &Path) -> String {
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

impl Parser {
    /// Counts an `Include` or `Import` at `loc` against the include limits.
    pub(super) fn count_include(&mut self, loc: &Loc, kw: &str) -> crate::error::Result<()> {
        if self.include_stack.len() > MAX_INCLUDE_DEPTH {
            return Err(loc.error(format!(
                "{kw}: includes nest more than {MAX_INCLUDE_DEPTH} deep (a fixed limit)"
            )));
        }
        self.includes += 1;
        if self.includes > MAX_INCLUDES {
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
        // A FIFO, a device or a file past the fixed limit is refused before it is read.
        let (file, size) =
            crate::input_file::open(path, &crate::input_file::PBRT_SCENE).map_err(|e| {
                match (e, at) {
                    (Error::Io { source, .. }, _) => io(source),
                    (Error::Input { detail, .. }, Some(_)) => {
                        fail(format!("{}: {detail}", path.display()))
                    }
                    (e, _) => e,
                }
            })?;
        let room = MAX_SCENE_TEXT.saturating_sub(self.text);
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
            self.held.total().saturating_add(size),
        )?;
        // Not trusting the size: a file may grow while it is read.
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
    /// the limit on the scene text; [`Parser::close_file`] gives the memory back.
    pub(super) fn open_file(
        &mut self,
        path: &Path,
        text: &str,
        at: Option<&Loc>,
    ) -> crate::error::Result<(Vec<Token>, u64)> {
        self.text = self.text.saturating_add(text.len() as u64);
        if self.text > MAX_SCENE_TEXT {
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
        let base = self.held.total().saturating_add(text.len() as u64);
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
            self.held.total().saturating_add(bytes),
        )?;
        self.held.open(bytes);
        Ok((tokens, bytes))
    }

    /// The memory of a file read (what [`Parser::open_file`] returned) given back.
    pub(super) fn close_file(&mut self, bytes: u64) {
        self.held.close(bytes);
    }
}
