//! Messages: every problem becomes one line that names the file and the line (and, for
//! toml's own errors, the column), e.g. `line 12: shapes[2].radius: must be positive, got -1`.

use crate::error::Error;
use std::fmt;
use std::ops::Range;
use std::path::Path;

#[derive(Clone, Copy)]
pub(super) struct Ctx<'a> {
    pub(super) path: &'a Path,
    pub(super) text: &'a str,
    /// The job's controls: a cancel stops the reading of meshes between shapes, and the
    /// geometry read so far is checked against the memory budget after each shape.
    pub(super) control: Option<&'a crate::control::Control>,
}

/// A table of the file, for messages: its name (`shapes[2]`) and where it is.
pub(super) struct Site {
    pub(super) name: String,
    pub(super) span: Range<usize>,
}

impl Ctx<'_> {
    pub(super) fn line_at(&self, offset: usize) -> usize {
        let end = offset.min(self.text.len());
        1 + self.text.as_bytes()[..end]
            .iter()
            .filter(|&&b| b == b'\n')
            .count()
    }

    fn column_at(&self, offset: usize) -> usize {
        let end = offset.min(self.text.len());
        let bytes = &self.text.as_bytes()[..end];
        let start = bytes.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1);
        // Count characters, not bytes.
        1 + self
            .text
            .get(start..end)
            .map_or(end - start, |s| s.chars().count())
    }

    /// toml's errors span several lines (a snippet with a caret); keep the position and the
    /// message on one line.
    pub(super) fn toml_error(&self, e: &toml::de::Error) -> Error {
        let message = one_line(&e.message());
        let detail = match e.span() {
            Some(span) => format!(
                "line {}, column {}: {message}{}",
                self.line_at(span.start),
                self.column_at(span.start),
                self.snippet(span.start)
            ),
            None => message,
        };
        Error::input(self.path, detail)
    }

    /// ` (in `...`)` quoting the line around `offset`, shortened; empty for a blank line.
    fn snippet(&self, offset: usize) -> String {
        let bytes = self.text.as_bytes();
        let at = offset.min(bytes.len());
        let start = bytes[..at]
            .iter()
            .rposition(|&b| b == b'\n')
            .map_or(0, |i| i + 1);
        let end = bytes[at..]
            .iter()
            .position(|&b| b == b'\n')
            .map_or(bytes.len(), |i| at + i);
        let line = self.text.get(start..end).unwrap_or("").trim();
        if line.is_empty() {
            return String::new();
        }
        const MAX: usize = 60;
        let short: String = if line.chars().count() > MAX {
            line.chars().take(MAX - 3).chain("...".chars()).collect()
        } else {
            line.to_string()
        };
        format!(" (in `{short}`)")
    }

    /// The line on which `key` is set inside the table at `span`; the table's first line
    /// when it cannot be found.
    pub(super) fn key_line(&self, span: &Range<usize>, key: &str) -> usize {
        let span = &self.table_extent(span);
        let body = self.text.get(span.clone()).unwrap_or("");
        if !key.is_empty() {
            let bytes = body.as_bytes();
            let mut from = 0;
            while let Some(i) = body.get(from..).and_then(|s| s.find(key)) {
                let at = from + i;
                let before_ok =
                    at == 0 || matches!(bytes[at - 1], b' ' | b'\t' | b'\n' | b'\r' | b'{' | b',');
                let after = body.get(at + key.len()..).unwrap_or("");
                if before_ok && after.trim_start_matches([' ', '\t']).starts_with('=') {
                    return self.line_at(span.start + at);
                }
                from = at + key.len();
            }
        }
        self.line_at(span.start)
    }

    /// A `[table]` or `[[table]]` header's span (what toml gives for a table opened by a
    /// header) extended over the table's body, up to the next header line; any other span as
    /// it is.
    fn table_extent(&self, span: &Range<usize>) -> Range<usize> {
        let Some(head) = self.text.get(span.clone()) else {
            return span.clone();
        };
        if !head.trim_start().starts_with('[') || head.contains('=') {
            return span.clone();
        }
        let is_header = |line: &str| {
            let l = line.trim_start();
            let name = l.trim_start_matches('[').trim_start();
            l.starts_with('[')
                && name
                    .chars()
                    .next()
                    .is_some_and(|c| c.is_alphabetic() || c == '_' || c == '"' || c == '\'')
        };
        let mut end = self.text.len();
        let mut offset = span.end;
        for line in self.text[span.end..].split_inclusive('\n') {
            if offset > span.end && is_header(line) {
                end = offset;
                break;
            }
            offset += line.len();
        }
        span.start..end
    }

    /// An error about `field` (a path inside the table, may be empty) of the table `site`.
    pub(super) fn fail(&self, site: &Site, field: &str, msg: impl fmt::Display) -> Error {
        let key = field.split(['.', '[']).next().unwrap_or("");
        let line = self.key_line(&site.span, key);
        let name = match (site.name.is_empty(), field.is_empty()) {
            (_, true) => site.name.clone(),
            (true, false) => field.to_string(),
            (false, false) => format!("{}.{field}", site.name),
        };
        Error::input(
            self.path,
            format!("line {line}: {name}: {}", one_line(&msg)),
        )
    }
}

fn one_line(msg: &dyn fmt::Display) -> String {
    let text = msg.to_string();
    text.split(['\n', '\r'])
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .collect::<Vec<_>>()
        .join("; ")
}
