//! Backgrounds a camera can really have: views of the empty workspace captured during calibration
//! (before any object is placed), warped into the camera's current pose through the table plane.
//!
//! A real robot cannot photograph the empty table while objects stand on it, and its head never
//! returns to exactly the pose of a calibration view (pan, tilt and vergence servo continuously;
//! the encoders are noisy). So at calibration the robot keeps a bank of views — for each camera a
//! few head poses spread over the workspace, each the mean of several frames — and, for the pose it
//! has now, predicts the background pixel by pixel: the pixel's ray meets the table plane at a point
//! (rays that do not meet it ahead are taken as directions at infinity), that point is projected
//! into the calibration view whose axis is closest to the current one and that sees it, and the
//! background there is the **interval** spanned by the four neighbouring calibration pixels (per
//! channel, min and max). The table plane is exact for everything on the table; for what lies off it
//! (bin walls, the floor beyond the table edge) the error is the parallax of the camera's shift
//! between the two poses, `f·|t|·|1/Z − 1/Z_plane|` — a fraction of a pixel for the head's few
//! centimetres — and the interval absorbs it at edges. A pixel is foreground when its colour lies
//! farther than the threshold from that interval ([`crate::vision::Segmenter`]).
//!
//! Pixels of a calibration view where the robot's own body was (its self-mask then) are not used:
//! the next view that sees the point without the body is. Pixels no calibration view sees are
//! reported (`coverage`) and never foreground: the robot is blind there, as it would be.

use control_basis::hardware::{Camera, Image};
use control_basis::math::{Mat3, Vec3};

use crate::error::RobotError;

/// One calibration view of the empty workspace: the camera where the robot's kinematics put it, the
/// mean of the frames it took there, and which pixels show the workspace (not the robot's own body,
/// whose parts near the cameras would warp with a large parallax, and which moves during a task).
#[derive(Debug, Clone, PartialEq)]
pub struct BackgroundView {
    /// The camera (intrinsics and pose from the measured joint angles).
    pub camera: Camera,
    /// The mean image of the empty workspace.
    pub image: Image,
    /// Per pixel: `true` where the image shows the workspace (outside the self-mask); empty =
    /// every pixel.
    pub valid: Vec<bool>,
}

/// The calibration views of one camera and the table plane they are warped through.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct BackgroundBank {
    views: Vec<BackgroundView>,
    plane_z: f64,
}

/// Per-view constants of one warp: current homogeneous pixel `q` → view pixel
/// `b + s·A·q` (point on the plane at ray parameter `s`) or `A·q` (direction at infinity).
#[derive(Debug, Clone, Copy)]
struct WarpView {
    a: Mat3,
    b: Vec3,
    /// The view's largest pixel coordinates (width − 1, height − 1).
    u_max: f64,
    v_max: f64,
    /// Its width in pixels and its index in the bank.
    iw: usize,
    view: usize,
}

/// Reused buffers of [`BackgroundBank::render`].
#[derive(Debug, Clone, Default)]
pub struct WarpScratch {
    order: Vec<(f64, usize)>,
    warps: Vec<WarpView>,
}

impl BackgroundBank {
    /// An empty bank for a table plane at height `plane_z` (m, world z).
    pub fn new(plane_z: f64) -> Self {
        Self {
            views: Vec::new(),
            plane_z,
        }
    }

    /// Adds a view. Errors if its image does not have the camera's size.
    pub fn push(&mut self, view: BackgroundView) -> Result<(), RobotError> {
        let (c, im) = (&view.camera, &view.image);
        if c.width != im.width
            || c.height != im.height
            || im.rgb.len() != 3 * c.pixel_count()
            || !(view.valid.is_empty() || view.valid.len() == c.pixel_count())
        {
            return Err(RobotError::invalid(
                "<calibration>",
                "background view",
                format!(
                    "a {}×{} image ({} validity pixels) for a {}×{} camera",
                    im.width,
                    im.height,
                    view.valid.len(),
                    c.width,
                    c.height
                ),
            ));
        }
        self.views.push(view);
        Ok(())
    }

    /// The views.
    pub fn views(&self) -> &[BackgroundView] {
        &self.views
    }

    /// Height of the table plane (m).
    pub fn plane_z(&self) -> f64 {
        self.plane_z
    }

    /// Whether the bank has no view.
    pub fn is_empty(&self) -> bool {
        self.views.is_empty()
    }

    /// The background of `camera` as an interval per pixel and channel: `lo` and `hi` (resized to
    /// the camera). Returns the fraction of pixels some view covers; uncovered pixels get the full
    /// interval `[0, 255]` (never foreground). Allocates only when the buffers grow.
    pub fn render(&self, camera: &Camera, lo: &mut Image, hi: &mut Image, scratch: &mut WarpScratch) -> f64 {
        let (w, h) = (camera.width, camera.height);
        lo.resize(w, h);
        hi.resize(w, h);
        if self.views.is_empty() {
            lo.rgb.fill(0);
            hi.rgb.fill(255);
            return 0.0;
        }
        // Views ordered by the angle between their optical axis and the current one.
        let axis = camera.axis();
        scratch.order.clear();
        scratch.order.extend(
            self.views
                .iter()
                .enumerate()
                .map(|(k, v)| (-v.camera.axis().dot(&axis), k)),
        );
        scratch.order.sort_by(|a, b| a.0.total_cmp(&b.0));
        let k_inv = Mat3::new(
            1.0 / camera.fx,
            0.0,
            -camera.cx / camera.fx,
            0.0,
            1.0 / camera.fy,
            -camera.cy / camera.fy,
            0.0,
            0.0,
            1.0,
        );
        let rc = camera.world_from_optical.rotation.to_rotation_matrix().into_inner();
        let ray = rc * k_inv; // current homogeneous pixel → world ray direction (unnormalised)
        let oc = camera.position();
        scratch.warps.clear();
        for &(_, k) in &scratch.order {
            let v = &self.views[k].camera;
            let kv = Mat3::new(v.fx, 0.0, v.cx, 0.0, v.fy, v.cy, 0.0, 0.0, 1.0);
            let rv_t = v
                .world_from_optical
                .rotation
                .to_rotation_matrix()
                .into_inner()
                .transpose();
            scratch.warps.push(WarpView {
                a: kv * rv_t * ray,
                b: kv * rv_t * (oc - v.position()),
                u_max: v.width as f64 - 1.0,
                v_max: v.height as f64 - 1.0,
                iw: v.width as usize,
                view: k,
            });
        }
        let dz_row = ray.row(2).transpose();
        let height = self.plane_z - oc.z;
        let mut covered = 0usize;
        for row in 0..h {
            for col in 0..w {
                let q = Vec3::new(col as f64, row as f64, 1.0);
                let dz = dz_row.dot(&q);
                // Ray parameter to the plane; a ray that does not meet it ahead looks at infinity.
                let s = if dz < -1e-9 && height < 0.0 {
                    height / dz
                } else {
                    f64::INFINITY
                };
                let pix = row as usize * w as usize + col as usize;
                // The first view (nearest axis first) that sees the point: its index and the four
                // calibration pixels around it (row-major indices).
                let mut hit = None;
                for wv in &scratch.warps {
                    let p = if s.is_finite() { wv.b + wv.a * q * s } else { wv.a * q };
                    if p.z <= 1e-9 {
                        continue;
                    }
                    let (u, v) = (p.x / p.z, p.y / p.z);
                    if u >= 0.0 && v >= 0.0 && u <= wv.u_max && v <= wv.v_max {
                        let (u0, v0) = (u as usize, v as usize);
                        let (u1, v1) = ((u0 + 1).min(wv.iw - 1), (v0 + 1).min(wv.v_max as usize));
                        let corners = [v0 * wv.iw + u0, v0 * wv.iw + u1, v1 * wv.iw + u0, v1 * wv.iw + u1];
                        let valid = &self.views[wv.view].valid;
                        if !valid.is_empty() && !corners.iter().all(|&i| valid[i]) {
                            continue;
                        }
                        hit = Some((wv.view, corners));
                        break;
                    }
                }
                let (l, hh) = (&mut lo.rgb[3 * pix..3 * pix + 3], &mut hi.rgb[3 * pix..3 * pix + 3]);
                match hit {
                    None => {
                        l.fill(0);
                        hh.fill(255);
                    }
                    Some((k, corners)) => {
                        covered += 1;
                        let im = &self.views[k].image.rgb;
                        let (mut a, mut b) = ([255u8; 3], [0u8; 3]);
                        for i in corners {
                            let px = &im[3 * i..3 * i + 3];
                            for c in 0..3 {
                                a[c] = a[c].min(px[c]);
                                b[c] = b[c].max(px[c]);
                            }
                        }
                        l.copy_from_slice(&a);
                        hh.copy_from_slice(&b);
                    }
                }
            }
        }
        covered as f64 / (w as f64 * h as f64).max(1.0)
    }
}

/// The mean of `frames` (same size), rounded.
pub fn mean_image(frames: &[Image]) -> Option<Image> {
    let first = frames.first()?;
    if frames
        .iter()
        .any(|f| f.width != first.width || f.height != first.height)
    {
        return None;
    }
    let n = frames.len() as u32;
    let mut out = first.clone();
    for (i, b) in out.rgb.iter_mut().enumerate() {
        let sum: u32 = frames.iter().map(|f| u32::from(f.rgb[i])).sum();
        *b = ((sum + n / 2) / n) as u8;
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use control_basis::hardware::Intrinsics;

    const TABLE: f64 = 0.75;

    /// A synthetic world: a checkered table plane at `TABLE` and a grey sky; the colour of the
    /// first surface along each pixel's ray.
    fn shoot(camera: &Camera) -> Image {
        let mut im = Image::new(camera.width, camera.height);
        for v in 0..camera.height {
            for u in 0..camera.width {
                let (o, d) = camera.ray(u as f64, v as f64);
                let rgb = if d.z < -1e-9 {
                    let p = o + d * ((TABLE - o.z) / d.z);
                    let check = ((p.x / 0.1).floor() as i64 + (p.y / 0.1).floor() as i64).rem_euclid(2);
                    if check == 0 { [200, 60, 40] } else { [40, 90, 200] }
                } else {
                    [128, 128, 128]
                };
                let i = 3 * (v as usize * camera.width as usize + u as usize);
                im.rgb[i..i + 3].copy_from_slice(&rgb);
            }
        }
        im
    }

    fn camera_at(eye: Vec3, target: Vec3) -> Camera {
        let intr = Intrinsics {
            width: 80,
            height: 60,
            hfov_deg: 60.0,
        };
        Camera::new(&intr, Camera::pose_looking_at(eye, target).unwrap()).unwrap()
    }

    #[test]
    fn a_nearby_pose_is_predicted_within_the_interval_on_the_table() {
        let eye = Vec3::new(0.0, 0.0, 1.5);
        let mut bank = BackgroundBank::new(TABLE);
        for y in [-0.3, 0.0, 0.3] {
            let cam = camera_at(eye, Vec3::new(0.7, y, TABLE));
            let image = shoot(&cam);
            bank.push(BackgroundView {
                camera: cam,
                image,
                valid: Vec::new(),
            })
            .unwrap();
        }
        // A pose between two views, shifted by 1 cm (the head's parallax).
        let cam = camera_at(eye + Vec3::new(0.01, 0.005, 0.0), Vec3::new(0.72, 0.13, TABLE));
        let truth = shoot(&cam);
        let (mut lo, mut hi) = (Image::default(), Image::default());
        let coverage = bank.render(&cam, &mut lo, &mut hi, &mut WarpScratch::default());
        assert!(coverage > 0.99, "coverage {coverage}");
        let mut outside = 0;
        for i in 0..truth.rgb.len() {
            if truth.rgb[i] < lo.rgb[i] || truth.rgb[i] > hi.rgb[i] {
                outside += 1;
            }
        }
        // Only the sky/table horizon may fall outside (off the plane); the table is exact.
        assert!(
            outside < truth.rgb.len() / 100,
            "{outside} channel values outside the interval"
        );
    }

    #[test]
    fn pixels_no_view_sees_are_never_foreground() {
        let eye = Vec3::new(0.0, 0.0, 1.5);
        let mut bank = BackgroundBank::new(TABLE);
        let cam = camera_at(eye, Vec3::new(0.7, 0.0, TABLE));
        bank.push(BackgroundView {
            image: shoot(&cam),
            camera: cam,
            valid: Vec::new(),
        })
        .unwrap();
        let away = camera_at(eye, Vec3::new(0.0, 0.9, TABLE));
        let (mut lo, mut hi) = (Image::default(), Image::default());
        let coverage = bank.render(&away, &mut lo, &mut hi, &mut WarpScratch::default());
        assert!(coverage < 0.5, "coverage {coverage}");
        let n_full = lo
            .rgb
            .iter()
            .zip(&hi.rgb)
            .filter(|&(&l, &h)| l == 0 && h == 255)
            .count();
        assert!(n_full > 0);
    }

    #[test]
    fn mean_of_frames_rounds_and_checks_sizes() {
        let mut a = Image::new(2, 1);
        let mut b = Image::new(2, 1);
        a.rgb = vec![0, 10, 255, 1, 2, 3];
        b.rgb = vec![1, 11, 255, 2, 2, 4];
        assert_eq!(mean_image(&[a.clone(), b]).unwrap().rgb, vec![1, 11, 255, 2, 2, 4]);
        assert!(mean_image(&[a, Image::new(3, 1)]).is_none());
        assert!(mean_image(&[]).is_none());
    }
}
