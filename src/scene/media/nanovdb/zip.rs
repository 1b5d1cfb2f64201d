//! ZIP-compressed grids (codec 1): NanoVDB writes each grid as its compressed size (a
//! little-endian u64) and then one zlib stream (zlib's `compress`) of the grid's bytes.

use crate::error::{Error, Result};
use crate::input_file::Allowance;
use miniz_oxide::inflate::core::{decompress, inflate_flags, DecompressorOxide};
use miniz_oxide::inflate::TINFLStatus;
use std::path::Path;

/// Inflates the `stored` bytes of grid `grid` of the file at `path`, which the record says
/// hold `size` bytes once inflated; `held` bytes already count against `allowance`.
pub(super) fn inflate(
    stored: &[u8],
    size: u64,
    path: &Path,
    grid: &str,
    allowance: &Allowance,
    held: u64,
) -> Result<Vec<u8>> {
    let corrupt = |what: String| Error::input(path, format!("grid \"{grid}\" is corrupt: {what}"));
    let Some(prefix) = stored.get(..8) else {
        return Err(corrupt(format!(
            "its ZIP data takes {} bytes, too few for its compressed size",
            stored.len()
        )));
    };
    let packed = u64::from_le_bytes(prefix.try_into().expect("8 bytes"));
    let body = &stored[8..];
    if packed != body.len() as u64 {
        return Err(corrupt(format!(
            "its ZIP data says {packed} compressed bytes but the file gives it {}",
            body.len()
        )));
    }
    // The size the record claims is checked before anything is allocated for it.
    let what = || format!("the NanoVDB grid \"{grid}\" of {}", path.display());
    allowance.check(&what(), held.saturating_add(size))?;
    let size = usize::try_from(size).map_err(|_| corrupt(format!("it claims {size} bytes")))?;
    let mut out = Vec::new();
    crate::platform::try_reserve(&mut out, size, what)?;
    out.resize(size, 0);
    let flags = inflate_flags::TINFL_FLAG_PARSE_ZLIB_HEADER
        | inflate_flags::TINFL_FLAG_COMPUTE_ADLER32
        | inflate_flags::TINFL_FLAG_USING_NON_WRAPPING_OUTPUT_BUF;
    let mut state = Box::<DecompressorOxide>::default();
    let (status, read, written) = decompress(&mut state, body, &mut out, 0, flags);
    match status {
        TINFLStatus::Done if written == size && read == body.len() => Ok(out),
        TINFLStatus::Done if written != size => Err(corrupt(format!(
            "it inflates to {written} bytes, not the {size} its record says"
        ))),
        TINFLStatus::Done => Err(corrupt(format!(
            "{} bytes follow the end of its ZIP data",
            body.len() - read
        ))),
        TINFLStatus::HasMoreOutput => Err(corrupt(format!(
            "it inflates to more than the {size} bytes its record says"
        ))),
        TINFLStatus::Adler32Mismatch => Err(corrupt("its ZIP data fails its checksum".into())),
        TINFLStatus::FailedCannotMakeProgress | TINFLStatus::NeedsMoreInput => {
            Err(corrupt("its ZIP data is cut short".into()))
        }
        _ => Err(corrupt("its ZIP data is not a valid zlib stream".into())),
    }
}
