//! Stereo vision on the robot's own cameras: background subtraction, segments and their features,
//! stereo matching, triangulation, support-plane height and footprint (§5.1.2, §6.2.1).
//!
//! 1. [`Segmenter`] subtracts the background (the empty workspace as calibration saw it, warped to
//!    the camera's pose: [`background`]), drops the robot's own pixels (its self-model at the
//!    measured joint angles: [`self_model`]) and labels 8-connected components ([`Segment`]).
//! 2. Each segment has [`SegmentFeatures`]: size in pixels (§5.1.2.2), first and second moments
//!    (§6.2.1), the 64-colour HSV histogram with the 20th-percentile rule (§5.1.2.1), mean colour
//!    and the colour-term counts ([`color::color_term`]).
//! 3. [`StereoMatcher`] pairs left and right segments by colour and epipolar geometry and triangulates
//!    the centroid rays ([`StereoBlob`]); objects seen by one camera only are reported as such.
//! 4. With a known table plane ([`StereoConfig::support`]), objects resting on it get a more precise
//!    centroid, a measured height and a footprint ([`support`]); things too tall to grasp (a post, a
//!    wall) are located from their vertical silhouette edges instead ([`edges`]).
//!
//! [`StereoPipeline`] runs all of it for a stereo pair with every buffer reused. Images come from
//! [`control_basis::Hardware::capture`]; nothing here renders.

pub mod background;
pub mod color;
pub mod edges;
pub mod segment;
pub mod self_model;
pub mod stereo;
pub mod support;

pub use background::{BackgroundBank, BackgroundView, WarpScratch};
pub use color::{ColorHistogram, HISTOGRAM_BINS};
pub use control_basis::hardware::{Camera, Image};
pub use segment::{Segment, SegmentConfig, SegmentFeatures, Segmenter};
pub use self_model::SelfModel;
pub use stereo::{
    DepthCorrection, Frame, Side, StereoBlob, StereoCameras, StereoConfig, StereoMatcher, StereoPipeline,
    Triangulation, Visibility, triangulate, triangulate_rays,
};
pub use support::{CentroidSource, Footprint, SupportEstimator, SupportPlane};
