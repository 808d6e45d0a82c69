//! Stereo vision: ray-cast rendering, background subtraction, segments and their features, triangulation.
//!
//! The pipeline of §5.1.2 and §6.2.1 of the seed, on simulated cameras:
//!
//! 1. [`Renderer`] casts one ray per pixel against the parry shapes of a [`RenderScene`] (table,
//!    bins, objects, robot links), shades with Lambert + ambient ([`crate::scene::LightSpec`]) and adds
//!    seeded Gaussian pixel noise ([`crate::scene::CameraSpec::pixel_noise`]). It also returns a
//!    per-pixel [`ItemLabel`] buffer, used only for the robot self-filter and as test ground truth.
//! 2. [`Segmenter`] subtracts the background (the empty scene rendered from the same camera),
//!    drops robot pixels, and labels 8-connected components ([`Segment`]).
//! 3. Each segment has [`SegmentFeatures`]: size in pixels (§5.1.2.2), first and second moments
//!    (§6.2.1), the 64-colour HSV histogram with the 20th-percentile rule (§5.1.2.1), mean colour.
//! 4. [`StereoMatcher`] pairs left and right segments by colour and epipolar geometry and triangulates
//!    the centroid rays ([`StereoBlob`]); objects seen by one camera only are reported as such.
//! 5. With a known table plane ([`StereoConfig::support`]), objects resting on it get a more precise
//!    centroid from their measured height and footprint ([`support`]).
//!
//! [`StereoVision`] runs all of it for a stereo pair with every buffer reused.

pub mod camera;
pub mod color;
pub mod fixtures;
pub mod noise;
pub mod render;
pub mod segment;
pub mod stereo;
pub mod support;

pub use camera::Camera;
pub use color::{ColorHistogram, HISTOGRAM_BINS};
pub use render::{Image, ItemLabel, Material, RenderItem, RenderScene, RenderStats, Renderer};
pub use segment::{Segment, SegmentConfig, SegmentFeatures, Segmenter};
pub use stereo::{
    DepthCorrection, Side, StereoBlob, StereoCameras, StereoConfig, StereoMatcher, StereoVision, Triangulation,
    Visibility, triangulate, triangulate_rays,
};
pub use support::{CentroidSource, SupportEstimator, SupportPlane};
