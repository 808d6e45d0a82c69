//! Reading a log's messages back ([`read_recording`]) and any message as JSON ([`message_json`]).

use std::collections::{BTreeMap, HashMap};
use std::path::Path;

use crate::scan::*;
use anyhow::Result;
use foxglove::messages as fm;
use mcap::records::Record;
use serde::Serialize;

/// One message of a pbd log as JSON, whatever its encoding: pbd's own (`json`) as written,
/// Foxglove's (`protobuf`, by schema name) decoded with the `foxglove` crate's types and shown with
/// that crate's field names (Foxglove's, lower-cased: a calibration's `K` is `k`; bytes as base64,
/// enums by name), and ROS 2's (`cdr`, by type name) with the field names of their definitions
/// (pbd's own `pbd_msgs` as the JSON of the other encoding) — what the tests read, and what a
/// script can print.
pub fn message_json(schema_name: &str, message_encoding: &str, data: &[u8]) -> Result<serde_json::Value> {
    fn decode<T: prost::Message + Default + Serialize>(data: &[u8]) -> Result<serde_json::Value> {
        Ok(serde_json::to_value(T::decode(data)?)?)
    }
    match message_encoding {
        "json" => Ok(serde_json::from_slice(data)?),
        "protobuf" => match schema_name {
            "foxglove.FrameTransforms" => decode::<fm::FrameTransforms>(data),
            "foxglove.SceneUpdate" => decode::<fm::SceneUpdate>(data),
            "foxglove.Log" => decode::<fm::Log>(data),
            "foxglove.CompressedImage" => decode::<fm::CompressedImage>(data),
            "foxglove.CompressedVideo" => decode::<fm::CompressedVideo>(data),
            "foxglove.RawImage" => decode::<fm::RawImage>(data),
            "foxglove.CameraCalibration" => decode::<fm::CameraCalibration>(data),
            other => anyhow::bail!("Protobuf schema `{other}` is not one pbd writes"),
        },
        "cdr" => crate::ros2::message_json(schema_name, data),
        other => anyhow::bail!("message encoding `{other}` is not one pbd writes"),
    }
}

/// Messages of some topics read back from a log, with its metadata and attachments.
#[derive(Debug, Clone, Default)]
pub struct Recording {
    /// (topic, log time ns, payload) in file order: JSON on pbd's own topics whatever the log's
    /// encoding (a ROS 2 log's `pbd_msgs` are converted back), Protobuf on Foxglove's (JSON in
    /// recordings before 2026-11-29) or CDR on their ROS 2 counterparts ([`message_json`] reads
    /// each).
    pub messages: Vec<(String, u64, Vec<u8>)>,
    /// Metadata records by name.
    pub metadata: BTreeMap<String, BTreeMap<String, String>>,
    /// Attachments by name.
    pub attachments: BTreeMap<String, Vec<u8>>,
    /// How the file ended.
    pub status: Option<FileStatus>,
    /// Damaged chunks that were skipped (see [`Summary::skipped_chunks`]).
    pub skipped_chunks: Vec<String>,
    /// Channels on a wanted topic that were skipped because pbd did not write them: neither JSON
    /// with a JSON Schema, nor Protobuf with a `foxglove.*` schema, nor CDR of a ROS 2 type pbd
    /// writes.
    pub foreign_channels: Vec<String>,
}

impl Recording {
    /// Payloads on `topic`, with their log times (ns).
    pub fn topic<'a>(&'a self, topic: &'a str) -> impl Iterator<Item = (u64, &'a [u8])> + 'a {
        self.messages
            .iter()
            .filter(move |(t, _, _)| t == topic)
            .map(|(_, time, data)| (*time, data.as_slice()))
    }
}

/// Reads the messages on `topics` (all topics if empty), the metadata and the attachments of the
/// MCAP file at `path`. A file cut short keeps everything up to its last complete chunk;
/// [`Recording::status`] says so.
pub fn read_recording(path: impl AsRef<Path>, topics: &[&str]) -> Result<Recording> {
    record_of(Source::File(path.as_ref()), topics)
}

/// [`read_recording`] of an MCAP file held in memory (`bytes` is the whole file); errors name it
/// `<memory>`.
pub fn read_recording_bytes(bytes: &[u8], topics: &[&str]) -> Result<Recording> {
    record_of(Source::Bytes(bytes), topics)
}

fn record_of(source: Source<'_>, topics: &[&str]) -> Result<Recording> {
    // Topic, and the `pbd_msgs` type to convert to JSON.
    let mut wanted: HashMap<u16, (String, Option<String>)> = HashMap::new();
    let mut schemas: HashMap<u16, (String, String)> = HashMap::new();
    let mut rec = Recording::default();
    let scanned = scan(source, &mut |record| match record {
        Record::Schema { header, .. } => {
            schemas.insert(header.id, (header.name, header.encoding));
        }
        Record::Channel(c) if topics.is_empty() || topics.contains(&c.topic.as_str()) => {
            // pbd's own messages are JSON with a JSON Schema (or none), Foxglove's well-known ones
            // Protobuf (JSON before 2026-11-29): both are read (decode with [`message_json`]);
            // anything else is not ours.
            let schema = schemas.get(&c.schema_id);
            let foreign_schema = c.schema_id != 0 && schema.is_none_or(|(_, enc)| enc != "jsonschema");
            let foxglove_proto =
                c.message_encoding == "protobuf" && schema.is_some_and(|(name, _)| name.starts_with("foxglove."));
            let ros2 = c.message_encoding == "cdr"
                && schema.is_some_and(|(name, enc)| enc == "ros2msg" && crate::ros2::schema(name).is_ok());
            if (c.message_encoding == "json" && !foreign_schema) || foxglove_proto {
                wanted.insert(c.id, (c.topic, None));
            } else if ros2 {
                let name = schema.map(|(name, _)| name.clone()).unwrap_or_default();
                let pbd = name.starts_with("pbd_msgs/").then_some(name);
                wanted.insert(c.id, (c.topic, pbd));
            } else {
                let what = match schema {
                    Some((name, enc)) => format!("schema `{name}` ({enc})"),
                    None if c.schema_id != 0 => format!("unknown schema id {}", c.schema_id),
                    None => "no schema".into(),
                };
                let note = format!(
                    "channel {} on {} has message encoding `{}` and {what}; pbd reads the JSON, Foxglove Protobuf and ROS 2 CDR channels it writes — skipped",
                    c.id, c.topic, c.message_encoding
                );
                if !rec.foreign_channels.contains(&note) {
                    rec.foreign_channels.push(note);
                }
            }
        }
        Record::Message { header, data } => {
            if let Some((topic, pbd)) = wanted.get(&header.channel_id) {
                let data = match pbd {
                    // A message that does not decode is kept as it is: its reader names it.
                    Some(ty) => match crate::ros2::pbd_json(ty, &data) {
                        Ok(Some(json)) => json,
                        _ => data.into_owned(),
                    },
                    None => data.into_owned(),
                };
                rec.messages.push((topic.clone(), header.log_time, data));
            }
        }
        Record::Metadata(m) => {
            rec.metadata.insert(m.name, m.metadata);
        }
        Record::Attachment { header, data, .. } => {
            rec.attachments.insert(header.name, data.into_owned());
        }
        _ => {}
    })?;
    if let FileStatus::Malformed { reason } = &scanned.status {
        anyhow::bail!("{}: {reason}; `pbd doctor` says more", source.name());
    }
    let count = rec.messages.len() as u64;
    rec.skipped_chunks = scanned.skipped;
    rec.status = Some(match scanned.status {
        FileStatus::Recovered { reason, .. } => FileStatus::Recovered {
            messages: count,
            reason,
        },
        s => s,
    });
    Ok(rec)
}
