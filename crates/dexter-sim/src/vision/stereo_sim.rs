//! The rendered stereo pipeline: two simulated cameras (renderers with pixel noise) feeding the
//! robot's [`StereoPipeline`]. For vision tests and benches that work on a [`RenderScene`] directly;
//! the robot itself gets its images through [`crate::hardware::SimRobot`].

use crate::error::SimError;
use crate::scene::{CameraSpec, LightSpec};
use crate::vision::render::{Image, RenderScene, Renderer};
use dexter::vision::{Frame, SegmentConfig, Segmenter, Side, StereoBlob, StereoCameras, StereoConfig, StereoPipeline};

fn robot_error(e: dexter::RobotError) -> SimError {
    crate::error::from_robot(e)
}

/// The robot's self-mask of a rendered frame: pixels labelled [`crate::vision::ItemLabel::Robot`].
pub fn self_mask(labels: &[Option<crate::vision::ItemLabel>], out: &mut Vec<bool>) {
    out.clear();
    out.extend(labels.iter().map(|l| *l == Some(crate::vision::ItemLabel::Robot)));
}

/// Two renderers and the robot's stereo pipeline, with all buffers reused.
///
/// The background of each camera is the empty scene (only [`crate::vision::ItemLabel::Static`]
/// items) seen from that camera's current pose. [`StereoVision::perceive`] re-renders it whenever
/// the cameras differ from the ones it was captured with (the head moved), as a robot would
/// re-capture its background per head pose.
#[derive(Debug, Clone)]
pub struct StereoVision {
    renderers: [Renderer; 2],
    pipeline: StereoPipeline,
    masks: [Vec<bool>; 2],
}

/// Noise seeds of the left and right cameras: streams 0 and 1 of `seed` ([`bayes::rng::stream`]).
fn camera_seeds(seed: u64) -> (u64, u64) {
    let s = |k| rand::Rng::next_u64(&mut bayes::rng::stream(seed, k));
    (s(0), s(1))
}

fn side_index(side: Side) -> usize {
    match side {
        Side::Left => 0,
        Side::Right => 1,
    }
}

impl StereoVision {
    /// Default segmentation (for the camera's pixel noise) and matching settings; the two cameras'
    /// noise streams are derived from `seed`.
    pub fn new(spec: &CameraSpec, light: &LightSpec, seed: u64) -> Result<Self, SimError> {
        Self::with_config(
            spec,
            light,
            seed,
            SegmentConfig::for_noise(spec.pixel_noise),
            StereoConfig::default(),
        )
    }

    /// Explicit settings.
    pub fn with_config(
        spec: &CameraSpec,
        light: &LightSpec,
        seed: u64,
        segment: SegmentConfig,
        stereo: StereoConfig,
    ) -> Result<Self, SimError> {
        crate::vision::camera::validate_spec(spec)?;
        let (sl, sr) = camera_seeds(seed);
        Ok(Self {
            renderers: [
                Renderer::new(spec.pixel_noise, light, sl)?,
                Renderer::new(spec.pixel_noise, light, sr)?,
            ],
            pipeline: StereoPipeline::new(segment, stereo),
            masks: [Vec::new(), Vec::new()],
        })
    }

    /// Restarts both noise streams from `seed` (as [`StereoVision::new`] does).
    pub fn reseed(&mut self, seed: u64) {
        let (sl, sr) = camera_seeds(seed);
        self.renderers[0].reseed(sl);
        self.renderers[1].reseed(sr);
    }

    /// The matching settings.
    pub fn config(&self) -> &StereoConfig {
        self.pipeline.config()
    }

    /// Changes the matching settings.
    pub fn set_config(&mut self, config: StereoConfig) {
        self.pipeline.set_config(config);
    }

    /// The renderer of one camera (its last image, labels and depth).
    pub fn renderer(&self, side: Side) -> &Renderer {
        &self.renderers[side_index(side)]
    }

    /// The renderer of one camera, mutable.
    pub fn renderer_mut(&mut self, side: Side) -> &mut Renderer {
        &mut self.renderers[side_index(side)]
    }

    /// The segmenter of one camera (its background, last mask, component map and segments).
    pub fn segmenter(&self, side: Side) -> &Segmenter {
        self.pipeline.segmenter(side)
    }

    /// The segmenter of one camera, mutable.
    pub fn segmenter_mut(&mut self, side: Side) -> &mut Segmenter {
        self.pipeline.segmenter_mut(side)
    }

    /// Renders the empty scene (static items only) from both cameras and stores it as background.
    ///
    /// Call it again whenever the static scene changes; [`StereoVision::perceive`] only notices
    /// camera motion.
    pub fn capture_background(&mut self, cams: &StereoCameras, scene: &RenderScene) -> Result<(), SimError> {
        // Until both succeed the backgrounds are inconsistent: force a re-capture on failure.
        self.pipeline.clear_backgrounds();
        let mut bg = [Image::default(), Image::default()];
        for (k, cam) in [&cams.left, &cams.right].into_iter().enumerate() {
            bg[k].copy_from(self.renderers[k].render_background(cam, scene)?);
        }
        self.pipeline.set_backgrounds(cams, &bg[0], &bg[1]);
        Ok(())
    }

    /// Renders both images of the scene.
    pub fn render_stereo(&mut self, cams: &StereoCameras, scene: &RenderScene) -> Result<(&Image, &Image), SimError> {
        self.renderers[0].render(&cams.left, scene)?;
        self.renderers[1].render(&cams.right, scene)?;
        Ok((self.renderers[0].image(), self.renderers[1].image()))
    }

    /// Renders, segments and matches; writes the blobs into `out` (cleared first). Captures the
    /// background first if it was never captured or the cameras moved.
    pub fn perceive_into(
        &mut self,
        cams: &StereoCameras,
        scene: &RenderScene,
        out: &mut Vec<StereoBlob>,
    ) -> Result<(), SimError> {
        if self.pipeline.needs_background(cams) {
            self.capture_background(cams, scene)?;
        }
        self.render_stereo(cams, scene)?;
        for k in 0..2 {
            self_mask(self.renderers[k].labels(), &mut self.masks[k]);
        }
        let frames = [
            Frame {
                image: self.renderers[0].image(),
                self_mask: &self.masks[0],
            },
            Frame {
                image: self.renderers[1].image(),
                self_mask: &self.masks[1],
            },
        ];
        self.pipeline.process(cams, frames, out).map_err(robot_error)
    }

    /// [`StereoVision::perceive_into`] into a new vector.
    pub fn perceive(&mut self, cams: &StereoCameras, scene: &RenderScene) -> Result<Vec<StereoBlob>, SimError> {
        let mut out = Vec::new();
        self.perceive_into(cams, scene, &mut out)?;
        Ok(out)
    }
}
