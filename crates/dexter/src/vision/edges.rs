//! Tall things standing on the support plane — a post, a wall, a box too tall to grasp — located
//! from the vertical edges of their silhouettes.
//!
//! The silhouette centroid ([`crate::vision::StereoBlob::raw_centroid`]) of a tall thing is a poor
//! point to triangulate: its silhouettes are cut, differently in the two cameras, by the top of the
//! image and by the robot's chest, so the two centroids are images of different parts of it and
//! their rays meet far from it (a 50 cm post was seen 7–10 cm nearer the robot than it stood). Its
//! vertical edges, though, are the same physical lines in both views wherever they show:
//!
//! * In each image, the left (right) boundary of the segment, row by row, is kept where the
//!   pixels beside it are background — not the robot's self-mask, another segment or the image
//!   border (a boundary there is an occlusion, not the thing's edge) — and a line `u = a + b v` is
//!   fitted to it: the line through two boundary points that most others lie within
//!   [`EDGE_FIT_TOLERANCE_PX`] of (near its ends the boundary follows the top and bottom faces),
//!   then least squares over those.
//! * Back-projected, each image line is a plane through its camera's centre; the left planes of
//!   the two cameras meet in the thing's left edge, the right ones in its right edge (midpoint
//!   stereo on lines: every row votes, so the fit is sub-pixel where a single disparity is not).
//! * Both edges must be near vertical ([`MAX_EDGE_TILT`]), and their visible length must exceed
//!   [`MIN_EDGE_LENGTH`] — longer than any object the hand grasps — for the estimate to apply;
//!   the caller also asks the raw centroid to lie [`MIN_CENTROID_HEIGHT`] above the plane.
//!
//! The footprint is the segment between the two edges' points on the plane: its centre, its
//! direction and half length. The thing's depth along the line of sight is not seen (its front
//! face hides it); [`EdgeFootprint::half_depth`] is set to [`ASSUMED_HALF_DEPTH`] for those that
//! plan around it.
//!
//! Checked on a rendered 6 × 22 × 50 cm post whose lower rows the chest hides
//! (`a_tall_post_cut_by_the_chest_and_the_border_is_found_by_its_edges`): each edge within
//! 1.1 cm of the box's corner, the centre within 1 cm.

use crate::vision::segment::Segment;
use crate::vision::support::Footprint;
use control_basis::hardware::Camera;
use control_basis::math::Vec3;

/// Boundary pixels farther than this (px) from the consensus line are not on the edge.
pub const EDGE_FIT_TOLERANCE_PX: f64 = 1.5;

/// Fewest boundary rows for a line fit in one image.
pub const MIN_EDGE_ROWS: usize = 10;

/// Largest angle (rad) between a triangulated edge and the vertical: 20°.
pub const MAX_EDGE_TILT: f64 = 0.35;

/// Shortest visible edge (m, along z) for a segment to count as a tall standing thing: longer than
/// the tallest graspable object (22 cm) and its triangulation error.
pub const MIN_EDGE_LENGTH: f64 = 0.25;

/// Least height (m above the plane) of a standing thing's raw triangulated centroid, and …
/// (a graspable object of up to 22 cm has it at most about 11 cm up, but a cut or merged
/// silhouette can triangulate higher: a 20 cm thermos measured 16 cm and, from its edges, 32 cm
/// tall and 22 cm wide; the 50 cm post of the blocked-arm fault measures 33–36 cm)
pub const MIN_CENTROID_HEIGHT: f64 = 0.22;

/// … least height (m) of the top of its edges: things this tall are obstacles, never objects to
/// grasp.
pub const MIN_STANDING_TOP: f64 = 0.35;

/// Half the depth (m) assumed for a standing thing along the line of sight, which its silhouettes
/// do not show.
pub const ASSUMED_HALF_DEPTH: f64 = 0.04;

/// One camera's view of a segment for [`standing_edges`].
#[derive(Debug, Clone, Copy)]
pub struct EdgeView<'a> {
    /// The camera.
    pub camera: &'a Camera,
    /// Its component map (segment `i` has id `i + 1`).
    pub components: &'a [u32],
    /// The robot's self-mask of that frame (empty: none).
    pub self_mask: &'a [bool],
    /// The segment.
    pub segment: &'a Segment,
    /// The segment's component id.
    pub id: u32,
}

/// A tall thing standing on the support plane, from its two vertical silhouette edges.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EdgeFootprint {
    /// Where the left and right edges (as seen from the cameras) meet the plane (x, y; m).
    pub edges: [[f64; 2]; 2],
    /// Height (m above the plane) of the highest point of the edges both cameras see.
    pub top: f64,
    /// Whether that top is the thing's top: the segment does not reach the image's top border.
    pub top_seen: bool,
    /// Assumed half depth along the line of sight ([`ASSUMED_HALF_DEPTH`]).
    pub half_depth: f64,
    /// The footprint measured whole — from the edges' bases and the far outline of the top face —
    /// when the top is seen in both views ([`top_outline`]); `None`: only the edges are known.
    pub outline: Option<Footprint>,
}

impl EdgeFootprint {
    /// As a [`Footprint`]: centred between the edges, the major axis along them, the half depth
    /// across. (Seen obliquely, a box's silhouette edges are two opposite corners and their
    /// midpoint is its centre; seen face on, they are its front corners, half its depth nearer.)
    pub fn footprint(&self) -> Footprint {
        if let Some(f) = self.outline {
            return f;
        }
        let [l, r] = self.edges;
        let (dx, dy) = (r[0] - l[0], r[1] - l[1]);
        let len = dx.hypot(dy).max(1e-9);
        Footprint {
            center: [0.5 * (l[0] + r[0]), 0.5 * (l[1] + r[1])],
            major_axis: [dx / len, dy / len],
            half_major: 0.5 * len,
            half_minor: self.half_depth,
        }
    }
}

/// A fitted image line `u = a + b v` over rows `v0..=v1`.
#[derive(Debug, Clone, Copy)]
struct ImageLine {
    a: f64,
    b: f64,
    v0: f64,
    v1: f64,
}

/// Scratch buffers of [`standing_edges`].
#[derive(Debug, Clone, Default)]
pub struct EdgeScratch {
    points: Vec<[f64; 2]>,
    hull: Vec<[f64; 2]>,
}

/// The vertical edges of a segment seen by both cameras, standing on the plane at `table_z`, or
/// `None` when either edge is not found in either view, is not near vertical, or is shorter than
/// [`MIN_EDGE_LENGTH`], or its top is lower than [`MIN_STANDING_TOP`].
pub fn standing_edges(views: [EdgeView<'_>; 2], table_z: f64, scratch: &mut EdgeScratch) -> Option<EdgeFootprint> {
    let mut lines = [[None; 2]; 2];
    for (k, view) in views.iter().enumerate() {
        for (side, line) in lines[k].iter_mut().enumerate() {
            *line = Some(boundary_line(view, side == 1, scratch)?);
        }
    }
    let mut edges = [[0.0; 2]; 2];
    let mut top = f64::NEG_INFINITY;
    let mut bottom = f64::INFINITY;
    // The top's height for its outline, from the four lines' tops (two edges in two views).
    // Where a view sees the top face's receding side edge in line with a vertical edge (a post
    // seen end on, along that camera's line of sight), its fitted line runs on up that side edge
    // and its top lies above the thing's; the other camera, 8 cm aside, sees the side edge turn
    // away: so the lower of an edge's two views. Where an arm hides an edge's top, that edge's
    // tops lie below: so the higher of the two edges. (A rendered 50 cm post seen end on:
    // 0.600 / 0.524 and 0.518 / 0.600 → 0.524; development seed 2, blocked arm, scene 14:
    // 0.474 / 0.445 and 0.492 / 0.554 → 0.492.)
    let mut edge_top = [f64::NEG_INFINITY; 2];
    for side in 0..2 {
        let (Some(la), Some(lb)) = (lines[0][side], lines[1][side]) else {
            return None;
        };
        let na = plane_normal(views[0].camera, &la);
        let nb = plane_normal(views[1].camera, &lb);
        let dir = na.cross(&nb);
        let norm = dir.norm();
        if norm.is_nan() || norm <= 1e-9 || (dir.z.abs() / norm) < MAX_EDGE_TILT.cos() {
            return None;
        }
        let (oa, ob) = (views[0].camera.position(), views[1].camera.position());
        // The edge line: n_a·p = n_a·o_a, n_b·p = n_b·o_b; at height z it is the 2×2 solve below.
        let at = |z: f64| -> Option<Vec3> {
            let (ca, cb) = (na.dot(&oa) - na.z * z, nb.dot(&ob) - nb.z * z);
            let det = na.x * nb.y - na.y * nb.x;
            if det.abs() < 1e-12 {
                return None;
            }
            Some(Vec3::new(
                (ca * nb.y - cb * na.y) / det,
                (na.x * cb - nb.x * ca) / det,
                z,
            ))
        };
        let base = at(table_z)?;
        edges[side] = [base.x, base.y];
        // The visible span: where the rows seen by both cameras' fits meet the edge line (the
        // ray through each end row, closest point on the line).
        let line_dir = dir / norm;
        let mut line_top = [f64::NEG_INFINITY; 2];
        for (k, line) in [(0, la), (1, lb)] {
            for v in [line.v0, line.v1] {
                let (o, d) = views[k].camera.ray(line.a + line.b * v, v);
                if let Some(p) = closest_on_line(&o, &d, &base, &line_dir) {
                    top = top.max(p.z - table_z);
                    line_top[k] = line_top[k].max(p.z - table_z);
                    bottom = bottom.min(p.z - table_z);
                }
            }
        }
        edge_top[side] = line_top[0].min(line_top[1]);
    }
    let width = (edges[1][0] - edges[0][0]).hypot(edges[1][1] - edges[0][1]);
    let tall = top - bottom >= MIN_EDGE_LENGTH && top >= MIN_STANDING_TOP;
    if !tall || width.is_nan() || width <= 0.005 || width >= 1.0 || !edges.iter().flatten().all(|x| x.is_finite()) {
        return None;
    }
    let top_seen = views.iter().all(|v| v.segment.bbox[1] > 0);
    let top_face = edge_top[0].max(edge_top[1]);
    let outline = if top_seen && top_face.is_finite() {
        top_outline(&views, table_z + top_face, &edges, scratch)
    } else {
        None
    };
    tracing::trace!(
        "standing prism: edges {edges:?} top {top:.3} face {top_face:.3} seen {top_seen} outline {outline:?}, {} points",
        scratch.points.len()
    );
    Some(EdgeFootprint {
        edges,
        top,
        top_seen,
        half_depth: ASSUMED_HALF_DEPTH,
        outline,
    })
}

/// The whole footprint of a standing prism whose top both cameras see: the cameras look down on
/// it, so the upper boundary of its silhouette, column by column, is the far outline of its top
/// face — which, for an upright prism, is its footprint's far outline — and back-projected onto
/// the plane of the top (at `top_z`, from the edges) it gives the depth along the line of sight
/// that the edges alone do not (a post seen end on: its 22 cm length runs away from the head,
/// and its two edges are the near end's corners). Only columns whose top pixel has background
/// above it count (another segment or the robot's body there is an occlusion, not the outline).
/// The footprint is the smallest rectangle holding those points and the edges' bases
/// (`edges`); `None` with fewer than [`MIN_OUTLINE_POINTS`] points, or points farther than
/// [`MAX_OUTLINE_REACH`] from the edges (a top plane missed: the outline would run away).
fn top_outline(
    views: &[EdgeView<'_>; 2],
    top_z: f64,
    edges: &[[f64; 2]; 2],
    scratch: &mut EdgeScratch,
) -> Option<Footprint> {
    scratch.points.clear();
    let mut count = 0;
    for view in views {
        let (w, h) = (view.camera.width as usize, view.camera.height as usize);
        if view.components.len() != w * h || (!view.self_mask.is_empty() && view.self_mask.len() != w * h) {
            return None;
        }
        let background = |i: usize| view.components[i] == 0 && !view.self_mask.get(i).copied().unwrap_or(false);
        let [u0, v0, u1, v1] = view.segment.bbox.map(|x| x as usize);
        let eye = view.camera.position();
        let near = edges
            .iter()
            .map(|e| (e[0] - eye.x).hypot(e[1] - eye.y))
            .fold(f64::INFINITY, f64::min);
        let mut here = 0;
        for u in u0..=u1.min(w - 1) {
            let Some(v) = (v0..=v1.min(h - 1)).find(|&v| view.components[v * w + u] == view.id) else {
                continue;
            };
            if v < 2 || !background((v - 1) * w + u) || !background((v - 2) * w + u) {
                continue;
            }
            // The boundary lies between the pixel and the one above it.
            let (o, d) = view.camera.ray(u as f64, v as f64 - 0.5);
            if d.z >= -1e-6 {
                continue;
            }
            let t = (top_z - o.z) / d.z;
            let p = [o.x + t * d.x, o.y + t * d.y];
            // The far outline lies beyond the near edges; a top pixel nearer than them is not
            // the thing's (a piece of an arm merged with its silhouette).
            if (p[0] - o.x).hypot(p[1] - o.y) < near - OUTLINE_NEAR_TOLERANCE {
                continue;
            }
            scratch.points.push(p);
            here += 1;
        }
        if here < MIN_OUTLINE_POINTS {
            return None;
        }
        count += here;
    }
    let mid = [0.5 * (edges[0][0] + edges[1][0]), 0.5 * (edges[0][1] + edges[1][1])];
    if count == 0
        || scratch
            .points
            .iter()
            .any(|p| !p[0].is_finite() || (p[0] - mid[0]).hypot(p[1] - mid[1]) > MAX_OUTLINE_REACH)
    {
        return None;
    }
    scratch.points.extend_from_slice(edges);
    min_area_rectangle(&mut scratch.points, &mut scratch.hull)
}

/// How much nearer (m, horizontally) than the nearer edge an outline point may lie.
pub const OUTLINE_NEAR_TOLERANCE: f64 = 0.02;

/// Fewest outline columns per view for [`top_outline`].
pub const MIN_OUTLINE_POINTS: usize = 4;

/// Farthest (m) an outline point may lie from the middle of the edges' bases.
pub const MAX_OUTLINE_REACH: f64 = 0.5;

/// The smallest-area rectangle holding `points` (x, y; reordered): over the directions of its
/// convex hull's edges (one of which the smallest rectangle shares).
fn min_area_rectangle(points: &mut Vec<[f64; 2]>, hull: &mut Vec<[f64; 2]>) -> Option<Footprint> {
    points.sort_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
    points.dedup();
    if points.len() < 3 {
        return None;
    }
    // Andrew's monotone chain.
    let cross = |o: [f64; 2], a: [f64; 2], b: [f64; 2]| (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]);
    hull.clear();
    for pass in 0..2 {
        let start = hull.len();
        for i in 0..points.len() {
            let p = if pass == 0 {
                points[i]
            } else {
                points[points.len() - 1 - i]
            };
            while hull.len() >= start + 2 && cross(hull[hull.len() - 2], hull[hull.len() - 1], p) <= 0.0 {
                hull.pop();
            }
            hull.push(p);
        }
        hull.pop();
    }
    if hull.len() < 3 {
        return None;
    }
    let mut best: Option<(f64, Footprint)> = None;
    for i in 0..hull.len() {
        let (a, b) = (hull[i], hull[(i + 1) % hull.len()]);
        let len = (b[0] - a[0]).hypot(b[1] - a[1]);
        if len < 1e-9 {
            continue;
        }
        let e = [(b[0] - a[0]) / len, (b[1] - a[1]) / len];
        let n = [-e[1], e[0]];
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for p in hull.iter() {
            let (s, t) = (p[0] * e[0] + p[1] * e[1], p[0] * n[0] + p[1] * n[1]);
            lo = [lo[0].min(s), lo[1].min(t)];
            hi = [hi[0].max(s), hi[1].max(t)];
        }
        let area = (hi[0] - lo[0]) * (hi[1] - lo[1]);
        if best.as_ref().is_none_or(|(m, _)| area < *m) {
            let (cs, ct) = (0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]));
            let (hs, ht) = (0.5 * (hi[0] - lo[0]), 0.5 * (hi[1] - lo[1]));
            let center = [cs * e[0] + ct * n[0], cs * e[1] + ct * n[1]];
            let (major_axis, half_major, half_minor) = if hs >= ht { (e, hs, ht) } else { (n, ht, hs) };
            best = Some((
                area,
                Footprint {
                    center,
                    major_axis,
                    half_major,
                    half_minor,
                },
            ));
        }
    }
    best.map(|(_, f)| f)
}

/// The point of the line `p0 + s·u` closest to the ray `o + t·d` (t > 0).
fn closest_on_line(o: &Vec3, d: &Vec3, p0: &Vec3, u: &Vec3) -> Option<Vec3> {
    let w = p0 - o;
    let b = u.dot(d);
    let denom = 1.0 - b * b;
    if denom.is_nan() || denom <= 1e-12 {
        return None;
    }
    let s = (b * d.dot(&w) - u.dot(&w)) / denom;
    Some(p0 + u * s)
}

/// The normal of the plane through the camera centre and the image line.
fn plane_normal(cam: &Camera, line: &ImageLine) -> Vec3 {
    let (_, d0) = cam.ray(line.a + line.b * line.v0, line.v0);
    let (_, d1) = cam.ray(line.a + line.b * line.v1, line.v1);
    d0.cross(&d1).normalize()
}

/// The left (`right == false`) or right boundary of a segment, where it is the thing's own edge,
/// as a fitted line.
fn boundary_line(view: &EdgeView<'_>, right: bool, scratch: &mut EdgeScratch) -> Option<ImageLine> {
    let (w, h) = (view.camera.width as usize, view.camera.height as usize);
    if view.components.len() != w * h || (!view.self_mask.is_empty() && view.self_mask.len() != w * h) {
        return None;
    }
    let [u0, v0, u1, v1] = view.segment.bbox.map(|x| x as usize);
    let background = |u: usize, v: usize| {
        let i = v * w + u;
        view.components[i] == 0 && !view.self_mask.get(i).copied().unwrap_or(false)
    };
    scratch.points.clear();
    for v in v0..=v1.min(h - 1) {
        let row = &view.components[v * w..(v + 1) * w];
        let found = if right {
            (u0..=u1.min(w - 1)).rev().find(|&u| row[u] == view.id)
        } else {
            (u0..=u1.min(w - 1)).find(|&u| row[u] == view.id)
        };
        let Some(u) = found else {
            continue;
        };
        // Two pixels of background beside it, inside the image.
        let clear = if right {
            u + 2 < w && background(u + 1, v) && background(u + 2, v)
        } else {
            u >= 2 && background(u - 1, v) && background(u - 2, v)
        };
        if clear {
            // The boundary lies between the pixel and its outer neighbour.
            let edge = if right { u as f64 + 0.5 } else { u as f64 - 0.5 };
            scratch.points.push([v as f64, edge]);
        }
    }
    // The boundary runs along the vertical edge over most rows and along the top and bottom
    // faces' edges at its ends: the line through two boundary points that most others lie on
    // (within the tolerance), then least squares over those.
    let pts = &scratch.points;
    let mut best: Option<(usize, f64, f64)> = None;
    for i in (0..pts.len()).step_by(2) {
        for j in (i + MIN_EDGE_ROWS..pts.len()).step_by(2) {
            let b = (pts[j][1] - pts[i][1]) / (pts[j][0] - pts[i][0]);
            let a = pts[i][1] - b * pts[i][0];
            let n = pts
                .iter()
                .filter(|p| (p[1] - (a + b * p[0])).abs() <= EDGE_FIT_TOLERANCE_PX)
                .count();
            if best.is_none_or(|(m, ..)| n > m) {
                best = Some((n, a, b));
            }
        }
    }
    let (_, a, b) = best?;
    scratch
        .points
        .retain(|p| (p[1] - (a + b * p[0])).abs() <= EDGE_FIT_TOLERANCE_PX);
    let fit = fit_line(&scratch.points)?;
    let (lo, hi) = scratch
        .points
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(p[0]), hi.max(p[0]))
        });
    Some(ImageLine {
        a: fit.0,
        b: fit.1,
        v0: lo,
        v1: hi,
    })
}

/// Least-squares `u = a + b v` through points `[v, u]`: `None` with fewer than [`MIN_EDGE_ROWS`]
/// points or rows spanning fewer than that.
fn fit_line(points: &[[f64; 2]]) -> Option<(f64, f64)> {
    if points.len() < MIN_EDGE_ROWS {
        return None;
    }
    let n = points.len() as f64;
    let (sv, su) = points.iter().fold((0.0, 0.0), |(a, b), p| (a + p[0], b + p[1]));
    let (mv, mu) = (sv / n, su / n);
    let (svv, svu) = points.iter().fold((0.0, 0.0), |(a, b), p| {
        (a + (p[0] - mv).powi(2), b + (p[0] - mv) * (p[1] - mu))
    });
    if svv < (MIN_EDGE_ROWS as f64).powi(3) / 12.0 {
        return None;
    }
    let b = svu / svv;
    Some((mu - b * mv, b))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::vision::StereoCameras;
    use control_basis::hardware::Intrinsics;

    /// The component maps (id 1) of a 50 cm box standing on the table at 0.75 m — centre `c`,
    /// long side along `axis`, half extents `half` — rendered by projecting a dense point set, with
    /// the rows from `chest` down hidden by a self-mask (the robot's chest); and the self-mask.
    fn rendered_post(
        cams: &StereoCameras,
        c: [f64; 2],
        axis: [f64; 2],
        half: [f64; 2],
        chest: usize,
    ) -> (Vec<Vec<u32>>, Vec<bool>) {
        let table = 0.75;
        let n = [-axis[1], axis[0]];
        let mut maps = Vec::new();
        for cam in [&cams.left, &cams.right] {
            let mut comp = vec![0u32; 160 * 120];
            for i in 0..=88 {
                for j in 0..=24 {
                    for k in 0..=200 {
                        let s = -half[0] + 2.0 * half[0] * f64::from(i) / 88.0;
                        let t = -half[1] + 2.0 * half[1] * f64::from(j) / 24.0;
                        let z = table + 0.5 * f64::from(k) / 200.0;
                        let p = Vec3::new(c[0] + s * axis[0] + t * n[0], c[1] + s * axis[1] + t * n[1], z);
                        if let Some((u, v)) = cam.project(&p) {
                            comp[v.round() as usize * 160 + u.round() as usize] = 1;
                        }
                    }
                }
            }
            maps.push(comp);
        }
        let mask: Vec<bool> = (0..160 * 120).map(|i| i / 160 >= chest).collect();
        for comp in &mut maps {
            for (i, m) in mask.iter().enumerate() {
                if *m {
                    comp[i] = 0;
                }
            }
        }
        (maps, mask)
    }

    /// The segment of component 1 in `comp` (its bounding box is all that is used).
    fn post_segment(comp: &[u32]) -> Segment {
        let mut b = [u32::MAX, u32::MAX, 0, 0];
        for (i, &x) in comp.iter().enumerate() {
            if x == 1 {
                let (u, v) = ((i % 160) as u32, (i / 160) as u32);
                b = [b[0].min(u), b[1].min(v), b[2].max(u), b[3].max(v)];
            }
        }
        Segment {
            features: crate::vision::segment::SegmentFeatures {
                pixel_count: 1,
                centroid: [0.0; 2],
                covariance: [[0.0; 2]; 2],
                histogram: Default::default(),
                mean_rgb: [0.0; 3],
                mean_hsv: [0.0; 3],
                color_terms: [0; 10],
            },
            bbox: b,
            touches_border: false,
            touches_robot: true,
        }
    }

    fn find_post(cams: &StereoCameras, c: [f64; 2], axis: [f64; 2], half: [f64; 2], chest: usize) -> EdgeFootprint {
        let (maps, mask) = rendered_post(cams, c, axis, half, chest);
        let segs: Vec<Segment> = maps.iter().map(|m| post_segment(m)).collect();
        let views = [0, 1].map(|k| EdgeView {
            camera: if k == 0 { &cams.left } else { &cams.right },
            components: &maps[k],
            self_mask: &mask,
            segment: &segs[k],
            id: 1,
        });
        standing_edges(views, 0.75, &mut EdgeScratch::default()).expect("edges found")
    }

    fn intrinsics() -> Intrinsics {
        Intrinsics {
            width: 160,
            height: 120,
            hfov_deg: 60.0,
        }
    }

    /// A 6 × 22 × 50 cm post, its lower rows hidden by the chest and its top beyond the image in
    /// one camera: its edges are found within 2 cm.
    #[test]
    fn a_tall_post_cut_by_the_chest_and_the_border_is_found_by_its_edges() {
        let cams = StereoCameras::verged(
            &intrinsics(),
            Vec3::new(0.05, 0.04, 1.55),
            Vec3::new(0.05, -0.04, 1.55),
            Vec3::new(0.6, 0.0, 0.85),
        )
        .unwrap();
        // The post: centre (0.52, −0.07), long side 22 cm along (0.5, 0.866), 6 cm deep.
        let (c, axis, half) = ([0.52, -0.07], [0.5f64, 0.866f64], [0.11, 0.03]);
        let found = find_post(&cams, c, axis, half, 95);
        let fp = found.footprint();
        let err = (fp.center[0] - c[0]).hypot(fp.center[1] - c[1]);
        assert!(err < 0.02, "centre {:?} vs {c:?} ({err:.3} m)", fp.center);
        assert!((fp.half_major - half[0]).abs() < 0.04, "half length {}", fp.half_major);
        assert!(found.top > 0.4, "top {}", found.top);
    }

    /// The same post seen end on — its 22 cm running away from the head, as the blocked-arm fault
    /// put it beside the left arm (development seed 2, scene 14: the edges alone, the near end's
    /// corners, measured it 9 cm wide and 9 cm nearer the head) — with its top in view: the far
    /// outline of its top gives its length, and the footprint is found within 2 cm.
    #[test]
    fn a_post_seen_end_on_is_measured_whole_from_the_outline_of_its_top() {
        let cams = StereoCameras::verged(
            &intrinsics(),
            Vec3::new(0.05, 0.04, 1.55),
            Vec3::new(0.05, -0.04, 1.55),
            Vec3::new(0.5, 0.15, 1.15),
        )
        .unwrap();
        let (c, half) = ([0.47, 0.16], [0.11, 0.03]);
        let d: [f64; 2] = [c[0] - 0.05, c[1]];
        let l = d[0].hypot(d[1]);
        let axis = [d[0] / l, d[1] / l];
        let found = find_post(&cams, c, axis, half, 115);
        assert!(found.top_seen && found.outline.is_some(), "{found:?}");
        let fp = found.footprint();
        let err = (fp.center[0] - c[0]).hypot(fp.center[1] - c[1]);
        assert!(err < 0.03, "centre {:?} vs {c:?} ({err:.3} m)", fp.center);
        assert!((fp.half_major - half[0]).abs() < 0.03, "half length {}", fp.half_major);
        assert!((fp.half_minor - half[1]).abs() < 0.02, "half width {}", fp.half_minor);
        let along = (fp.major_axis[0] * axis[0] + fp.major_axis[1] * axis[1]).abs();
        assert!(along > 0.97, "axis {:?} vs {axis:?}", fp.major_axis);
    }

    /// The smallest rectangle round the corners of a rotated rectangle and points inside it is
    /// that rectangle.
    #[test]
    fn the_smallest_rectangle_round_a_rotated_box_is_the_box() {
        let (c, e, h) = ([0.4, -0.2], [0.6f64, 0.8f64], [0.1, 0.03]);
        let n = [-e[1], e[0]];
        let mut pts = Vec::new();
        for (s, t) in [
            (-1.0, -1.0),
            (1.0, -1.0),
            (1.0, 1.0),
            (-1.0, 1.0),
            (0.3, 0.2),
            (-0.5, -0.1),
        ] {
            pts.push([
                c[0] + s * h[0] * e[0] + t * h[1] * n[0],
                c[1] + s * h[0] * e[1] + t * h[1] * n[1],
            ]);
        }
        let f = min_area_rectangle(&mut pts, &mut Vec::new()).unwrap();
        assert!(
            (f.center[0] - c[0]).abs() < 1e-9 && (f.center[1] - c[1]).abs() < 1e-9,
            "{f:?}"
        );
        assert!(
            (f.half_major - h[0]).abs() < 1e-9 && (f.half_minor - h[1]).abs() < 1e-9,
            "{f:?}"
        );
        assert!(
            (f.major_axis[0] * e[0] + f.major_axis[1] * e[1]).abs() > 1.0 - 1e-9,
            "{f:?}"
        );
    }
}
