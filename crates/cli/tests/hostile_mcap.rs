//! Regression tests for MCAP files that `pbd doctor` once called "complete" (issue 38): two
//! recordings concatenated, a flipped header opcode, chunk times that disagree with the messages in
//! the chunk or with the summary. Each is refused or flagged naming the file and the byte offset;
//! genuine and interrupted recordings keep their verdicts.

use crate::common;

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use common::{pbd, refused, stderr, stdout};
use serde_json::Value;

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("pbd-hostile-mcap-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn s(p: &Path) -> String {
    p.display().to_string()
}

/// A short genuine recording (10 s of the `touch` script, a few hundred kB), made once.
fn recording() -> &'static [u8] {
    static BYTES: OnceLock<Vec<u8>> = OnceLock::new();
    BYTES.get_or_init(|| {
        let d = dir("genuine");
        let p = d.join("genuine.mcap");
        let o = pbd(&["record", "--script", "touch", "--max-seconds", "10", "-o", &s(&p)]);
        assert!(o.status.success(), "{}", stderr(&o));
        let bytes = std::fs::read(&p).unwrap();
        let _ = std::fs::remove_dir_all(&d);
        bytes
    })
}

/// The top-level records of an MCAP file: (opcode, offset of the record), up to the footer.
fn records(bytes: &[u8]) -> Vec<(u8, usize)> {
    let mut out = Vec::new();
    let mut at = 8;
    while at + 9 <= bytes.len() {
        let op = bytes[at];
        let len = u64::from_le_bytes(bytes[at + 1..at + 9].try_into().unwrap()) as usize;
        out.push((op, at));
        if op == 0x02 {
            break;
        }
        at += 9 + len;
    }
    out
}

/// The offset of the first top-level record with opcode `op` (the `n`th, counting from 0).
fn nth(bytes: &[u8], op: u8, n: usize) -> usize {
    records(bytes)
        .into_iter()
        .filter(|&(o, _)| o == op)
        .nth(n)
        .unwrap_or_else(|| panic!("no record {op:#04x} number {n}"))
        .1
}

fn u64_at(bytes: &[u8], at: usize) -> u64 {
    u64::from_le_bytes(bytes[at..at + 8].try_into().unwrap())
}

fn set_u64(bytes: &mut [u8], at: usize, v: u64) {
    bytes[at..at + 8].copy_from_slice(&v.to_le_bytes());
}

/// Zeroes the footer's summary CRC ("not written"), so that summary records can be edited.
fn without_summary_crc(bytes: &mut [u8]) {
    let footer = nth(bytes, 0x02, 0);
    // opcode, length, summary start, summary offset start, CRC
    bytes[footer + 9 + 16..footer + 9 + 20].fill(0);
}

/// `pbd doctor file` and `pbd doctor file --json`: the verdict is not complete, the exit status is
/// 1 (never a panic), and stderr names the file and every needle. Returns the JSON report.
fn doctor_flags(file: &Path, verdict: &str, needles: &[&str]) -> Value {
    let o = pbd(&["doctor", &s(file)]);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{}{e}", stdout(&o));
    assert!(e.contains(&s(file)), "the file is not named: {e}");
    assert!(stdout(&o).contains(&verdict.to_uppercase()), "{}", stdout(&o));
    for n in needles {
        assert!(e.contains(n), "expected {n:?} in: {e}");
    }
    let o = pbd(&["doctor", &s(file), "--json"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let d: Value = serde_json::from_str(&stdout(&o)).unwrap();
    assert_eq!(d["complete"], false, "{d:#}");
    assert_eq!(d["verdict"], verdict, "{d:#}");
    d
}

/// The control: a genuine recording is complete, one cut short is cut short (and read by `infer`).
#[test]
fn genuine_recordings_stay_complete_and_cut_ones_cut_short() {
    let d = dir("control");
    let genuine = d.join("genuine.mcap");
    std::fs::write(&genuine, recording()).unwrap();
    let o = pbd(&["doctor", &s(&genuine), "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let r: Value = serde_json::from_str(&stdout(&o)).unwrap();
    assert_eq!(r["complete"], true, "{r:#}");
    assert_eq!(r["verdict"], "complete", "{r:#}");
    assert!(r["issues"].as_array().unwrap().is_empty(), "{r:#}");
    let cut = d.join("cut.mcap");
    let bytes = recording();
    std::fs::write(&cut, &bytes[..bytes.len() * 2 / 3]).unwrap();
    doctor_flags(&cut, "cut short", &["cut short"]);
    let o = pbd(&["infer", &s(&cut), "-o", &s(&d.join("cut.infer.json"))]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("cut short"), "{}", stderr(&o));
    let _ = std::fs::remove_dir_all(&d);
}

/// `cat a.mcap b.mcap > c.mcap`: the second recording was silently ignored and the file called
/// complete. Now the bytes after the first end magic are an error naming the file and the offset,
/// in `doctor` and in every reader of recordings (`infer`, `learn` from .mcap).
#[test]
fn concatenated_recordings_are_not_one_complete_recording() {
    let d = dir("concat");
    let one = recording();
    let c = d.join("c.mcap");
    std::fs::write(&c, [one, one].concat()).unwrap();
    let at = format!(
        "{} bytes after the end of the recording at offset {}",
        one.len(),
        one.len()
    );
    let r = doctor_flags(&c, "malformed", &[&at, "two recordings concatenated?"]);
    assert!(r["problem"].as_str().unwrap().contains(&at), "{r:#}");
    let infer_out = d.join("c.infer.json");
    refused(&["infer", &s(&c), "-o", &s(&infer_out)], &[&s(&c), &at]);
    assert!(!infer_out.exists());
    let model = d.join("model.json");
    refused(&["learn", &s(&c), "-o", &s(&model)], &[&s(&c), &at]);
    assert!(!model.exists());
    // A repair keeps the first recording, as a complete file.
    let fixed = d.join("fixed.mcap");
    let o = pbd(&["doctor", &s(&c), "--repair", &s(&fixed)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = pbd(&["doctor", &s(&fixed), "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let _ = std::fs::remove_dir_all(&d);
}

/// The first record after the magic must be a header (opcode 0x01). A flip to an unknown opcode
/// once passed unnoticed; a flip to a known one is not MCAP. Either way the file and offset 8 are
/// named.
#[test]
fn a_flipped_header_opcode_is_refused_naming_the_offset() {
    let d = dir("header");
    let needle = "the first record, at offset 8, has opcode";
    for (flip, verdict) in [(0x81u8, Some("malformed")), (0x00, Some("malformed")), (0x03, None)] {
        let mut bytes = recording().to_vec();
        assert_eq!(bytes[8], 0x01, "a genuine file begins with a header");
        bytes[8] = flip;
        let f = d.join(format!("flipped-{flip:02x}.mcap"));
        std::fs::write(&f, &bytes).unwrap();
        let opcode = format!("{needle} {flip:#04x}");
        match verdict {
            Some(v) => {
                doctor_flags(&f, v, &[&opcode]);
            }
            None => refused(&["doctor", &s(&f)], &[&s(&f), "not an MCAP file", &opcode]),
        }
        refused(
            &["infer", &s(&f), "-o", &s(&d.join("f.infer.json"))],
            &[&s(&f), &opcode],
        );
    }
    let _ = std::fs::remove_dir_all(&d);
}

/// Chunk times that are not those of the messages inside, or that the chunk index or the
/// statistics record contradict, are flagged with the chunk's offset.
#[test]
fn chunk_times_that_disagree_with_the_messages_are_flagged() {
    let d = dir("chunk-times");
    // The chunk holding the most messages: the largest.
    let bytes = recording();
    let chunk = records(bytes)
        .windows(2)
        .filter(|w| w[0].0 == 0x06)
        .max_by_key(|w| w[1].1 - w[0].1)
        .unwrap()[0]
        .1;
    let (start, end) = (u64_at(bytes, chunk + 9), u64_at(bytes, chunk + 17));
    assert!(end > start, "a chunk of several messages: {start}–{end}");

    // 1. The chunk header's start time moved (the chunk CRC covers the records, not the header).
    let mut moved = bytes.to_vec();
    set_u64(&mut moved, chunk + 9, start + 1_000_000);
    let f = d.join("chunk-start.mcap");
    std::fs::write(&f, &moved).unwrap();
    let at = format!("at offset {chunk} declares messages logged");
    let r = doctor_flags(&f, "inconsistent", &[&at]);
    let issues = r["issues"].to_string();
    assert!(issues.contains(&at), "{r:#}");
    assert!(issues.contains("chunk index"), "the index disagrees too: {r:#}");

    // 2. The header and the messages agree; the chunk index in the summary does not.
    let mut index = bytes.to_vec();
    without_summary_crc(&mut index);
    let entry = records(&index)
        .into_iter()
        .filter(|&(op, at)| op == 0x08 && u64_at(&index, at + 9 + 16) == chunk as u64)
        .map(|(_, at)| at)
        .next()
        .expect("a chunk index for the chunk");
    set_u64(&mut index, entry + 9 + 8, end + 5_000_000_000);
    let f = d.join("chunk-index.mcap");
    std::fs::write(&f, &index).unwrap();
    doctor_flags(
        &f,
        "inconsistent",
        &["chunk index", &format!("at offset {chunk} holds messages logged")],
    );

    // 3. The statistics record's time range is not that of the messages.
    let mut stats = bytes.to_vec();
    without_summary_crc(&mut stats);
    let record = nth(&stats, 0x0B, 0);
    // counts: messages (8), schemas (2), channels, attachments, metadata, chunks (4 each)
    let first = record + 9 + 26;
    let t = u64_at(&stats, first);
    set_u64(&mut stats, first, t + 7);
    let f = d.join("statistics.mcap");
    std::fs::write(&f, &stats).unwrap();
    doctor_flags(&f, "inconsistent", &["the statistics record says messages are logged"]);

    // `--repair` writes fresh chunks and a fresh summary: complete.
    let fixed = d.join("fixed.mcap");
    let o = pbd(&["doctor", &s(&d.join("chunk-start.mcap")), "--repair", &s(&fixed)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = pbd(&["doctor", &s(&fixed), "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let _ = std::fs::remove_dir_all(&d);
}
