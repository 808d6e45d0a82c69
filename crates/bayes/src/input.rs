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
    let file = open_input(path)?;
    let mut text = String::new();
    file.take(max.saturating_add(1)).read_to_string(&mut text)?;
    if text.len() as u64 > max {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("larger than the input limit of {max} bytes (set PBD_MAX_INPUT_BYTES to change it)"),
        ));
    }
    // A UTF-8 byte-order mark (some editors write one) is not part of the text: JSON and TOML
    // parsers reported it as "expected value at line 1 column 1".
    if let Some(rest) = text.strip_prefix('\u{feff}') {
        return Ok(rest.to_string());
    }
    Ok(text)
}

/// Opens the input file at `path` for reading, refusing a FIFO (a named pipe) with
/// [`std::io::ErrorKind::InvalidInput`]: opening one blocks until some other process writes to it
/// (`mkfifo f; pbd doctor f` once waited forever).
pub fn open_input(path: &Path) -> std::io::Result<std::fs::File> {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if std::fs::metadata(path)?.file_type().is_fifo() {
            return Err(std::io::Error::new(
                std::io::ErrorKind::InvalidInput,
                "a FIFO (named pipe), not a file: pbd reads files (write the data to a file first)",
            ));
        }
    }
    std::fs::File::open(path)
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

    /// A UTF-8 byte-order mark is dropped.
    #[test]
    fn a_byte_order_mark_is_not_text() {
        let f = std::env::temp_dir().join(format!("bayes-bom-{}.json", std::process::id()));
        std::fs::write(&f, "\u{feff}{\"a\": 1}").unwrap();
        assert_eq!(read_text(&f).unwrap(), "{\"a\": 1}");
        let _ = std::fs::remove_file(&f);
    }

    /// A FIFO with no writer is refused at once (opening it would block forever).
    #[cfg(unix)]
    #[test]
    fn a_fifo_is_refused_without_blocking() {
        let dir = std::env::temp_dir().join(format!("bayes-fifo-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let f = dir.join("f");
        let ok = std::process::Command::new("mkfifo").arg(&f).status();
        if !ok.is_ok_and(|s| s.success()) {
            eprintln!("skipped: mkfifo is not available");
            return;
        }
        let e = read_text(&f).unwrap_err();
        assert_eq!(e.kind(), std::io::ErrorKind::InvalidInput);
        assert!(e.to_string().contains("FIFO"), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
