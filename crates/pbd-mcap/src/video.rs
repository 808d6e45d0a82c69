//! A camera's images as an H.264 video stream ([`crate::ImageFormat::H264`]): OpenH264's encoder
//! (Cisco's BSD-licensed codec, built from source by the `openh264` crate) at a constant
//! quantiser, one stream per camera, each frame one `foxglove.CompressedVideo` message.

use anyhow::{Context, Result, ensure};
use openh264::OpenH264API;
use openh264::encoder::{
    BitRate, Complexity, Encoder, EncoderConfig, FrameRate, FrameType, IntraFramePeriod, QpRange, RateControlMode,
    UsageType,
};
use openh264::formats::{RgbSliceU8, YUVBuffer};

/// One camera's video stream being encoded.
pub(crate) struct H264Stream {
    encoder: Encoder,
    yuv: YUVBuffer,
    size: (usize, usize),
}

impl H264Stream {
    /// A stream of `width × height` frames at quantiser `qp` (0–51), a keyframe every
    /// `keyframe_interval` frames.
    pub(crate) fn new(width: u32, height: u32, qp: u8, keyframe_interval: u32) -> Result<Self> {
        ensure!(
            width >= 16 && height >= 16 && width.is_multiple_of(2) && height.is_multiple_of(2),
            "H.264 needs an even width and height of at least 16 pixels, not {width}×{height} (use --image-format jpeg)"
        );
        // The quantiser is held constant by giving the rate control a target it never meets (the raw
        // stream's rate at 30 Hz): the encoder then never skips a frame nor raises the quantiser.
        let raw_bps = (u64::from(width) * u64::from(height) * 24 * 30).min(i32::MAX as u64) as u32;
        let qp = qp.min(51);
        let config = EncoderConfig::new()
            .usage_type(UsageType::CameraVideoRealTime)
            .rate_control_mode(RateControlMode::Quality)
            .bitrate(BitRate::from_bps(raw_bps))
            .skip_frames(true)
            .qp(QpRange::new(qp, qp))
            .max_frame_rate(FrameRate::from_hz(30.0))
            .intra_frame_period(IntraFramePeriod::from_num_frames(keyframe_interval.max(1)))
            .complexity(Complexity::High)
            // One thread: the same frames give the same bytes, and the simulator needs the other core.
            .num_threads(1);
        let encoder =
            Encoder::with_api_config(OpenH264API::from_source(), config).context("cannot start the H.264 encoder")?;
        let size = (width as usize, height as usize);
        Ok(Self {
            encoder,
            yuv: YUVBuffer::new(size.0, size.1),
            size,
        })
    }

    /// The frame's size, to check that a camera's images keep theirs.
    pub(crate) fn size(&self) -> (usize, usize) {
        self.size
    }

    /// Encodes one `rgb8` frame into `out` (cleared first; Annex B NAL units, the SPS and PPS before
    /// a keyframe). Returns whether a frame was written (the encoder may skip one; none is skipped at
    /// a constant quantiser).
    pub(crate) fn encode(&mut self, rgb: &[u8], out: &mut Vec<u8>) -> Result<bool> {
        out.clear();
        self.yuv.read_rgb(RgbSliceU8::new(rgb, self.size));
        let stream = self.encoder.encode(&self.yuv).context("H.264 encoding")?;
        if matches!(stream.frame_type(), FrameType::Skip | FrameType::Invalid) {
            return Ok(false);
        }
        stream.write_vec(out);
        Ok(!out.is_empty())
    }
}
