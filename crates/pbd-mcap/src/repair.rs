//! `pbd doctor --repair`: every readable record rewritten into a complete file.

use std::collections::HashMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::Path;

use crate::scan::*;
use anyhow::{Context, Result, ensure};
use mcap::records::{MessageHeader, Record};
use mcap::{Attachment, Compression, WriteOptions, Writer};

/// Rewrites every readable record of `path` (schemas, channels, messages, attachments, metadata) into
/// a new, complete MCAP file at `out`; returns the number of messages written. For a file cut short.
pub fn repair(path: impl AsRef<Path>, out: impl AsRef<Path>) -> Result<u64> {
    let (path, out) = (path.as_ref(), out.as_ref());
    ensure!(path != out, "--repair must name a new file, not {}", path.display());
    ensure!(
        std::fs::canonicalize(path)
            .ok()
            .zip(std::fs::canonicalize(out).ok())
            .is_none_or(|(a, b)| a != b),
        "--repair must name a new file, not {} again",
        path.display()
    );
    // Written beside the target and renamed at the end: never a half-written repair. (The facade
    // checks every command's inputs and outputs before this: `pbd::files::IoPlan`.)
    let name = out
        .file_name()
        .with_context(|| format!("cannot write {}: not a file name", out.display()))?;
    let tmp = out.with_file_name(format!(".{}.{}.tmp", name.to_string_lossy(), std::process::id()));
    let file = File::create(&tmp).with_context(|| format!("cannot create {}", tmp.display()))?;
    let mut writer = Writer::with_options(
        BufWriter::new(file),
        WriteOptions::new().compression(Some(Compression::Zstd)).profile(""),
    )?;
    let mut schema_ids: HashMap<u16, u16> = HashMap::new();
    let mut channel_ids: HashMap<u16, u16> = HashMap::new();
    let mut count = 0u64;
    let mut failure: Option<anyhow::Error> = None;
    let scanned = scan(Source::File(path), &mut |record| {
        if failure.is_some() {
            return;
        }
        let r: Result<()> = (|| {
            match record {
                Record::Schema { header, data } => {
                    if let std::collections::hash_map::Entry::Vacant(e) = schema_ids.entry(header.id) {
                        e.insert(writer.add_schema(&header.name, &header.encoding, &data)?);
                    }
                }
                Record::Channel(c) => {
                    if let std::collections::hash_map::Entry::Vacant(e) = channel_ids.entry(c.id) {
                        let schema = schema_ids.get(&c.schema_id).copied().unwrap_or(0);
                        e.insert(writer.add_channel(schema, &c.topic, &c.message_encoding, &c.metadata)?);
                    }
                }
                Record::Message { header, data } => {
                    if let Some(&channel_id) = channel_ids.get(&header.channel_id) {
                        writer.write_to_known_channel(&MessageHeader { channel_id, ..header }, &data)?;
                        count += 1;
                    }
                }
                Record::Attachment { header, data, .. } => {
                    writer.attach(&Attachment {
                        log_time: header.log_time,
                        create_time: header.create_time,
                        name: header.name,
                        media_type: header.media_type,
                        data,
                    })?;
                }
                Record::Metadata(m) => writer.write_metadata(&m)?,
                _ => {}
            }
            Ok(())
        })();
        if let Err(e) = r {
            failure = Some(e);
        }
    });
    let finished = match (scanned, failure) {
        (Err(e), _) => Err(e),
        (Ok(_), Some(e)) => Err(e.context(format!("cannot write {}", out.display()))),
        (Ok(_), None) => writer
            .finish()
            .map(|_| ())
            .with_context(|| format!("cannot write {}", out.display())),
    };
    if let Err(e) = finished {
        let _ = std::fs::remove_file(&tmp);
        return Err(e);
    }
    std::fs::rename(&tmp, out).with_context(|| format!("cannot write {}", out.display()))?;
    Ok(count)
}
