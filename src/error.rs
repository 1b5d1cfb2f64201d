//! The one error type of the library. Every message is a single line that names the file or
//! the setting and the problem. Settings are named as the library names them (`max_depth`,
//! `ic_accuracy`); a front end that calls them something else (a command-line flag) maps
//! [`Error::Setting`] to its own names.

use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A scene, mesh or other input file is malformed; `detail` names the line or field.
    #[error("{}: {detail}", path.display())]
    Input { path: PathBuf, detail: String },
    /// Several inputs at once, one [`Error::Input`] each (the files a scene names that are
    /// missing); shown as one line joined by "; ", and by the command line one line each.
    #[error("{}", .0.iter().map(ToString::to_string).collect::<Vec<_>>().join("; "))]
    Inputs(Vec<Error>),
    /// An image could not be written or read.
    #[error("{}: {detail}", path.display())]
    Image { path: PathBuf, detail: String },
    /// One setting of a job is invalid or does not apply: `name` is the setting's name
    /// (see [`crate::Settings`]), `detail` the rest of the sentence.
    #[error("{name} {detail}")]
    Setting { name: String, detail: String },
    /// A request that is invalid as a whole (not one setting's fault).
    #[error("{0}")]
    Invalid(String),
    /// Embree reported an error.
    #[error("embree: {0}")]
    Embree(String),
    /// A library loaded at run time (OpenImageIO) could not be loaded.
    #[error("{0}")]
    Library(String),
    /// The caller cancelled work that had nothing to keep.
    #[error("cancelled during {stage}; nothing was kept")]
    Cancelled { stage: String },
    /// The work would need more memory than the job's budget allows.
    #[error("{what} would need {} of memory, more than the budget of {}{}",
        human_size(*needed), human_size(*limit),
        if *default_limit { " (3/4 of the physical memory)" } else { "" })]
    Memory {
        what: String,
        needed: u64,
        limit: u64,
        /// The budget was the machine's default, not one the caller chose.
        default_limit: bool,
    },
    /// Memory for `what` (`bytes` of it) could not be allocated: the system has none left to
    /// give (or a limit such as `ulimit -v` refused it).
    #[error("cannot allocate {} for {what}: out of memory", human_size(*bytes))]
    OutOfMemory { what: String, bytes: u64 },
    /// Reading or writing a file failed.
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
}

impl Error {
    /// `errors` as one: none is `None`, one is itself, more are [`Error::Inputs`].
    pub fn joined(mut errors: Vec<Error>) -> Option<Error> {
        match errors.len() {
            0 => None,
            1 => Some(errors.remove(0)),
            _ => Some(Error::Inputs(errors)),
        }
    }

    pub fn input(path: impl Into<PathBuf>, detail: impl Into<String>) -> Self {
        Error::Input {
            path: path.into(),
            detail: one_line(&detail.into()),
        }
    }

    pub fn image(path: impl Into<PathBuf>, detail: impl Into<String>) -> Self {
        Error::Image {
            path: path.into(),
            detail: one_line(&detail.into()),
        }
    }

    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Error::Io {
            path: path.into(),
            source,
        }
    }

    /// A problem with the setting `name`: `detail` completes the sentence ("must be at
    /// most 1024, got 2000").
    pub fn setting(name: &str, detail: impl Into<String>) -> Self {
        Error::Setting {
            name: name.to_string(),
            detail: one_line(&detail.into()),
        }
    }
}

pub type Result<T, E = Error> = std::result::Result<T, E>;

/// A size for people: "1.5 GiB".
pub fn human_size(bytes: u64) -> String {
    let units = ["bytes", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"];
    let mut v = bytes as f64;
    let mut u = 0;
    while v >= 1024.0 && u + 1 < units.len() {
        v /= 1024.0;
        u += 1;
    }
    if u == 0 {
        format!("{bytes} bytes")
    } else {
        format!("{v:.1} {}", units[u])
    }
}

/// `text` on one line: control characters (a newline inside a quoted string of the input,
/// say) are written as escapes, so that every message stays one line.
pub fn one_line(text: &str) -> String {
    if !text.chars().any(char::is_control) {
        return text.to_string();
    }
    text.chars()
        .map(|c| match c {
            '\n' => "\\n".to_string(),
            '\r' => "\\r".to_string(),
            '\t' => " ".to_string(),
            c if c.is_control() => c.escape_default().to_string(),
            c => c.to_string(),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    #[test]
    fn messages_are_one_line() {
        let e = super::Error::input("a.pbrt", "declaration \"rgb reflect\nce\" is bad\r\u{7}");
        assert_eq!(
            e.to_string(),
            "a.pbrt: declaration \"rgb reflect\\nce\" is bad\\r\\u{7}"
        );
        let s = super::Error::setting("max_depth", "must be at most 1024, got 2000");
        assert_eq!(s.to_string(), "max_depth must be at most 1024, got 2000");
    }
}
