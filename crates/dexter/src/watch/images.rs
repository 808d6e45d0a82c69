//! Geometry in the head cameras' images: one-camera views, projected boxes and silhouettes, and the
//! image tests of a move or a doubt.

use control_basis::math::Vec3;
use schema::SegmentPercept;

/// A partial view (near an arm, or cut) whose image centroids lie beyond where any visible part
/// of the track's projected box can have them, by this much (px) in both cameras, casts doubt on
/// where the track is ([`image_doubt`]). Not proof — the box comes from a measured extent, and a
/// view's share of the whole is known only roughly — so the robot looks again with its hand out of
/// the way before it closes ([`Watcher::doubted`]). (The stereo centroid of a partial view is no
/// help: a cup two-thirds hidden by the fingers triangulated 4.5 cm high after a 0.2 px change.)
pub(super) const DOUBT_PX: f64 = 1.5;

/// … and its centroid is within this height (m) of the track's (mismatched stereo pairs of a
/// partly hidden object measured 4–7 cm high).
pub(super) const MOVED_DZ: f64 = 0.035;

/// A view near an arm whose centroid is this far (m) outside the track's footprint may show the
/// object moved ([`moved_clear`]; partial views measured up to 2.2 cm outside from stereo noise).
pub(super) const MOVED_FOOTPRINT: f64 = 0.03;

/// … if it shows at least this share of the track's whole view …
pub(super) const MOVED_SHARE: f64 = 0.55;

/// A blob one head camera saw and the other did not match (`camera`: 0 left, 1 right): its image
/// centroid (px) and its main colour term.
#[derive(Debug, Clone, Copy)]
pub(super) struct MonoView {
    pub(super) camera: usize,
    pub(super) centroid: [f64; 2],
    /// Its bounding box (u min, v min, u max, v max; px).
    pub(super) bbox: [u32; 4],
    pub(super) term: Option<u8>,
}

/// How far (px, at the head cameras' 160 × 120) a one-camera blob may lie from a track's projection
/// to count as a view of it: about 5 cm at the table's range.
pub(super) const MONO_GATE_PX: f64 = 10.0;

/// How far (px) inside the image border a track must project to count as in view.
pub(super) const IN_VIEW_MARGIN_PX: f64 = 4.0;

/// Whether `p` is in view of both cameras: in front of them, at least [`IN_VIEW_MARGIN_PX`] inside
/// each image, and not behind the robot's own body (`masks`, the self-masks; empty = none).
pub(super) fn in_view(cams: [&crate::vision::Camera; 2], masks: [&[bool]; 2], p: &[f64; 3]) -> bool {
    cams.iter().zip(masks).all(|(cam, mask)| {
        let Some((u, v)) = project(cam, &Vec3::from(*p)) else {
            return false;
        };
        let (w, h) = (f64::from(cam.width), f64::from(cam.height));
        if !(u >= IN_VIEW_MARGIN_PX && u < w - IN_VIEW_MARGIN_PX && v >= IN_VIEW_MARGIN_PX && v < h - IN_VIEW_MARGIN_PX)
        {
            return false;
        }
        let i = v as usize * cam.width as usize + u as usize;
        !mask.get(i).copied().unwrap_or(false)
    })
}

/// `(u, v)` (px) of the world point `p` in `cam`, if in front of it.
pub(super) fn project(cam: &crate::vision::Camera, p: &Vec3) -> Option<(f64, f64)> {
    let q = cam.world_from_optical.inverse_transform_point(&(*p).into());
    (q.z > 1e-6).then(|| (cam.fx * q.x / q.z + cam.cx, cam.fy * q.y / q.z + cam.cy))
}

/// The colour term with the largest share.
pub(super) fn dominant_term(colors: &[(u8, f64)]) -> Option<u8> {
    colors.iter().max_by(|a, b| a.1.total_cmp(&b.1)).map(|c| c.0)
}

/// Keeps the elements of `v` whose entry in `keep` is true (the tracker's per-track vectors).
pub(super) fn retain_mask<T>(v: &mut Vec<T>, keep: &[bool]) {
    let mut i = 0;
    v.retain(|_| {
        i += 1;
        keep[i - 1]
    });
}

/// Whether `blob`, matched to `track` while an arm is near, shows the object moved rather than
/// partly hidden. The centroid of any part of a convex object lies inside its footprint, so a view
/// whose centroid is clearly outside the track's footprint ([`MOVED_FOOTPRINT`]) is the object
/// somewhere else — if the view is trustworthy: most of the object's pixels (`share` of its whole
/// view ≥ [`MOVED_SHARE`]), alike in both cameras (a stereo pair of two different visible parts
/// triangulates to a wrong point, typically centimetres above the object) and at the track's
/// height ([`MOVED_DZ`]).
pub(super) fn moved_clear(track: &SegmentPercept, blob: &SegmentPercept, share: f64) -> bool {
    let Some(e) = track.extent.as_ref() else {
        return false;
    };
    let [l, r] = blob.pixels.map(f64::from);
    let lr = l / r.max(1.0);
    footprint_distance(e, [blob.centroid[0], blob.centroid[1]]) > MOVED_FOOTPRINT
        && share >= MOVED_SHARE
        && (blob.centroid[2] - track.centroid[2]).abs() < MOVED_DZ
        && (0.75..=1.0 / 0.75).contains(&lr)
}

/// The same test in the images, immune to the stereo error of a partial view: the image centroid
/// of a visible part of an object lies inside the object's silhouette — and the larger the part,
/// the nearer its middle: a part with the share s of a convex silhouette has its centroid within
/// (1 − s/2) of the half-width from the middle along any axis. A view whose image centroids lie
/// clearly beyond that ([`MOVED_PX`]) from the middle of the track's projected box (its footprint
/// and height) in **both** cameras is the object somewhere else — if most of it is seen (`share` ≥
/// [`MOVED_SHARE`]) and alike in both cameras. (A bumped can's partial view triangulated 5 cm high
/// and 4 cm short, its image centroids 11–13 px outside the box; a bumped bottle showing 66 % of
/// its pixels was 12 px from the middle of a box 22 px wide.)
pub(super) fn moved_in_images(
    track: &SegmentPercept,
    blob: &SegmentPercept,
    views: [[f64; 2]; 2],
    cams: [&crate::vision::Camera; 2],
    share: f64,
) -> bool {
    let [l, r] = blob.pixels.map(f64::from);
    let lr = l / r.max(1.0);
    if share < MOVED_SHARE || !(0.75..=1.0 / 0.75).contains(&lr) {
        return false;
    }
    let Some((lo, hi)) = projected_boxes(track, cams) else {
        return false;
    };
    // A part holding the share s of a convex silhouette has its centroid at most (1 − s/2) of the
    // half-width from the middle (the bound of a triangle's cap; a rectangle's is 1 − s), along
    // either image axis.
    let reach = 1.0 - 0.5 * share.min(1.0);
    (0..2).all(|k| {
        (0..2).any(|a| {
            let (mid, half) = (0.5 * (lo[k][a] + hi[k][a]), 0.5 * (hi[k][a] - lo[k][a]));
            (views[k][a] - mid).abs() > half * reach + MOVED_PX
        })
    })
}

/// Whether a partial view casts doubt on where its track is ([`DOUBT_PX`]): its image centroid in
/// each camera lies beyond where a visible part of the track's projected box can have it, given
/// that camera's share of half the track's whole pixel count `whole` (both cameras) — the test of
/// [`moved_in_images`] without its demand for a large, balanced view.
pub(super) fn image_doubt(
    track: &SegmentPercept,
    blob: &SegmentPercept,
    views: [[f64; 2]; 2],
    cams: [&crate::vision::Camera; 2],
    whole: f64,
) -> bool {
    let Some((lo, hi)) = projected_boxes(track, cams) else {
        return false;
    };
    (0..2).all(|k| {
        let share = (f64::from(blob.pixels[k]) / (0.5 * whole).max(1.0)).min(1.0);
        let reach = 1.0 - 0.5 * share;
        (0..2).any(|a| {
            let (mid, half) = (0.5 * (lo[k][a] + hi[k][a]), 0.5 * (hi[k][a] - lo[k][a]));
            (views[k][a] - mid).abs() > half * reach + DOUBT_PX
        })
    })
}

/// The image boxes (min, max corners per camera, px) of a track's extent projected into both
/// cameras, or `None` without an extent or with a corner behind a camera.
#[allow(clippy::type_complexity)]
pub(super) fn projected_boxes(
    track: &SegmentPercept,
    cams: [&crate::vision::Camera; 2],
) -> Option<([[f64; 2]; 2], [[f64; 2]; 2])> {
    let e = track.extent.as_ref()?;
    let [ax, ay] = e.major_axis;
    let z0 = track.centroid[2] - 0.5 * e.height;
    let mut lo = [[f64::INFINITY; 2]; 2];
    let mut hi = [[f64::NEG_INFINITY; 2]; 2];
    for (k, cam) in cams.iter().enumerate() {
        for (su, sv, sz) in box_corners() {
            let p = Vec3::new(
                e.center[0] + su * e.half_major * ax - sv * e.half_minor * ay,
                e.center[1] + su * e.half_major * ay + sv * e.half_minor * ax,
                z0 + sz * e.height,
            );
            let (u, v) = project(cam, &p)?;
            lo[k] = [lo[k][0].min(u), lo[k][1].min(v)];
            hi[k] = [hi[k][0].max(u), hi[k][1].max(v)];
        }
    }
    Some((lo, hi))
}

/// The eight corners of a box as signs (major, minor) ∈ {−1, 1} and height share ∈ {0, 1}.
pub(super) fn box_corners() -> impl Iterator<Item = (f64, f64, f64)> {
    (0..8).map(|i| {
        (
            if i & 1 == 0 { -1.0 } else { 1.0 },
            if i & 2 == 0 { -1.0 } else { 1.0 },
            f64::from((i >> 2) & 1),
        )
    })
}

/// A view's image centroid this far (px, at the head cameras' 160 × 120, ≈ 1.5 cm at the table's
/// range) beyond where a part of the track's projected box can have it shows the object moved
/// ([`moved_in_images`]).
pub(super) const MOVED_PX: f64 = 3.0;

/// Horizontal distance (m) from `p` to the footprint `e` (0 inside).
pub(super) fn footprint_distance(e: &schema::SeenExtent, p: [f64; 2]) -> f64 {
    let d = [p[0] - e.center[0], p[1] - e.center[1]];
    let [ax, ay] = e.major_axis;
    let u = (d[0] * ax + d[1] * ay).abs() - e.half_major;
    let v = (-d[0] * ay + d[1] * ax).abs() - e.half_minor;
    u.max(0.0).hypot(v.max(0.0))
}

/// Distance from `p` to the line of sight from `eye` to `target` (the segment between them).
pub(super) fn sight_distance(eye: &[f64; 3], target: &[f64; 3], p: &[f64; 3]) -> f64 {
    let d: [f64; 3] = std::array::from_fn(|i| target[i] - eye[i]);
    let w: [f64; 3] = std::array::from_fn(|i| p[i] - eye[i]);
    let dd: f64 = d.iter().map(|v| v * v).sum();
    let s = if dd > 0.0 {
        (d.iter().zip(&w).map(|(a, b)| a * b).sum::<f64>() / dd).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let q: [f64; 3] = std::array::from_fn(|i| eye[i] + s * d[i]);
    dist(&q, p)
}

/// A segment's pixel count in both cameras.
pub(super) fn pixels(s: &SegmentPercept) -> f64 {
    f64::from(s.pixels[0]) + f64::from(s.pixels[1])
}

pub(super) fn dist(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    (0..3).map(|i| (a[i] - b[i]).powi(2)).sum::<f64>().sqrt()
}
