//! Reading an input file whole, with a size limit: shared plumbing of every pbd reader (robot models,
//! scenes, libraries, models, corpora), so that `--scene /dev/zero` or a mistyped multi-gigabyte path
//! is an error after a bounded read, never an exhausted memory. Also the one check of JSON inputs
//! for a key given twice in an object ([`check_json_keys`]): parsers keep one of the two silently.

use std::cell::RefCell;
use std::collections::HashSet;
use std::fmt;
use std::io::Read;
use std::path::Path;

use serde::de::{DeserializeSeed, Deserializer, MapAccess, SeqAccess, Visitor};

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

/// A key given twice in one JSON object (see [`check_json_keys`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DuplicateKey {
    /// The key's path from the top of the document, as errors name fields: `places`,
    /// `hyper.color.terms`, `objects[2].name`.
    pub path: String,
    /// Line (1-based) of the second occurrence.
    pub line: usize,
    /// Column (1-based) just after the second occurrence of the key.
    pub column: usize,
}

impl fmt::Display for DuplicateKey {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "duplicate key `{}` (second at line {} column {}): a JSON object may give each key only once",
            self.path, self.line, self.column
        )
    }
}

impl std::error::Error for DuplicateKey {}

/// Checks JSON text (one document: a file, or one line of a JSON-lines file) for an object that
/// gives a key twice, at any depth. JSON parsers accept such a document and keep one of the values
/// silently (a map the last, a struct sometimes the first), so a model with two `"places"` keys once
/// loaded as if the first were not there. Every pbd reader of JSON calls this before parsing; text
/// that is not JSON at all passes (the reader's own parser reports where it goes wrong).
pub fn check_json_keys(text: &str) -> Result<(), DuplicateKey> {
    let found = RefCell::new(None);
    let mut de = serde_json::Deserializer::from_str(text);
    let walk = Walk {
        at: &Segment::Root,
        found: &found,
    };
    match walk.deserialize(&mut de) {
        Err(e) => match found.into_inner() {
            Some(path) => Err(DuplicateKey {
                path,
                line: e.line(),
                column: e.column(),
            }),
            None => Ok(()),
        },
        Ok(()) => Ok(()),
    }
}

/// Where a value is in a JSON document: a linked list from the value up to the root, turned into a
/// path only when a duplicate is found (most documents have none).
enum Segment<'a> {
    Root,
    Key(&'a Segment<'a>, &'a str),
    Index(&'a Segment<'a>, usize),
}

impl Segment<'_> {
    fn path(&self) -> String {
        match self {
            Segment::Root => String::new(),
            Segment::Key(parent, key) => match **parent {
                Segment::Root => (*key).to_string(),
                _ => format!("{}.{key}", parent.path()),
            },
            Segment::Index(parent, i) => format!("{}[{i}]", parent.path()),
        }
    }
}

/// Visits every value of a document, remembering the keys of each object.
struct Walk<'a> {
    at: &'a Segment<'a>,
    found: &'a RefCell<Option<String>>,
}

impl<'de> DeserializeSeed<'de> for Walk<'_> {
    type Value = ();

    fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<(), D::Error> {
        d.deserialize_any(self)
    }
}

impl<'de> Visitor<'de> for Walk<'_> {
    type Value = ();

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("any JSON value")
    }

    fn visit_bool<E>(self, _: bool) -> Result<(), E> {
        Ok(())
    }

    fn visit_i64<E>(self, _: i64) -> Result<(), E> {
        Ok(())
    }

    fn visit_u64<E>(self, _: u64) -> Result<(), E> {
        Ok(())
    }

    fn visit_i128<E>(self, _: i128) -> Result<(), E> {
        Ok(())
    }

    fn visit_u128<E>(self, _: u128) -> Result<(), E> {
        Ok(())
    }

    fn visit_f64<E>(self, _: f64) -> Result<(), E> {
        Ok(())
    }

    fn visit_str<E>(self, _: &str) -> Result<(), E> {
        Ok(())
    }

    fn visit_unit<E>(self) -> Result<(), E> {
        Ok(())
    }

    fn visit_none<E>(self) -> Result<(), E> {
        Ok(())
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<(), A::Error> {
        let mut i = 0;
        loop {
            let at = Segment::Index(self.at, i);
            let walk = Walk {
                at: &at,
                found: self.found,
            };
            if seq.next_element_seed(walk)?.is_none() {
                return Ok(());
            }
            i += 1;
        }
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<(), A::Error> {
        let mut seen = HashSet::new();
        while let Some(key) = map.next_key::<String>()? {
            let at = Segment::Key(self.at, &key);
            if seen.contains(&key) {
                *self.found.borrow_mut() = Some(at.path());
                return Err(serde::de::Error::custom("duplicate key"));
            }
            map.next_value_seed(Walk {
                at: &at,
                found: self.found,
            })?;
            seen.insert(key);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A key given twice is found at any depth and named by its path; distinct keys, the same key
    /// in sibling objects and text that is not JSON pass.
    #[test]
    fn duplicate_keys_are_found_at_any_depth() {
        let top = check_json_keys("{\"places\": [], \"a\": 1,\n \"places\": [1]}").unwrap_err();
        assert_eq!(top.path, "places");
        assert_eq!(top.line, 2);
        let deep = check_json_keys(r#"{"o": [{"n": 1}, {"n": 2, "m": {"x": 1, "x": 2}}]}"#).unwrap_err();
        assert_eq!(deep.path, "o[1].m.x");
        assert!(deep.to_string().contains("duplicate key `o[1].m.x`"), "{deep}");
        assert_eq!(
            check_json_keys(r#"{"a": {"n": 1}, "b": {"n": 1}, "c": [{"n": 1}, {"n": 2}]}"#),
            Ok(())
        );
        assert_eq!(check_json_keys(r#"[1, 2.5, -3, true, null, "s", 1e400]"#), Ok(()));
        assert_eq!(check_json_keys("{not json"), Ok(()));
        assert_eq!(check_json_keys(r#"{"a\u0062": 1, "ab": 2}"#).unwrap_err().path, "ab");
    }

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
            println!("skipped: mkfifo is not available");
            return;
        }
        let e = read_text(&f).unwrap_err();
        assert_eq!(e.kind(), std::io::ErrorKind::InvalidInput);
        assert!(e.to_string().contains("FIFO"), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
