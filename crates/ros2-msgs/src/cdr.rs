//! CDR as ROS 2 sends and rosbag2 stores it: a 4-byte encapsulation header (`00 01 00 00`, CDR
//! little endian) and the message in OMG XCDR1, aligned from the end of the header.

use serde::Serialize;
use serde::de::DeserializeOwned;

/// The encapsulation header of little-endian CDR.
pub const CDR_LE: [u8; 4] = [0, 1, 0, 0];

/// A message that does not encode or decode.
#[derive(Debug, thiserror::Error)]
pub enum CdrError {
    /// Fewer than 4 bytes, or an encapsulation other than plain CDR (big or little endian).
    #[error("not CDR: {0}")]
    Header(String),
    /// The body does not decode as the type (or does not encode).
    #[error("CDR: {0}")]
    Body(String),
}

/// Encodes `msg` into `buf` (cleared first): header and body.
pub fn encode_into<T: Serialize>(buf: &mut Vec<u8>, msg: &T) -> Result<(), CdrError> {
    buf.clear();
    buf.extend_from_slice(&CDR_LE);
    cdr_encoding::to_writer::<T, byteorder_le::Le, _>(&mut *buf, msg).map_err(|e| CdrError::Body(e.to_string()))
}

/// Encodes `msg`: header and body.
pub fn encode<T: Serialize>(msg: &T) -> Result<Vec<u8>, CdrError> {
    let mut buf = Vec::new();
    encode_into(&mut buf, msg)?;
    Ok(buf)
}

/// Decodes a message (header and body; big- or little-endian CDR).
pub fn decode<T: DeserializeOwned>(data: &[u8]) -> Result<T, CdrError> {
    let (header, body) = data
        .split_first_chunk::<4>()
        .ok_or_else(|| CdrError::Header(format!("{} bytes, fewer than the 4 of the header", data.len())))?;
    let decoded = match header {
        [0, 1, _, _] => cdr_encoding::from_bytes::<T, byteorder_le::Le>(body),
        [0, 0, _, _] => cdr_encoding::from_bytes::<T, byteorder_le::Be>(body),
        other => return Err(CdrError::Header(format!("encapsulation {other:02x?} is not plain CDR"))),
    };
    decoded.map(|(v, _)| v).map_err(|e| CdrError::Body(e.to_string()))
}

mod byteorder_le {
    pub(super) type Le = byteorder::LittleEndian;
    pub(super) type Be = byteorder::BigEndian;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msg::*;

    #[test]
    fn joint_state_has_the_layout_of_the_standard() {
        let m = JointState {
            header: Header {
                stamp: Time { sec: 1, nanosec: 2 },
                frame_id: "w".into(),
            },
            name: vec!["a".into()],
            position: vec![0.5],
            velocity: vec![],
            effort: vec![],
        };
        let b = encode(&m).unwrap();
        // header; sec, nanosec; "w\0" (len 2) and 2 bytes of padding; names: 1, "a\0", padding;
        // 1 position (the body is at 32, aligned for the f64: no padding); 0.5; 0; 0.
        let mut want = vec![0u8, 1, 0, 0, 1, 0, 0, 0, 2, 0, 0, 0, 2, 0, 0, 0, b'w', 0, 0, 0];
        want.extend_from_slice(&[1, 0, 0, 0, 2, 0, 0, 0, b'a', 0, 0, 0]);
        want.extend_from_slice(&[1, 0, 0, 0]);
        want.extend_from_slice(&0.5f64.to_le_bytes());
        want.extend_from_slice(&[0, 0, 0, 0, 0, 0, 0, 0]);
        assert_eq!(b, want);
        assert_eq!(decode::<JointState>(&b).unwrap(), m);
    }

    #[test]
    fn bad_input_is_an_error() {
        assert!(decode::<JointState>(&[0, 1]).is_err());
        assert!(decode::<JointState>(&[0, 1, 0, 0, 1]).is_err());
        assert!(decode::<JointState>(&[9, 9, 0, 0]).is_err());
    }
}
