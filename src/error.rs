//! The one error type of the library. Every message is a single line that names the file
//! (or option) and the problem, ready to print after `raylink: error: `.

use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A scene, mesh or other input file is malformed; `detail` names the line or field.
    #[error("{}: {detail}", path.display())]
    Input { path: PathBuf, detail: String },
    /// An image could not be written or read.
    #[error("{}: {detail}", path.display())]
    Image { path: PathBuf, detail: String },
    /// A command-line option or render setting is invalid.
    #[error("{0}")]
    Options(String),
    /// Embree reported an error.
    #[error("embree: {0}")]
    Embree(String),
    /// The render was stopped by a signal; `detail` says what was kept.
    #[error("{detail}")]
    Interrupted { signal: i32, detail: String },
    /// The work would need more memory than --max-memory allows.
    #[error("{0}")]
    Memory(String),
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
}

impl Error {
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
}

pub type Result<T, E = Error> = std::result::Result<T, E>;

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
    }
}
