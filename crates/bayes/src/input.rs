//! Reading an input file whole, with a size limit: shared plumbing of every pbd reader (robot models,
//! scenes, libraries, models, corpora), so that `--scene /dev/zero` or a mistyped multi-gigabyte path
//! is an error after a bounded read, never an exhausted memory.

use std::io::Read;
use std::path::Path;

/// The default limit on one input file: 256 MiB.
pub const DEFAULT_MAX_INPUT_BYTES: u64 = 256 << 20;

/// The limit on one input file: `PBD_MAX_INPUT_BYTES` if set to a number, else
/// [`DEFAULT_MAX_INPUT_BYTES`].
pub fn max_input_bytes() -> u64 {
    std::env::var("PBD_MAX_INPUT_BYTES")
        .ok()
        .and_then(|s| s.trim().parse().ok())
        .unwrap_or(DEFAULT_MAX_INPUT_BYTES)
}

/// Reads the UTF-8 text file at `path`, failing with [`std::io::ErrorKind::InvalidData`] once more
/// than [`max_input_bytes`] bytes have been read (devices and pipes included, whose size is unknown).
pub fn read_text(path: &Path) -> std::io::Result<String> {
    let max = max_input_bytes();
    let file = std::fs::File::open(path)?;
    let mut text = String::new();
    file.take(max.saturating_add(1)).read_to_string(&mut text)?;
    if text.len() as u64 > max {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("larger than the input limit of {max} bytes (set PBD_MAX_INPUT_BYTES to change it)"),
        ));
    }
    Ok(text)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_endless_device_stops_at_the_limit() {
        // The default limit (the environment is left alone: tests run in parallel threads).
        let e = read_text(Path::new("/dev/zero"));
        // /dev/zero is NUL bytes: valid UTF-8, so only the limit stops it.
        assert_eq!(e.unwrap_err().kind(), std::io::ErrorKind::InvalidData);
    }
}
