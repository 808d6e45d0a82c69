//! The simulated cameras: ray-cast rendering with pixel noise, and test fixtures.
//!
//! [`Renderer`] casts one ray per pixel against the parry shapes of a [`RenderScene`] (table, bins,
//! objects, robot links), shades with Lambert + ambient ([`crate::scene::LightSpec`]) and adds seeded
//! Gaussian pixel noise ([`crate::scene::CameraSpec::pixel_noise`]). It also returns a per-pixel
//! [`ItemLabel`] buffer, used for the robot's self-mask (what a real robot renders from its
//! self-model) and as test ground truth. Everything after the pixels — segmentation, colour, stereo,
//! support plane — is the robot's own vision in [`dexter::vision`], re-exported here for tests;
//! [`StereoVision`] chains the two on a render scene.

pub mod camera;
pub mod fixtures;
pub mod noise;
pub mod render;
pub mod stereo_sim;

pub use camera::SpecCamera;
pub use control_basis::hardware::Camera;
pub use dexter::vision::{
    CentroidSource, ColorHistogram, DepthCorrection, Footprint, HISTOGRAM_BINS, Segment, SegmentConfig,
    SegmentFeatures, Segmenter, Side, StereoBlob, StereoCameras, StereoConfig, StereoMatcher, StereoPipeline,
    SupportEstimator, SupportPlane, Triangulation, Visibility, triangulate, triangulate_rays,
};
pub use dexter::vision::{color, segment, stereo, support};
pub use render::{Image, ItemLabel, Material, RenderItem, RenderScene, RenderStats, Renderer};
pub use stereo_sim::StereoVision;
