//! Outputs checked against the run's inputs before any work: nothing the user had is
//! overwritten.

use raylink::Error;
use std::path::PathBuf;

/// The path as the file system resolves it, for comparing: the file's own if it exists, else
/// its folder's followed by its name.
fn resolved(path: &std::path::Path) -> PathBuf {
    if let Ok(p) = path.canonicalize() {
        return p;
    }
    let dir = path.parent().filter(|d| !d.as_os_str().is_empty());
    let dir = dir.map_or_else(|| std::path::Path::new(".").into(), PathBuf::from);
    match (dir.canonicalize(), path.file_name()) {
        (Ok(d), Some(name)) => d.join(name),
        _ => path.to_path_buf(),
    }
}

/// An error if an output would overwrite one of the run's inputs (the scene, what it reads,
/// a cache, network or checkpoint): checked before any work, so that nothing the user had
/// is lost.
pub fn refuse_aliases<'a>(
    outputs: impl IntoIterator<Item = &'a PathBuf>,
    inputs: impl IntoIterator<Item = &'a PathBuf>,
) -> Result<(), Error> {
    let inputs: Vec<(PathBuf, &PathBuf)> = inputs.into_iter().map(|p| (resolved(p), p)).collect();
    for out in outputs {
        let r = resolved(out);
        if let Some((_, input)) = inputs.iter().find(|(i, _)| *i == r) {
            return Err(Error::Invalid(format!(
                "{}: the output is one of the inputs ({}); it would be overwritten",
                out.display(),
                input.display()
            )));
        }
    }
    Ok(())
}
