//! Reading a log start to end without trusting it: the summary, every issue found, damaged chunks
//! skipped and files cut short recovered.

use std::collections::{BTreeMap, HashMap};
use std::io::Read;
use std::path::Path;

use anyhow::{Context, Result};
use mcap::records::Record;
use mcap::sans_io::linear_reader::{LinearReadEvent, LinearReader, LinearReaderOptions};

/// What an MCAP file holds, from reading it start to end (see [`read_summary`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Summary {
    /// File size (bytes).
    pub file_bytes: u64,
    /// Whether the file ended properly.
    pub status: FileStatus,
    /// Every channel seen, by topic.
    pub channels: Vec<ChannelSummary>,
    /// Messages read, all channels.
    pub message_count: u64,
    /// Log times of the first and last message (ns), if any.
    pub time_range_ns: Option<(u64, u64)>,
    /// Attachment names, in file order.
    pub attachments: Vec<String>,
    /// Metadata record names, in file order.
    pub metadata: Vec<String>,
    /// Disagreements between what was read and the file's own records: chunk headers whose times are
    /// not those of their messages, chunk indexes and a statistics record that disagree with them.
    pub issues: Vec<String>,
    /// Damaged chunks that were skipped (their CRC or compression failed); everything else was read.
    pub skipped_chunks: Vec<String>,
}

impl Summary {
    /// The channel on `topic`.
    pub fn channel(&self, topic: &str) -> Option<&ChannelSummary> {
        self.channels.iter().find(|c| c.topic == topic)
    }

    /// Messages on `topic` (0 if there is no such channel).
    pub fn count(&self, topic: &str) -> u64 {
        self.channel(topic).map_or(0, |c| c.message_count)
    }

    /// Time from the first to the last message (s).
    pub fn duration_secs(&self) -> f64 {
        self.time_range_ns.map_or(0.0, |(a, b)| (b - a) as f64 * 1e-9)
    }
}

/// How an MCAP file ended.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum FileStatus {
    /// Read to the end magic without error: the writer finished it.
    Complete,
    /// Cut short or damaged (the writer crashed, or the disk filled): everything before the first
    /// bad record was read, and `messages` messages were recovered.
    Recovered {
        /// Messages recovered.
        messages: u64,
        /// What stopped the reader.
        reason: String,
    },
    /// Not one well-formed recording: its first record is not a header, or bytes follow its end
    /// magic (two recordings concatenated, data appended). Everything up to the end magic was read;
    /// [`read_recording`] refuses such a file, [`read_summary`] reports it.
    Malformed {
        /// What is wrong, with the byte offset.
        reason: String,
    },
}

/// One channel of a [`Summary`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ChannelSummary {
    /// Topic.
    pub topic: String,
    /// Schema name (`foxglove.FrameTransforms`, …), empty if none.
    pub schema_name: String,
    /// Message encoding (`json`).
    pub message_encoding: String,
    /// Messages read.
    pub message_count: u64,
    /// Log times of its first and last message (ns), if any.
    pub time_range_ns: Option<(u64, u64)>,
}

/// Largest record the reader accepts (a corrupt length must not allocate gigabytes).
const READ_RECORD_LIMIT: usize = 1 << 30;

/// Reads the MCAP file at `path` start to end, validating chunk CRCs, and counts messages per
/// channel. A file that was cut short (a crashed writer) is not an error: its readable part is
/// summarised and [`Summary::status`] says [`FileStatus::Recovered`]. Errors are for files that
/// cannot be opened or read, or are not MCAP at all.
pub fn read_summary(path: impl AsRef<Path>) -> Result<Summary> {
    summarise(Source::File(path.as_ref()))
}

/// [`read_summary`] of an MCAP file held in memory (`bytes` is the whole file); errors name it
/// `<memory>`. For fuzzing and for callers that already hold the bytes.
pub fn read_summary_bytes(bytes: &[u8]) -> Result<Summary> {
    summarise(Source::Bytes(bytes))
}

/// Where [`scan`] reads an MCAP file from.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Source<'a> {
    File(&'a Path),
    Bytes(&'a [u8]),
}

impl Source<'_> {
    /// The name errors give the input.
    pub(crate) fn name(&self) -> String {
        match self {
            Source::File(path) => path.display().to_string(),
            Source::Bytes(_) => "<memory>".to_owned(),
        }
    }
}

fn summarise(source: Source<'_>) -> Result<Summary> {
    let mut schemas: HashMap<u16, String> = HashMap::new();
    // channel id -> index into `channels`
    let mut channel_index: HashMap<u16, usize> = HashMap::new();
    let mut channels: Vec<ChannelSummary> = Vec::new();
    let mut summary = Summary {
        file_bytes: 0,
        status: FileStatus::Complete,
        channels: Vec::new(),
        message_count: 0,
        time_range_ns: None,
        attachments: Vec::new(),
        metadata: Vec::new(),
        issues: Vec::new(),
        skipped_chunks: Vec::new(),
    };
    let mut stats = None;
    let scanned = scan(source, &mut |record| match record {
        Record::Schema { header, .. } => {
            schemas.insert(header.id, header.name);
        }
        Record::Channel(c) => {
            let schema_name = schemas.get(&c.schema_id).cloned().unwrap_or_default();
            // Channels are repeated in the summary section.
            if let std::collections::hash_map::Entry::Vacant(e) = channel_index.entry(c.id) {
                e.insert(channels.len());
                channels.push(ChannelSummary {
                    topic: c.topic,
                    schema_name,
                    message_encoding: c.message_encoding,
                    message_count: 0,
                    time_range_ns: None,
                });
            }
        }
        Record::Message { header, .. } => {
            let i = *channel_index.entry(header.channel_id).or_insert_with(|| {
                channels.push(ChannelSummary {
                    topic: format!("<unknown channel {}>", header.channel_id),
                    schema_name: String::new(),
                    message_encoding: String::new(),
                    message_count: 0,
                    time_range_ns: None,
                });
                channels.len() - 1
            });
            let t = header.log_time;
            let c = &mut channels[i];
            c.message_count += 1;
            c.time_range_ns = Some(c.time_range_ns.map_or((t, t), |(a, b)| (a.min(t), b.max(t))));
            summary.message_count += 1;
            summary.time_range_ns = Some(summary.time_range_ns.map_or((t, t), |(a, b)| (a.min(t), b.max(t))));
        }
        Record::Attachment { header, .. } => summary.attachments.push(header.name),
        Record::Metadata(m) => summary.metadata.push(m.name),
        Record::Statistics(s) => stats = Some(s),
        _ => {}
    })?;
    summary.file_bytes = scanned.file_bytes;
    summary.skipped_chunks = scanned.skipped;
    summary.issues = scanned.issues;
    summary.status = match scanned.status {
        FileStatus::Recovered { reason, .. } => FileStatus::Recovered {
            messages: summary.message_count,
            reason,
        },
        s => s,
    };
    if let Some(stats) = stats
        && summary.skipped_chunks.is_empty()
    {
        if stats.message_count != summary.message_count {
            summary.issues.push(format!(
                "the statistics record counts {} messages, {} were read",
                stats.message_count, summary.message_count
            ));
        }
        for (id, &count) in &stats.channel_message_counts {
            let read = channel_index.get(id).map_or(0, |&i| channels[i].message_count);
            if read != count {
                let topic = channel_index.get(id).map_or("?", |&i| channels[i].topic.as_str());
                summary
                    .issues
                    .push(format!("channel {id} ({topic}): statistics count {count}, {read} read"));
            }
        }
    }
    channels.sort_by(|a, b| a.topic.cmp(&b.topic));
    summary.channels = channels;
    Ok(summary)
}

/// What [`scan`] found besides the records it handed on.
#[derive(Debug)]
pub(crate) struct Scanned {
    /// File size (bytes).
    pub(crate) file_bytes: u64,
    /// How the file ended (`Recovered` carries 0 messages; callers count their own).
    pub(crate) status: FileStatus,
    /// Damaged chunks, skipped.
    pub(crate) skipped: Vec<String>,
    /// Disagreements between chunk headers, the messages inside the chunks, the chunk indexes and
    /// the statistics record (a seeking reader trusts these and would miss or misplace messages).
    pub(crate) issues: Vec<String>,
}

/// Reads every record of the MCAP file at `path` in file order and hands each to `visit`. Chunks are
/// checked one by one (decompression and CRC): a damaged chunk is skipped and described in
/// [`Scanned::skipped`], and reading goes on with the next one. A file whose first record is not a
/// header, or with bytes after its end magic (two recordings concatenated), is
/// [`FileStatus::Malformed`]. Errors: the file cannot be read, or not one record could be parsed
/// (not MCAP).
pub(crate) fn scan(source: Source<'_>, visit: &mut dyn FnMut(Record<'_>)) -> Result<Scanned> {
    match source {
        Source::File(path) => {
            let context = || format!("cannot read MCAP log {}", path.display());
            let mut file = bayes::input::open_input(path).with_context(context)?;
            let file_bytes = file.metadata().with_context(context)?.len();
            scan_from(&mut file, file_bytes, &source.name(), visit)
        }
        Source::Bytes(bytes) => scan_from(
            &mut std::io::Cursor::new(bytes),
            bytes.len() as u64,
            &source.name(),
            visit,
        ),
    }
}

/// A log time (ns) as seconds, exactly.
fn secs(ns: u64) -> String {
    format!("{}.{:09} s", ns / 1_000_000_000, ns % 1_000_000_000)
}

/// A chunk as read: where it starts, the times its header declares, and the log times of the
/// messages found inside (`None`: no messages, or the chunk was damaged).
struct ChunkSeen {
    number: usize,
    declared: (u64, u64),
    actual: Option<(u64, u64)>,
    damaged: bool,
}

fn scan_from<R: Read + std::io::Seek>(
    file: &mut R,
    file_bytes: u64,
    name: &str,
    visit: &mut dyn FnMut(Record<'_>),
) -> Result<Scanned> {
    let context = || format!("cannot read MCAP log {name}");
    // Chunks are handed to us whole, so that one bad chunk costs its own messages only; the data
    // section CRC would fail for any bad chunk, so the chunks' own CRCs are the check.
    let options = LinearReaderOptions::default()
        .with_emit_chunks(true)
        .with_validate_data_section_crc(false)
        .with_validate_summary_section_crc(true)
        // No record is longer than the file: a corrupt length fails here, before a buffer is grown.
        .with_record_length_limit(READ_RECORD_LIMIT.min(usize::try_from(file_bytes).unwrap_or(usize::MAX)));
    let mut reader = LinearReader::new_with_options(options);
    let mut records_read = 0_u64;
    // Bytes handed to the reader so far. It asks for exactly the bytes it needs next, so this is
    // the offset just past the record it yields (and past the end magic once it is done).
    let mut position = 0_u64;
    // The opcode of the first record, right after the 8-byte magic.
    let mut first_opcode = None;
    let mut chunks: BTreeMap<u64, ChunkSeen> = BTreeMap::new();
    let mut chunk_indexes = Vec::new();
    let mut stats = None;
    // Log times of the messages outside chunks.
    let mut loose: Option<(u64, u64)> = None;
    let mut skipped = Vec::new();
    let mut stop = None;
    while let Some(event) = reader.next_event() {
        let (record, offset) = match event {
            Ok(LinearReadEvent::ReadRequest(need)) => {
                let buf = reader.insert(need);
                let n = file.read(buf).with_context(context)?;
                if position <= 8 && position + n as u64 > 8 {
                    first_opcode = Some(buf[(8 - position) as usize]);
                }
                position += n as u64;
                reader.notify_read(n);
                continue;
            }
            Ok(LinearReadEvent::Record { opcode, data }) => {
                // The opcode (1) and length (8) come before the body.
                let offset = position.saturating_sub(9 + data.len() as u64);
                (parse_record(opcode, data), offset)
            }
            Err(e) => (Err(e), position),
        };
        match record {
            Ok(Record::Chunk { header, data }) => {
                records_read += 1;
                let number = chunks.len() + 1;
                let mut seen = ChunkSeen {
                    number,
                    declared: (header.message_start_time, header.message_end_time),
                    actual: None,
                    damaged: false,
                };
                match visit_chunk(&header, &data, visit) {
                    Ok(times) => seen.actual = times,
                    Err(why) => {
                        seen.damaged = true;
                        skipped.push(format!(
                            "chunk {number} at offset {offset} (messages logged {:.3}–{:.3} s): {why}; skipped",
                            header.message_start_time as f64 * 1e-9,
                            header.message_end_time as f64 * 1e-9
                        ));
                    }
                }
                chunks.insert(offset, seen);
            }
            Ok(record) => {
                records_read += 1;
                match &record {
                    Record::Message { header, .. } => loose = Some(widen(loose, header.log_time)),
                    Record::ChunkIndex(i) => chunk_indexes.push(i.clone()),
                    Record::Statistics(s) => stats = Some(s.clone()),
                    _ => {}
                }
                visit(record);
            }
            Err(e) => {
                stop = Some(e);
                break;
            }
        }
    }
    let not_a_header = first_opcode
        .filter(|&op| op != mcap::records::op::HEADER)
        .map(|op| format!("the first record, at offset 8, has opcode {op:#04x} where a header record (0x01) must be"));
    if records_read == 0
        && let Some(e) = &stop
    {
        let why = match &not_a_header {
            Some(header) => format!("{header} ({})", describe(e)),
            None => describe(e),
        };
        return Err(anyhow::anyhow!("{why}")).with_context(|| format!("{name} is not an MCAP file"));
    }
    // A complete file ends with the magic right after its footer: bytes after it are not part of
    // the recording (an append, a second recording) and make the file malformed; they are never read.
    let mut malformed: Vec<String> = not_a_header.into_iter().collect();
    if stop.is_none() && position < file_bytes {
        use std::io::SeekFrom;
        let mut next = [0u8; 8];
        file.seek(SeekFrom::Start(position)).with_context(context)?;
        let n = file.read(&mut next).with_context(context)?;
        let guess = if next[..n] == mcap::MAGIC[..] {
            "two recordings concatenated?"
        } else {
            "data appended by another tool?"
        };
        malformed.push(format!(
            "{} bytes after the end of the recording at offset {position} (after the footer and its end magic): {guess}",
            file_bytes - position
        ));
    }
    let issues = chunk_time_issues(&chunks, &chunk_indexes, stats.as_ref(), loose);
    let truncated = stop.map(|e| match e {
        // Also reported at a record boundary: the reader wants a footer.
        mcap::McapError::UnexpectedEof => "the file ends before its footer (the writer did not finish)".to_owned(),
        // The length limit is the file size: the last record was cut short.
        mcap::McapError::RecordTooLarge { len, .. } if len > file_bytes => {
            format!("the file ends before its footer (a record of {len} bytes runs past its end)")
        }
        e => describe(&e),
    });
    let status = match (malformed.is_empty(), truncated) {
        (true, None) => FileStatus::Complete,
        (true, Some(reason)) => FileStatus::Recovered { messages: 0, reason },
        (false, truncated) => FileStatus::Malformed {
            reason: malformed.into_iter().chain(truncated).collect::<Vec<_>>().join("; "),
        },
    };
    Ok(Scanned {
        file_bytes,
        status,
        skipped,
        issues,
    })
}

/// Chunk times that disagree: a chunk header's [start, end] with the log times of the messages
/// inside it, a chunk index with the chunk it points at, the statistics record with the messages
/// of the file (`loose`: those outside chunks). Damaged chunks are not judged.
fn chunk_time_issues(
    chunks: &BTreeMap<u64, ChunkSeen>,
    indexes: &[mcap::records::ChunkIndex],
    stats: Option<&mcap::records::Statistics>,
    loose: Option<(u64, u64)>,
) -> Vec<String> {
    let mut issues = Vec::new();
    for (offset, c) in chunks {
        if let Some((first, last)) = c.actual
            && c.declared != (first, last)
        {
            issues.push(format!(
                "chunk {} at offset {offset} declares messages logged {}–{}, its messages are logged {}–{}",
                c.number,
                secs(c.declared.0),
                secs(c.declared.1),
                secs(first),
                secs(last)
            ));
        }
    }
    for (i, index) in indexes.iter().enumerate() {
        let offset = index.chunk_start_offset;
        match chunks.get(&offset) {
            None => issues.push(format!(
                "chunk index {} points at offset {offset}, where no chunk begins",
                i + 1
            )),
            Some(c) if !c.damaged && (index.message_start_time, index.message_end_time) != c.declared => {
                issues.push(format!(
                    "chunk index {} says chunk {} at offset {offset} holds messages logged {}–{}, its header says {}–{}",
                    i + 1,
                    c.number,
                    secs(index.message_start_time),
                    secs(index.message_end_time),
                    secs(c.declared.0),
                    secs(c.declared.1)
                ));
            }
            Some(_) => {}
        }
    }
    if !indexes.is_empty() && indexes.len() != chunks.len() {
        issues.push(format!(
            "the summary indexes {} chunks, the file holds {}",
            indexes.len(),
            chunks.len()
        ));
    }
    if let Some(stats) = stats
        && chunks.values().all(|c| !c.damaged)
    {
        if stats.chunk_count as usize != chunks.len() {
            issues.push(format!(
                "the statistics record counts {} chunks, the file holds {}",
                stats.chunk_count,
                chunks.len()
            ));
        }
        let actual = chunks
            .values()
            .filter_map(|c| c.actual)
            .chain(loose)
            .reduce(|(a, b), (c, d)| (a.min(c), b.max(d)));
        if let Some((first, last)) = actual
            && (stats.message_start_time, stats.message_end_time) != (first, last)
        {
            issues.push(format!(
                "the statistics record says messages are logged {}–{}, the file holds messages logged {}–{}",
                secs(stats.message_start_time),
                secs(stats.message_end_time),
                secs(first),
                secs(last)
            ));
        }
    }
    issues
}

/// `mcap::parse_record` after [`check_lengths`]: the crate reserves a string's or a byte array's
/// declared length before reading it, so a corrupt 4-byte length once asked for 4 GB.
fn parse_record(opcode: u8, body: &[u8]) -> std::result::Result<Record<'_>, mcap::McapError> {
    check_lengths(opcode, body)
        .map_err(|why| mcap::McapError::Io(std::io::Error::new(std::io::ErrorKind::InvalidData, why)))?;
    mcap::parse_record(opcode, body)
}

/// An MCAP error as a reason: our own length errors (an `Io` of kind `InvalidData`) with their text.
fn describe(e: &mcap::McapError) -> String {
    match e {
        mcap::McapError::Io(io) if io.kind() == std::io::ErrorKind::InvalidData => io.to_string(),
        e => e.to_string(),
    }
}

/// Checks that every length prefix in a record body (strings, byte arrays, maps, and the strings
/// inside string maps) fits in the body, following the record layouts of the MCAP specification.
/// Unknown opcodes are not checked (the crate keeps their bodies as they are).
fn check_lengths(opcode: u8, body: &[u8]) -> std::result::Result<(), String> {
    #[derive(Clone, Copy)]
    enum F {
        /// A fixed-size integer of this many bytes.
        Int(usize),
        /// A string or byte array with a u32 length.
        Bytes32,
        /// A byte array with a u64 length.
        Bytes64,
        /// A map or array with a u32 byte length, of fixed-size entries.
        Table,
        /// A map<string, string> with a u32 byte length.
        StringMap,
    }
    use F::*;
    let (record, fields): (&str, &[(&str, F)]) = match opcode {
        0x01 => ("header", &[("profile", Bytes32), ("library", Bytes32)]),
        0x03 => (
            "schema",
            &[
                ("id", Int(2)),
                ("name", Bytes32),
                ("encoding", Bytes32),
                ("data", Bytes32),
            ],
        ),
        0x04 => (
            "channel",
            &[
                ("id", Int(2)),
                ("schema_id", Int(2)),
                ("topic", Bytes32),
                ("message_encoding", Bytes32),
                ("metadata", StringMap),
            ],
        ),
        0x06 => (
            "chunk",
            &[
                ("message_start_time", Int(8)),
                ("message_end_time", Int(8)),
                ("uncompressed_size", Int(8)),
                ("uncompressed_crc", Int(4)),
                ("compression", Bytes32),
                ("records", Bytes64),
            ],
        ),
        0x07 => ("message index", &[("channel_id", Int(2)), ("records", Table)]),
        0x08 => (
            "chunk index",
            &[
                ("times", Int(16)),
                ("chunk_start_offset", Int(8)),
                ("chunk_length", Int(8)),
                ("message_index_offsets", Table),
                ("message_index_length", Int(8)),
                ("compression", Bytes32),
                ("sizes", Int(16)),
            ],
        ),
        0x09 => (
            "attachment",
            &[
                ("times", Int(16)),
                ("name", Bytes32),
                ("media_type", Bytes32),
                ("data", Bytes64),
                ("crc", Int(4)),
            ],
        ),
        0x0A => (
            "attachment index",
            &[
                ("offsets and times", Int(40)),
                ("name", Bytes32),
                ("media_type", Bytes32),
            ],
        ),
        0x0B => (
            "statistics",
            &[
                ("counts", Int(26)),
                ("times", Int(16)),
                ("channel_message_counts", Table),
            ],
        ),
        0x0C => ("metadata", &[("name", Bytes32), ("metadata", StringMap)]),
        0x0D => ("metadata index", &[("offset and length", Int(16)), ("name", Bytes32)]),
        _ => return Ok(()),
    };
    let mut rest = body;
    let take = |rest: &mut &[u8], n: u64, field: &str| -> std::result::Result<(), String> {
        match usize::try_from(n).ok().filter(|&n| n <= rest.len()) {
            Some(n) => {
                *rest = &rest[n..];
                Ok(())
            }
            None => Err(format!(
                "{record} record: field `{field}` claims {n} bytes, {} are left in the record",
                rest.len()
            )),
        }
    };
    let read_len = |rest: &mut &[u8], width: usize, field: &str| -> std::result::Result<u64, String> {
        if rest.len() < width {
            return Err(format!("{record} record: field `{field}` is cut short"));
        }
        let mut b = [0u8; 8];
        b[..width].copy_from_slice(&rest[..width]);
        *rest = &rest[width..];
        Ok(u64::from_le_bytes(b))
    };
    for &(field, kind) in fields {
        match kind {
            Int(n) => take(&mut rest, n as u64, field)?,
            Bytes32 | Table => {
                let n = read_len(&mut rest, 4, field)?;
                take(&mut rest, n, field)?;
            }
            Bytes64 => {
                let n = read_len(&mut rest, 8, field)?;
                take(&mut rest, n, field)?;
            }
            StringMap => {
                let n = read_len(&mut rest, 4, field)?;
                let mut map = rest;
                take(&mut map, n, field)?;
                let mut entries = &rest[..rest.len() - map.len()];
                rest = map;
                while !entries.is_empty() {
                    for part in ["key", "value"] {
                        let n = read_len(&mut entries, 4, &format!("{field} {part}"))?;
                        take(&mut entries, n, &format!("{field} {part}"))?;
                    }
                }
            }
        }
    }
    Ok(())
}

/// Decompresses one chunk, checks its CRC and hands its records to `visit`; nothing is visited when
/// the chunk is damaged. Returns the log times of the first and last message inside (`None`: none).
fn visit_chunk(
    header: &mcap::records::ChunkHeader,
    data: &[u8],
    visit: &mut dyn FnMut(Record<'_>),
) -> std::result::Result<Option<(u64, u64)>, String> {
    let size = usize::try_from(header.uncompressed_size)
        .ok()
        .filter(|&n| n <= READ_RECORD_LIMIT)
        .ok_or_else(|| format!("uncompressed size {} is too large", header.uncompressed_size))?;
    let owned;
    let bytes: &[u8] = match header.compression.as_str() {
        "" => data,
        "zstd" => {
            owned = zstd::bulk::decompress(data, size).map_err(|e| format!("zstd: {e}"))?;
            &owned
        }
        "lz4" => {
            let mut out = Vec::with_capacity(size);
            lz4::Decoder::new(data)
                .and_then(|mut d| std::io::copy(&mut d, &mut out))
                .map_err(|e| format!("lz4: {e}"))?;
            owned = out;
            &owned
        }
        other => return Err(format!("unknown compression `{other}`")),
    };
    if bytes.len() != size {
        return Err(format!(
            "{} bytes after decompression, the header says {size}",
            bytes.len()
        ));
    }
    if header.uncompressed_crc != 0 {
        let crc = crc32fast::hash(bytes);
        if crc != header.uncompressed_crc {
            return Err(format!(
                "CRC {crc:#010x} does not match the header's {:#010x}",
                header.uncompressed_crc
            ));
        }
    }
    // Parse everything first: a chunk whose records do not parse is skipped whole.
    let mut records = Vec::new();
    let mut rest = bytes;
    while !rest.is_empty() {
        if rest.len() < 9 {
            return Err("a record header is cut short".into());
        }
        let opcode = rest[0];
        let mut len_bytes = [0u8; 8];
        len_bytes.copy_from_slice(&rest[1..9]);
        let len = usize::try_from(u64::from_le_bytes(len_bytes)).unwrap_or(usize::MAX);
        let body = rest
            .get(9..9usize.saturating_add(len))
            .ok_or_else(|| "a record runs past the chunk's end".to_string())?;
        records.push(parse_record(opcode, body).map_err(|e| describe(&e))?);
        rest = &rest[9 + len..];
    }
    let mut times = None;
    for r in records {
        if let Record::Message { header, .. } = &r {
            times = Some(widen(times, header.log_time));
        }
        visit(r);
    }
    Ok(times)
}

/// `range` widened to hold `t`.
fn widen(range: Option<(u64, u64)>, t: u64) -> (u64, u64) {
    range.map_or((t, t), |(a, b)| (a.min(t), b.max(t)))
}
