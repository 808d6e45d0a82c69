//! What Dexter perceives while it is being taught: one [`schema::Percept`] per observation step, from
//! its own sensors only — kinematics and encoders for the palms, the fingertip force/torque sensors
//! for contact and carried load, and the head's stereo cameras for segments (tracked across frames)
//! and the foveated stimulus. The robot is told its places (it knows its bins) and the table height,
//! never object poses.

use control_basis::Hardware;
use control_basis::hardware::ForceTorque;
use control_basis::math::Vec3;
use schema::{HandPercept, Percept, PlacePercept, SegmentPercept};

use crate::arm::Arm;
use crate::body::Body;
use crate::error::RobotError;
use crate::eyes::{Eyes, Pair, SearchTrack};

/// Tracks segments across frames by their triangulated centroids. A segment a hand carries moves with
/// the palm (the robot knows what it holds), so it keeps its id while the hand hides it; two tracks
/// closer than [`MERGE_GAP`] are one object seen in pieces; a track not seen for [`FORGET_SECS`] that
/// nothing carries is forgotten.
///
/// **Self-occlusion.** The robot's own pixels are never foreground, so a hand over an object cuts
/// its segment to the part still visible, whose centroid is off by the hidden part (a block under
/// the palm measured 6 cm off, and the palm then never looked "at" it). A resting object does not
/// move until something touches it, so while a hand or forearm is near a line of sight from a head
/// camera to an uncarried track ([`OCCLUSION_RADIUS`], [`FOREARM_RADIUS`]) and the segment shows
/// markedly fewer pixels than when it was last seen whole ([`OCCLUDED_SHARE`] of its largest
/// unhidden view), the track keeps its unoccluded centroid and features and is only marked seen; a track an arm may be hiding entirely is not forgotten. A pushed object is seen
/// where it was until the hand leaves; then it is re-acquired (the gate near a palm is
/// [`OCCLUDED_GATE`]).
#[derive(Debug, Clone, Default)]
struct Tracker {
    tracks: Vec<SegmentPercept>,
    last_seen: Vec<f64>,
    /// The time of the last update (s).
    last_t: Option<f64>,
    /// Per track: its largest pixel count (both cameras) seen with no arm near a line of sight.
    whole_pixels: Vec<f64>,
    /// Per track: whether it was ever seen whole — in both cameras, cut by neither the image border
    /// nor the robot's body ([`crate::vision::Segment::cut_off`]).
    whole: Vec<bool>,
    /// Per track: consecutive frames in which a partial view of it (near an arm, or cut) lay at its
    /// height but outside its footprint ([`DOUBT_FOOTPRINT`]): it may have moved under the hand.
    doubt: Vec<u32>,
    /// Per track: where the segment associated with it in the latest frame puts it (x, y, z), as
    /// measured even when the track kept what it saw whole — from its one uncut view at the
    /// track's height if the other view was cut, else its stereo centroid.
    latest: Vec<Option<[f64; 3]>>,
    /// Per hand: the carried track's id and the palm position at the last update.
    carried: [Option<(u32, [f64; 3])>; 2],
    /// Per hand: frames in a row the carrying hand did not hold.
    unheld: [u32; 2],
    next_id: u32,
}

/// Whether a segment's extent was measured from its vertical edges: a tall thing standing on the
/// table ([`crate::vision::edges`]).
fn standing(s: &SegmentPercept) -> bool {
    s.extent.as_ref().is_some_and(|e| e.model.starts_with("standing"))
}

/// Whether a standing thing's footprint was measured whole ([`crate::vision::edges`]: the outline
/// of its top seen).
fn standing_whole(s: &SegmentPercept) -> bool {
    s.extent.as_ref().is_some_and(|e| e.model == "standing_whole")
}

/// Whether a segment is taller than any object the hand grasps: measured standing from its edges,
/// or its coarse height (twice its centroid's height above the table) at the 0.4 m clamp.
fn tall(s: &SegmentPercept) -> bool {
    s.extent
        .as_ref()
        .is_some_and(|e| e.model.starts_with("standing") || (e.model == "coarse" && e.height >= 0.4 - 1e-9))
}

/// A segment moves at most this far between two frames to keep its id (m).
const TRACK_GATE: f64 = 0.08;
/// Tracks closer than this are merged (m).
const MERGE_GAP: f64 = 0.04;
/// Unseen, uncarried tracks are dropped after this long in view of both cameras (s): time while
/// the track is outside an image, behind the robot's body or near an arm does not count.
const FORGET_SECS: f64 = 1.0;
/// A palm within this distance (m) of a line of sight from a head camera to a track may hide part
/// of it (the open hand reaches about this far from the palm).
const OCCLUSION_RADIUS: f64 = 0.16;
/// The same for points on the forearm (its radius and a margin, m).
const FOREARM_RADIUS: f64 = 0.10;
/// A segment near an arm showing fewer than this share of the largest pixel count (both cameras) its
/// track had with no arm near is taken as partly hidden by the arm (pixel noise is ≈ ±5 %).
const OCCLUDED_SHARE: f64 = 0.85;
/// A view near an arm whose centroid is this far (m) outside the track's footprint may show the
/// object moved ([`moved_clear`]; partial views measured up to 2.2 cm outside from stereo noise).
const MOVED_FOOTPRINT: f64 = 0.03;
/// … if it shows at least this share of the track's whole view …
const MOVED_SHARE: f64 = 0.55;
/// … and its centroid is within this height (m) of the track's (mismatched stereo pairs of a
/// partly hidden object measured 4–7 cm high).
const MOVED_DZ: f64 = 0.035;
/// Margin (px) around a cut segment's bounding box within which a track's projection makes the
/// segment a view of that track.
const BOX_MARGIN_PX: f64 = 2.0;
/// A stereo centroid this far (m) below the table top is a false match.
const BELOW_TABLE: f64 = 0.01;
/// A carried track stays latched to its hand until the hand has not held for this many frames.
const UNHELD_FRAMES: u32 = 3;
/// An unmatched segment this close (m) to a palm that carries something is a piece of that object.
const CARRIED_RADIUS: f64 = 0.12;
/// The association gate for a track near a palm (m): a partly hidden segment's centroid moves by up
/// to the size of the hidden part.
const OCCLUDED_GATE: f64 = 0.12;
/// A partial view (near an arm, or cut) whose image centroids lie beyond where any visible part
/// of the track's projected box can have them, by this much (px) in both cameras, casts doubt on
/// where the track is ([`image_doubt`]). Not proof — the box comes from a measured extent, and a
/// view's share of the whole is known only roughly — so the robot looks again with its hand out of
/// the way before it closes ([`Watcher::doubted`]). (The stereo centroid of a partial view is no
/// help: a cup two-thirds hidden by the fingers triangulated 4.5 cm high after a 0.2 px change.)
const DOUBT_PX: f64 = 1.5;
/// … in this many frames in a row.
pub const DOUBT_FRAMES: u32 = 3;
/// The association gate for a segment cut by the image border or the robot's body in either camera
/// (m): its centroid lies off by up to the size of the hidden part, and a stereo pair of one whole
/// and one cut view triangulates the difference as depth (a lying can cut by the arm in one camera
/// measured 9.6 cm from its whole view, and started a second track).
const CUT_GATE: f64 = 0.12;

impl Tracker {
    /// Moves carried tracks with their palms; `holding[k]` says whether hand k holds something.
    fn predict(&mut self, palms: &[[f64; 3]; 2], holding: [bool; 2]) {
        for k in 0..2 {
            if holding[k] {
                self.unheld[k] = 0;
            }
            match (self.carried[k], holding[k]) {
                (Some((id, prev)), true) => {
                    if let Some(t) = self.tracks.iter_mut().find(|t| t.id == id) {
                        for i in 0..3 {
                            t.centroid[i] += palms[k][i] - prev[i];
                        }
                        if let Some(e) = t.extent.as_mut() {
                            for i in 0..2 {
                                e.center[i] += palms[k][i] - prev[i];
                            }
                        }
                    }
                    self.carried[k] = Some((id, palms[k]));
                }
                (None, true) => {
                    // Latch the track nearest the palm.
                    self.carried[k] = self
                        .tracks
                        .iter()
                        .map(|t| (dist(&t.centroid, &palms[k]), t.id))
                        .filter(|(d, _)| *d < 0.15)
                        .min_by(|a, b| a.0.total_cmp(&b.0))
                        .map(|(_, id)| (id, palms[k]));
                }
                (Some(_), false) => {
                    // The holding test flickers while the load passes to a support: let go of the
                    // latch only after a few frames without it.
                    self.unheld[k] += 1;
                    if self.unheld[k] >= UNHELD_FRAMES {
                        self.carried[k] = None;
                    }
                }
                (None, false) => {}
            }
        }
    }

    /// Associates this frame's segments with the tracks. `cut[i]`: segment `i` is cut by the image
    /// border or the robot's body in either camera — its centroid is biased, so it is gated wider
    /// ([`CUT_GATE`]), it does not overwrite a track seen whole, and it starts a track only with no
    /// track within [`CUT_GATE`]; a track never seen whole is dropped once a track seen whole lies
    /// within [`CUT_GATE`] of it.
    #[allow(clippy::too_many_arguments)]
    fn update(
        &mut self,
        seen: Vec<SegmentPercept>,
        cut: &[bool],
        views: &[[[f64; 2]; 2]],
        boxes: &[[[u32; 4]; 2]],
        mono: &[MonoView],
        cams: [&crate::vision::Camera; 2],
        masks: [&[bool]; 2],
        t: f64,
        occluders: &[([f64; 3], f64)],
    ) {
        let eyes = cams.map(|c| {
            let v = c.world_from_optical.translation.vector;
            [v.x, v.y, v.z]
        });
        for tr in &mut self.tracks {
            tr.seen = false;
        }
        self.latest.iter_mut().for_each(|l| *l = None);
        let carried_ids: Vec<u32> = self.carried.iter().flatten().map(|c| c.0).collect();
        // Uncarried tracks an arm may be hiding part of: a hand or forearm near a line of sight.
        let near_palm: Vec<bool> = self
            .tracks
            .iter()
            .map(|tr| {
                !carried_ids.contains(&tr.id)
                    && occluders
                        .iter()
                        .any(|(p, r)| eyes.iter().any(|e| sight_distance(e, &tr.centroid, p) < *r))
            })
            .collect();
        // Whether track j projects inside segment i's bounding box in either camera: a cut view's
        // triangulated centroid may be far off (a sliver beside the arm in one camera matched with
        // the whole object in the other measured 14 cm away), its image is not.
        let inside = |i: usize, tr: &SegmentPercept| {
            (0..2).any(|k| {
                let b = boxes[i][k];
                if b[0] > b[2] {
                    return false;
                }
                project(cams[k], &Vec3::from(tr.centroid)).is_some_and(|(u, v)| {
                    u >= f64::from(b[0]) - BOX_MARGIN_PX
                        && u <= f64::from(b[2]) + BOX_MARGIN_PX
                        && v >= f64::from(b[1]) - BOX_MARGIN_PX
                        && v <= f64::from(b[3]) + BOX_MARGIN_PX
                })
            })
        };
        // Greedy nearest-first assignment.
        let mut pairs: Vec<(f64, usize, usize)> = Vec::new();
        for (i, s) in seen.iter().enumerate() {
            for (j, tr) in self.tracks.iter().enumerate() {
                // An object seen whole on the table is never taken for a tall thing beside it (a
                // post that an arm reaching past the object leaves in view, while it hides the
                // object: the track jumped to the post, and the robot reached for the post).
                if self.whole[j] && !carried_ids.contains(&tr.id) && tall(s) && !tall(tr) {
                    continue;
                }
                let d = dist(&s.centroid, &tr.centroid);
                if cut[i] && d >= CUT_GATE && !near_palm[j] && inside(i, tr) {
                    pairs.push((d, i, j));
                    continue;
                }
                let gate = if near_palm[j] {
                    OCCLUDED_GATE
                } else if cut[i] {
                    CUT_GATE
                } else {
                    TRACK_GATE
                };
                if d < gate {
                    pairs.push((d, i, j));
                }
            }
        }
        pairs.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut used_s = vec![false; seen.len()];
        let mut used_t = vec![false; self.tracks.len()];
        for (_, i, j) in pairs {
            if used_s[i] || used_t[j] {
                continue;
            }
            used_s[i] = true;
            used_t[j] = true;
            let id = self.tracks[j].id;
            let px = pixels(&seen[i]);
            let share = px / self.whole_pixels[j];
            let moved = near_palm[j]
                && (moved_clear(&self.tracks[j], &seen[i], share)
                    || moved_in_images(&self.tracks[j], &seen[i], views[i], cams, share));
            // A cut view that still shows most of the object, alike in both cameras (the bottom
            // of a cup beside the robot's body, hidden by a few rows), measures it nearly as well
            // as a whole one.
            let [l, r] = seen[i].pixels.map(f64::from);
            let mostly = px >= OCCLUDED_SHARE * self.whole_pixels[j] && (0.8..=1.25).contains(&(l / r.max(1.0)));
            let partial = near_palm[j] || (cut[i] && !mostly);
            let suspect = partial && image_doubt(&self.tracks[j], &seen[i], views[i], cams, self.whole_pixels[j]);
            self.doubt[j] = if suspect { self.doubt[j] + 1 } else { 0 };
            // A cut view at the track's height, which has cast doubt on it frame after frame with
            // no arm near: the object is where this view shows it, not where it was seen whole.
            let level = (seen[i].centroid[2] - self.tracks[j].centroid[2]).abs() < MOVED_DZ;
            self.latest[j] = Some({
                // One view cut (its box withheld), the other whole: the ray through the whole
                // view's centroid at the track's height.
                let whole_view = match boxes[i].map(|b| b[0] <= b[2]) {
                    [true, false] => Some(0),
                    [false, true] => Some(1),
                    _ => None,
                };
                whole_view
                    .and_then(|k| {
                        let (o, d) = cams[k].ray(views[i][k][0], views[i][k][1]);
                        let tz = (self.tracks[j].centroid[2] - o.z) / d.z;
                        (tz.is_finite() && tz > 0.0).then(|| {
                            let p = o + d * tz;
                            [p.x, p.y, p.z]
                        })
                    })
                    .unwrap_or(seen[i].centroid)
            });
            tracing::trace!(
                "ASSOC t={t:.2} seg {i} -> track {} near_palm {} cut {} moved {} px {px:.0}/{:.0} whole {} doubt {}",
                self.tracks[j].id,
                near_palm[j],
                cut[i],
                moved,
                self.whole_pixels[j],
                self.whole[j],
                self.doubt[j]
            );
            if carried_ids.contains(&id) {
                // A carried object is seen merged with the hand that holds it (its centroid and
                // height pulled towards the hand): it stays where its palm moved it, with what it
                // looked like on the table, so that it is put down where it is.
                self.tracks[j].seen = true;
            } else if (standing(&self.tracks[j]) && !standing(&seen[i]))
                || (standing_whole(&self.tracks[j]) && !standing_whole(&seen[i]))
            {
                // A thing too tall to grasp, located from its edges (it stands where it stood: no
                // hand moves it), keeps that location when a view shows only one of its edges
                // (an arm beside it) and the cut silhouettes' centroid measures it 10 cm off — and
                // keeps its footprint measured whole when a view does not show its top.
                self.tracks[j].seen = true;
            } else if near_palm[j] && px < OCCLUDED_SHARE * self.whole_pixels[j] && !moved {
                // Partly hidden by the hand: keep what was seen whole.
                self.tracks[j].seen = true;
            } else if cut[i]
                && (!mostly || near_palm[j])
                && !(self.doubt[j] >= DOUBT_FRAMES && !near_palm[j] && level)
                && (self.whole[j] || dist(&seen[i].centroid, &self.tracks[j].centroid) >= CUT_GATE)
            {
                // Cut by the border or the robot's body: keep what was seen whole, or where it was
                // when only its image explains the segment.
                self.tracks[j].seen = true;
            } else {
                self.whole[j] |= !cut[i];
                self.tracks[j] = SegmentPercept { id, ..seen[i].clone() };
                if !near_palm[j] {
                    // The largest view: an arm not yet near a line of sight may already hide a little.
                    self.whole_pixels[j] = self.whole_pixels[j].max(px);
                }
            }
            self.last_seen[j] = t;
        }
        // A track no stereo segment matched is still seen when one camera alone shows a blob
        // whose main colour is one of the track's where the track projects (the other camera's
        // view of it was cut by the image border or by an arm, so stereo matching failed): it
        // keeps its centroid and features.
        let mut used_mono = vec![false; mono.len()];
        for ((track, last_seen), matched) in self.tracks.iter_mut().zip(&mut self.last_seen).zip(&used_t) {
            if *matched || carried_ids.contains(&track.id) {
                continue;
            }
            let c = Vec3::from(track.centroid);
            let colors = &track.colors;
            let best = mono
                .iter()
                .enumerate()
                .filter(|(m, v)| !used_mono[*m] && v.term.is_some_and(|t| colors.iter().any(|c| c.0 == t)))
                .filter_map(|(m, v)| {
                    let (u, w) = project(cams[v.camera], &c)?;
                    let d = (u - v.centroid[0]).hypot(w - v.centroid[1]);
                    (d < MONO_GATE_PX).then_some((d, m))
                })
                .min_by(|a, b| a.0.total_cmp(&b.0));
            if let Some((_, m)) = best {
                used_mono[m] = true;
                track.seen = true;
                *last_seen = t;
            }
        }
        for (i, s) in seen.into_iter().enumerate() {
            // The hand splits what it carries into pieces: a piece near a carrying palm is part of
            // the carried object, not a new one.
            let carried_piece = self
                .carried
                .iter()
                .flatten()
                .any(|(_, palm)| dist(&s.centroid, palm) < CARRIED_RADIUS);
            // A cut view near a track is a piece of that object (seen whole elsewhere, or to be).
            let cut_piece = cut[i]
                && self
                    .tracks
                    .iter()
                    .any(|tr| dist(&s.centroid, &tr.centroid) < CUT_GATE || inside(i, tr));
            if !used_s[i] && !carried_piece && !cut_piece {
                tracing::trace!(
                    "NEW t={t:.2} track {} at {:?} pixels {:?} cut {}",
                    self.next_id,
                    s.centroid,
                    s.pixels,
                    cut[i]
                );
                self.whole_pixels.push(pixels(&s));
                self.whole.push(!cut[i]);
                self.doubt.push(0);
                self.latest.push(None);
                self.tracks.push(SegmentPercept { id: self.next_id, ..s });
                self.last_seen.push(t);
                self.next_id += 1;
            }
        }
        // Merge pieces of one object (keep the older id) and forget stale tracks.
        let carried = carried_ids;
        let mut keep = vec![true; self.tracks.len()];
        for a in 0..self.tracks.len() {
            for b in a + 1..self.tracks.len() {
                // What a hand carries is never a piece of something else (it may be put down
                // right beside another object).
                let carried_pair = carried.contains(&self.tracks[a].id) || carried.contains(&self.tracks[b].id);
                if keep[a]
                    && keep[b]
                    && !carried_pair
                    && dist(&self.tracks[a].centroid, &self.tracks[b].centroid) < MERGE_GAP
                {
                    let (old, new) = if self.tracks[a].id < self.tracks[b].id {
                        (a, b)
                    } else {
                        (b, a)
                    };
                    if self.tracks[new].seen && !self.tracks[old].seen {
                        let id = self.tracks[old].id;
                        self.tracks[old] = SegmentPercept {
                            id,
                            ..self.tracks[new].clone()
                        };
                        self.last_seen[old] = self.last_seen[new];
                        self.whole_pixels[old] = self.whole_pixels[new];
                        self.whole[old] = self.whole[new];
                        self.doubt[old] = self.doubt[new];
                        self.latest[old] = self.latest[new].take();
                    }
                    tracing::trace!(
                        "MERGE t={t:.2} track {} into {}",
                        self.tracks[new].id,
                        self.tracks[old].id
                    );
                    keep[new] = false;
                } else if keep[a]
                    && keep[b]
                    && !carried_pair
                    && self.whole[a] != self.whole[b]
                    && dist(&self.tracks[a].centroid, &self.tracks[b].centroid) < CUT_GATE
                {
                    // A track only ever seen cut, beside one seen whole: the same object.
                    let drop = if self.whole[a] { b } else { a };
                    tracing::trace!("MERGE t={t:.2} cut track {} into a whole one", self.tracks[drop].id);
                    keep[drop] = false;
                }
            }
        }
        for (j, k) in keep.iter_mut().enumerate() {
            // Object permanence: a track an arm may be hiding is kept, and so is one the cameras
            // cannot see now (outside either image, or behind the robot's own body): only a track
            // that should be seen and is not is forgotten.
            let hidden = near_palm.get(j).copied().unwrap_or(false) || !in_view(cams, masks, &self.tracks[j].centroid);
            if hidden && !self.tracks[j].seen {
                // Time out of view does not count against it.
                self.last_seen[j] += t - self.last_t.unwrap_or(t);
            }
            if t - self.last_seen[j] > FORGET_SECS && !carried.contains(&self.tracks[j].id) && !hidden {
                tracing::trace!(
                    "FORGET t={t:.2} track {} at {:?}",
                    self.tracks[j].id,
                    self.tracks[j].centroid
                );
                *k = false;
            }
        }
        retain_mask(&mut self.tracks, &keep);
        retain_mask(&mut self.last_seen, &keep);
        self.last_t = Some(t);
        retain_mask(&mut self.whole_pixels, &keep);
        retain_mask(&mut self.whole, &keep);
        retain_mask(&mut self.doubt, &keep);
        retain_mask(&mut self.latest, &keep);
    }
}

/// A blob one head camera saw and the other did not match (`camera`: 0 left, 1 right): its image
/// centroid (px) and its main colour term.
#[derive(Debug, Clone, Copy)]
struct MonoView {
    camera: usize,
    centroid: [f64; 2],
    term: Option<u8>,
}

/// How far (px, at the head cameras' 160 × 120) a one-camera blob may lie from a track's projection
/// to count as a view of it: about 5 cm at the table's range.
const MONO_GATE_PX: f64 = 10.0;

/// How far (px) inside the image border a track must project to count as in view.
const IN_VIEW_MARGIN_PX: f64 = 4.0;

/// Whether `p` is in view of both cameras: in front of them, at least [`IN_VIEW_MARGIN_PX`] inside
/// each image, and not behind the robot's own body (`masks`, the self-masks; empty = none).
fn in_view(cams: [&crate::vision::Camera; 2], masks: [&[bool]; 2], p: &[f64; 3]) -> bool {
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
fn project(cam: &crate::vision::Camera, p: &Vec3) -> Option<(f64, f64)> {
    let q = cam.world_from_optical.inverse_transform_point(&(*p).into());
    (q.z > 1e-6).then(|| (cam.fx * q.x / q.z + cam.cx, cam.fy * q.y / q.z + cam.cy))
}

/// The colour term with the largest share.
fn dominant_term(colors: &[(u8, f64)]) -> Option<u8> {
    colors.iter().max_by(|a, b| a.1.total_cmp(&b.1)).map(|c| c.0)
}

/// Keeps the elements of `v` whose entry in `keep` is true (the tracker's per-track vectors).
fn retain_mask<T>(v: &mut Vec<T>, keep: &[bool]) {
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
fn moved_clear(track: &SegmentPercept, blob: &SegmentPercept, share: f64) -> bool {
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
fn moved_in_images(
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
fn image_doubt(
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
fn projected_boxes(
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
fn box_corners() -> impl Iterator<Item = (f64, f64, f64)> {
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
const MOVED_PX: f64 = 3.0;

/// Horizontal distance (m) from `p` to the footprint `e` (0 inside).
fn footprint_distance(e: &schema::SeenExtent, p: [f64; 2]) -> f64 {
    let d = [p[0] - e.center[0], p[1] - e.center[1]];
    let [ax, ay] = e.major_axis;
    let u = (d[0] * ax + d[1] * ay).abs() - e.half_major;
    let v = (-d[0] * ay + d[1] * ax).abs() - e.half_minor;
    u.max(0.0).hypot(v.max(0.0))
}

/// Distance from `p` to the line of sight from `eye` to `target` (the segment between them).
fn sight_distance(eye: &[f64; 3], target: &[f64; 3], p: &[f64; 3]) -> f64 {
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
fn pixels(s: &SegmentPercept) -> f64 {
    f64::from(s.pixels[0]) + f64::from(s.pixels[1])
}

fn dist(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    (0..3).map(|i| (a[i] - b[i]).powi(2)).sum::<f64>().sqrt()
}

/// Builds percepts from the robot's sensors at the observation rate.
#[derive(Debug)]
pub struct Watcher {
    eyes: Eyes,
    body: Body,
    head: SearchTrack,
    tracker: Tracker,
    places: Vec<PlacePercept>,
    table_z: f64,
    last: Option<(f64, [[f64; 3]; 2])>,
    tips: Vec<ForceTorque>,
    flex: [[usize; 3]; 2],
    /// Where the head looked last.
    pub gaze_point: Option<Vec3>,
}

impl Watcher {
    /// A watcher on `hw`, told its `places` and the table height `table_z`, seeing with the
    /// backgrounds of `calibration`.
    pub fn new(
        hw: &dyn Hardware,
        places: Vec<PlacePercept>,
        table_z: f64,
        calibration: std::sync::Arc<crate::calibration::Calibration>,
    ) -> Result<Watcher, RobotError> {
        let dof = |arm: Arm, f: u8| hw.dof_index(&format!("{}/bhand/finger_{f}/med_joint", arm.prefix()));
        Ok(Watcher {
            eyes: Eyes::new(hw, table_z, calibration)?,
            body: Body::new(),
            head: SearchTrack::new(hw)?,
            tracker: Tracker::default(),
            places,
            table_z,
            last: None,
            tips: vec![ForceTorque::default(); hw.force_torque_frames().len()],
            flex: [
                [dof(Arm::Left, 1)?, dof(Arm::Left, 2)?, dof(Arm::Left, 3)?],
                [dof(Arm::Right, 1)?, dof(Arm::Right, 2)?, dof(Arm::Right, 3)?],
            ],
            gaze_point: None,
        })
    }

    /// The eyes (for logging images).
    pub fn eyes(&self) -> &Eyes {
        &self.eyes
    }

    /// The eyes, mutable (a skill that looks itself).
    pub fn eyes_mut(&mut self) -> &mut Eyes {
        &mut self.eyes
    }

    /// The table height the robot was told.
    pub fn table_z(&self) -> f64 {
        self.table_z
    }

    /// Moves track `id` to where its latest view puts it (keeping what it looked like whole), even
    /// a view cut by the robot's body that the tracker kept apart from what it saw whole — from
    /// the view's one uncut camera at the track's height, or its stereo centroid if that lies at
    /// the track's height ([`MOVED_DZ`]). For the robot's own decision after it looked again, hand
    /// out of the way, at a [doubted](Self::doubted) track. Whether it moved the track.
    pub fn accept_view(&mut self, id: u32) -> bool {
        let t = &mut self.tracker;
        let Some(j) = t.tracks.iter().position(|tr| tr.id == id) else {
            return false;
        };
        let track = &mut t.tracks[j];
        match t.latest[j].take() {
            Some(c) if (c[2] - track.centroid[2]).abs() < MOVED_DZ => {
                let (dx, dy) = (c[0] - track.centroid[0], c[1] - track.centroid[1]);
                tracing::trace!("ACCEPT track {id}: moved by ({dx:.3}, {dy:.3})");
                track.centroid[0] += dx;
                track.centroid[1] += dy;
                if let Some(e) = track.extent.as_mut() {
                    e.center = [e.center[0] + dx, e.center[1] + dy];
                }
                t.doubt[j] = 0;
                true
            }
            _ => false,
        }
    }

    /// Whether the last [`DOUBT_FRAMES`] views of track `id` were partial views at its height
    /// but outside its footprint: it may have moved while an arm hid part of it (a push as the
    /// hand arrived). Only a look with the arm out of the way tells.
    pub fn doubted(&self, id: u32) -> bool {
        let t = &self.tracker;
        t.tracks
            .iter()
            .zip(&t.doubt)
            .any(|(tr, &d)| tr.id == id && d >= DOUBT_FRAMES)
    }

    /// Whether track `id` was ever seen whole — in both cameras, cut by neither the image border
    /// nor the robot's body. A track born of a cut view has a centroid biased towards its visible
    /// part (the border-cut edge of an object can put it 8 cm off and its top 10 cm too high).
    pub fn seen_whole(&self, id: u32) -> bool {
        let t = &self.tracker;
        t.tracks.iter().zip(&t.whole).any(|(tr, &w)| tr.id == id && w)
    }

    /// The places the robot was told.
    pub fn places(&self) -> &[PlacePercept] {
        &self.places
    }

    /// Points the head at `target` (where the teacher's hand is working).
    pub fn look_at(&mut self, hw: &mut dyn Hardware, target: &Vec3) -> Result<(), RobotError> {
        self.gaze_point = Some(*target);
        self.head.look_at(hw, &mut self.body, target)
    }

    /// Whether the head can look at `target` with pan and tilt `margin` (rad) inside their limits
    /// ([`SearchTrack::can_look_at`]).
    pub fn can_look_at(&mut self, hw: &dyn Hardware, target: &Vec3, margin: f64) -> Result<bool, RobotError> {
        self.head.can_look_at(hw, &mut self.body, target, margin)
    }

    /// One percept at time `t` (s since the start of the run): captures the head's stereo pair,
    /// segments it, updates the tracks.
    pub fn percept(&mut self, hw: &mut dyn Hardware, t: f64) -> Result<Percept, RobotError> {
        // Hands, from the encoders.
        let mut palms = [[0.0; 3]; 2];
        let mut elbows = [Vec3::zeros(); 2];
        for arm in Arm::BOTH {
            let p = self
                .body
                .pose(hw, &format!("{}/bhand/palm_surface_link", arm.prefix()))?
                .translation
                .vector;
            palms[arm.index()] = [p.x, p.y, p.z];
            elbows[arm.index()] = self
                .body
                .pose(hw, &format!("{}/forearm_link", arm.prefix()))?
                .translation
                .vector;
        }
        self.tips.resize(hw.force_torque_frames().len(), ForceTorque::default());
        hw.read_force_torque(&mut self.tips);
        if self.tips.len() < 6 {
            return Err(RobotError::invalid(
                "<hardware>",
                "force_torque_frames",
                format!(
                    "Dexter has six fingertip sensors; the hardware reports {}",
                    self.tips.len()
                ),
            ));
        }
        let q = hw.joint_positions();
        let mut hands = Vec::with_capacity(2);
        for (k, arm) in Arm::BOTH.into_iter().enumerate() {
            let speed = match self.last {
                Some((t0, prev)) if t > t0 => dist(&palms[k], &prev[k]) / (t - t0),
                _ => 0.0,
            };
            let tips = &self.tips[3 * k..3 * k + 3];
            let finger_force = std::array::from_fn(|f| {
                let v = tips[f].force;
                (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
            });
            let load = -tips.iter().map(|w| w.force[2]).sum::<f64>();
            let flexion = self.flex[k].iter().map(|&i| q[i]).sum::<f64>() / 3.0;
            hands.push(HandPercept {
                arm: arm.prefix().to_string(),
                palm: palms[k],
                palm_speed: speed,
                flexion,
                finger_force,
                load,
            });
        }
        self.last = Some((t, palms));
        // A hand holds something when two fingers are loaded and the hand is closed.
        let holding: [bool; 2] = std::array::from_fn(|k| {
            let h = &hands[k];
            h.flexion > 0.8 && h.finger_force.iter().filter(|&&f| f > 0.25).count() >= 2
        });
        self.tracker.predict(&palms, holding);
        // Vision.
        let cams = self.eyes.cameras(hw, Pair::Head)?;
        let table_z = self.table_z;
        let blobs = self.eyes.perceive(hw, Pair::Head)?;
        let mut seen = Vec::new();
        let mut cut = Vec::new();
        let mut boxes = Vec::new();
        let mut views = Vec::new();
        let mut mono = Vec::new();
        let mut gaze_candidates = Vec::new();
        for b in blobs {
            tracing::trace!(
                "BLOB t={t:.2} centroid {:?} left {:?} right {:?}",
                b.centroid.map(|c| [c.x, c.y, c.z]),
                b.left.map(|s| (s.features.pixel_count, s.features.centroid)),
                b.right.map(|s| (s.features.pixel_count, s.features.centroid))
            );
            // A stereo pair whose centroid lies below the table top matched two different things
            // (or one whole and one cut view): only its single views count.
            let centroid = b.centroid.filter(|c| c.z > table_z - BELOW_TABLE);
            let (Some(c), Some(l), Some(r)) = (centroid, b.left, b.right) else {
                if centroid.is_none()
                    && let (Some(l), Some(r)) = (b.left, b.right)
                {
                    for (camera, s) in [(0, l), (1, r)] {
                        mono.push(MonoView {
                            camera,
                            centroid: s.features.centroid,
                            term: dominant_term(&crate::vision::color::kept_color_terms(&s.features.color_terms)),
                        });
                    }
                    continue;
                }
                let one = match (b.left, b.right) {
                    (Some(l), None) => Some((0, l)),
                    (None, Some(r)) => Some((1, r)),
                    _ => None,
                };
                if let Some((camera, s)) = one {
                    mono.push(MonoView {
                        camera,
                        centroid: s.features.centroid,
                        term: dominant_term(&crate::vision::color::kept_color_terms(&s.features.color_terms)),
                    });
                }
                continue;
            };
            let mut histogram: Vec<(u8, f64)> = Vec::new();
            let h = &l.features.histogram;
            let kept: Vec<usize> = h.kept_bins().collect();
            let total: f64 = kept.iter().map(|&i| h.counts[i] as f64).sum();
            if total > 0.0 {
                for i in kept {
                    histogram.push((i as u8, h.counts[i] as f64 / total));
                }
            }
            let cov = b.mean_covariance();
            let seg = SegmentPercept {
                id: 0,
                centroid: [c.x, c.y, c.z],
                seen: true,
                pixels: [l.features.pixel_count as u32, r.features.pixel_count as u32],
                histogram,
                covariance: [cov[0][0], cov[0][1], cov[1][0], cov[1][1]],
                colors: crate::vision::color::kept_color_terms(&l.features.color_terms),
                extent: crate::skills::extent_of(b, &cams, table_z),
            };
            // Foveated: the segment's image centroid near the principal point in both cameras.
            let off = |s: &crate::vision::Segment, cam: &crate::vision::Camera| {
                let u = (s.features.centroid[0] - cam.cx) / cam.width as f64;
                let v = (s.features.centroid[1] - cam.cy) / cam.height as f64;
                (u * u + v * v).sqrt()
            };
            let o = off(&l, &cams.left).max(off(&r, &cams.right));
            gaze_candidates.push((o, seg.centroid));
            views.push([l.features.centroid, r.features.centroid]);
            cut.push(l.cut_off() || r.cut_off());
            // The box of a view cut by the border or the body says less than a whole one: with
            // one whole view, only its box explains other tracks.
            const NO_BOX: [u32; 4] = [1, 0, 0, 0];
            boxes.push(match (l.cut_off(), r.cut_off()) {
                (true, false) => [NO_BOX, r.bbox],
                (false, true) => [l.bbox, NO_BOX],
                _ => [l.bbox, r.bbox],
            });
            seen.push(seg);
        }
        let mut occluders: Vec<([f64; 3], f64)> = Vec::with_capacity(10);
        for (palm, e) in palms.iter().zip(&elbows) {
            occluders.push((*palm, OCCLUSION_RADIUS));
            for i in 0..4 {
                let s = f64::from(i) / 4.0;
                occluders.push((std::array::from_fn(|j| e[j] + s * (palm[j] - e[j])), FOREARM_RADIUS));
            }
        }
        let masks = self.eyes.self_masks(Pair::Head);
        self.tracker.update(
            seen,
            &cut,
            &views,
            &boxes,
            &mono,
            [&cams.left, &cams.right],
            [masks.0, masks.1],
            t,
            &occluders,
        );
        let gaze = gaze_candidates
            .iter()
            .filter(|(o, _)| *o < 0.12)
            .min_by(|a, b| a.0.total_cmp(&b.0))
            .and_then(|(_, c)| self.tracker.tracks.iter().find(|t| t.seen && t.centroid == *c))
            .map(|t| t.id);
        Ok(Percept {
            t,
            hands,
            segments: self.tracker.tracks.clone(),
            places: self.places.clone(),
            table_z: self.table_z,
            gaze,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::vision::Camera;
    use control_basis::math::Iso3;
    use nalgebra::Point3;

    /// A head camera (160 × 120, the head's focal length) at `eye`, looking at the table.
    fn camera(eye: [f64; 3]) -> Camera {
        let world_from_optical = Iso3::face_towards(
            &Point3::from(eye),
            &Point3::new(0.6, 0.0, 0.75),
            &Vec3::new(0.0, 0.0, -1.0),
        );
        Camera {
            world_from_optical,
            width: 160,
            height: 120,
            fx: 160.0,
            fy: 160.0,
            cx: 80.0,
            cy: 60.0,
        }
    }

    /// A can of radius 2.4 cm, 4.7 cm high, seen standing at (0.6, 0) on a table at 0.75 m.
    fn track() -> SegmentPercept {
        SegmentPercept {
            id: 0,
            centroid: [0.6, 0.0, 0.7735],
            seen: true,
            pixels: [80, 80],
            histogram: Vec::new(),
            covariance: [0.0; 4],
            colors: Vec::new(),
            extent: Some(schema::SeenExtent {
                height: 0.047,
                center: [0.6, 0.0],
                major_axis: [1.0, 0.0],
                half_major: 0.024,
                half_minor: 0.024,
                model: "round".into(),
            }),
        }
    }

    fn views(cams: [&Camera; 2], p: Vec3) -> [[f64; 2]; 2] {
        cams.map(|c| {
            let (u, v) = project(c, &p).expect("in front of the camera");
            [u, v]
        })
    }

    /// The bounding box (px) of a 20 × 16 px silhouette centred on `p`'s projection in each camera.
    fn boxes_around(cams: [&Camera; 2], p: Vec3) -> [[u32; 4]; 2] {
        views(cams, p).map(|[u, v]| [(u - 10.0) as u32, (v - 8.0) as u32, (u + 10.0) as u32, (v + 8.0) as u32])
    }

    #[test]
    fn a_cut_view_far_from_a_whole_track_is_that_object_when_its_image_holds_it() {
        let (l, r) = (camera([0.05, 0.03, 1.45]), camera([0.05, -0.03, 1.45]));
        let cams = [&l, &r];
        let no_mask: [&[bool]; 2] = [&[], &[]];
        let mut tracker = Tracker::default();
        let whole = track();
        let at = Vec3::from(whole.centroid);
        tracker.update(
            vec![whole.clone()],
            &[false],
            &[views(cams, at)],
            &[boxes_around(cams, at)],
            &[],
            cams,
            no_mask,
            0.0,
            &[],
        );
        assert_eq!(tracker.tracks.len(), 1);
        // The arm hides most of it in one camera: the pair triangulates 14 cm off, above the table.
        let cut = SegmentPercept {
            centroid: [0.52, 0.05, 0.88],
            pixels: [20, 80],
            ..whole.clone()
        };
        tracker.update(
            vec![cut.clone()],
            &[true],
            &[views(cams, at)],
            &[boxes_around(cams, at)],
            &[],
            cams,
            no_mask,
            0.1,
            &[],
        );
        assert_eq!(
            tracker.tracks.len(),
            1,
            "a cut view of a tracked object starts no track"
        );
        assert_eq!(tracker.tracks[0].centroid, whole.centroid, "nor moves the whole view");
        assert!(tracker.tracks[0].seen);
        // A whole view that far is another object.
        let other = Vec3::new(0.52, 0.05, 0.7735);
        let far = SegmentPercept {
            centroid: [0.52, 0.05, 0.7735],
            ..whole.clone()
        };
        tracker.update(
            vec![far],
            &[false],
            &[views(cams, other)],
            &[boxes_around(cams, other)],
            &[],
            cams,
            no_mask,
            0.2,
            &[],
        );
        assert_eq!(tracker.tracks.len(), 2);
    }

    #[test]
    fn a_partial_view_outside_the_tracks_box_in_both_images_casts_doubt_and_its_uncut_camera_relocates_it() {
        let (l, r) = (camera([0.05, 0.03, 1.45]), camera([0.05, -0.03, 1.45]));
        let cams = [&l, &r];
        let no_mask: [&[bool]; 2] = [&[], &[]];
        let mut tracker = Tracker::default();
        let whole = track();
        let at = Vec3::from(whole.centroid);
        let update =
            |tracker: &mut Tracker, seg: &SegmentPercept, cut: bool, p: Vec3, t: f64, palm: &[([f64; 3], f64)]| {
                let mut b = boxes_around(cams, p);
                if cut {
                    b[1] = [1, 0, 0, 0];
                }
                tracker.update(
                    vec![seg.clone()],
                    &[cut],
                    &[views(cams, p)],
                    &[b],
                    &[],
                    cams,
                    no_mask,
                    t,
                    palm,
                );
            };
        update(&mut tracker, &whole, false, at, 0.0, &[]);
        // A hand over it (a palm 10 cm above) hides half of it: a partial view inside its box is
        // no doubt, however many frames.
        let palm = [([0.6, 0.0, 0.87], OCCLUSION_RADIUS)];
        let half = SegmentPercept {
            pixels: [40, 40],
            ..whole.clone()
        };
        for k in 1..=5 {
            update(
                &mut tracker,
                &half,
                false,
                at + Vec3::new(0.0, 0.01, 0.0),
                0.1 * f64::from(k),
                &palm,
            );
        }
        assert_eq!(tracker.doubt[0], 0, "a part of it where it stands");
        // Pushed 4 cm sideways under the hand: what is seen lies outside its box in both images.
        let moved = at + Vec3::new(0.0, 0.045, 0.0);
        let pushed = SegmentPercept {
            centroid: [moved.x, moved.y, moved.z + 0.04],
            pixels: [40, 40],
            ..whole.clone()
        };
        for k in 6..=7 {
            update(&mut tracker, &pushed, false, moved, 0.1 * f64::from(k), &palm);
        }
        assert!(tracker.doubt[0] < DOUBT_FRAMES, "two frames are not yet a doubt");
        update(&mut tracker, &pushed, false, moved, 0.8, &palm);
        assert!(tracker.doubt[0] >= DOUBT_FRAMES);
        assert_eq!(
            tracker.tracks[0].centroid, whole.centroid,
            "the track keeps what it saw whole"
        );
        // The hand gone, the right view cut by the robot's body: its stereo centroid is 4 cm high,
        // the uncut left view at the track's height is where it is.
        update(&mut tracker, &pushed, true, moved, 0.9, &[]);
        let c = tracker.latest[0].expect("a view this frame");
        assert!(
            (c[1] - moved.y).abs() < 0.005 && (c[2] - whole.centroid[2]).abs() < 1e-9,
            "{c:?}"
        );
    }

    #[test]
    fn a_track_out_of_view_is_kept_and_one_in_view_unseen_is_forgotten() {
        let (l, r) = (camera([0.05, 0.03, 1.45]), camera([0.05, -0.03, 1.45]));
        let cams = [&l, &r];
        let no_mask: [&[bool]; 2] = [&[], &[]];
        let mut tracker = Tracker::default();
        // One object in view, one behind the cameras' field (far to the side).
        let seen = track();
        let aside = SegmentPercept {
            centroid: [0.6, 1.5, 0.7735],
            ..track()
        };
        let segs = vec![seen.clone(), aside.clone()];
        let v = [views(cams, Vec3::from(seen.centroid)), [[0.0; 2]; 2]];
        let b = [boxes_around(cams, Vec3::from(seen.centroid)), [[0; 4]; 2]];
        tracker.update(segs, &[false, false], &v, &b, &[], cams, no_mask, 0.0, &[]);
        assert_eq!(tracker.tracks.len(), 2);
        // Nothing seen for 5 s: the one in view goes after 1 s, the one out of view stays.
        for k in 1..=50 {
            tracker.update(Vec::new(), &[], &[], &[], &[], cams, no_mask, 0.1 * f64::from(k), &[]);
        }
        assert_eq!(tracker.tracks.len(), 1);
        assert_eq!(tracker.tracks[0].centroid, aside.centroid);
        // Behind the robot's body (its self-mask over the whole image) a track is out of view too.
        let mask = vec![true; 160 * 120];
        let mut tracker = Tracker::default();
        tracker.update(
            vec![seen.clone()],
            &[false],
            &v[..1],
            &b[..1],
            &[],
            cams,
            no_mask,
            0.0,
            &[],
        );
        for k in 1..=50 {
            tracker.update(
                Vec::new(),
                &[],
                &[],
                &[],
                &[],
                cams,
                [&mask, &mask],
                0.1 * f64::from(k),
                &[],
            );
        }
        assert_eq!(tracker.tracks.len(), 1);
    }

    #[test]
    fn a_view_outside_the_tracks_silhouette_in_both_images_is_a_move() {
        let (l, r) = (camera([0.05, 0.03, 1.45]), camera([0.05, -0.03, 1.45]));
        let cams = [&l, &r];
        let t = track();
        // Its stereo centroid is 5 cm too high (the 3-D test rejects it); its image centroids are
        // those of the can pushed 7 cm away.
        let blob = SegmentPercept {
            centroid: [0.61, 0.05, 0.8235],
            pixels: [70, 66],
            ..t.clone()
        };
        assert!(!moved_clear(&t, &blob, 0.85));
        let pushed = views(cams, Vec3::new(0.635, 0.06, 0.7735));
        assert!(moved_in_images(&t, &blob, pushed, cams, 0.85));
        // A part of the can where it stands (the hand hides the rest): not a move.
        let part = views(cams, Vec3::new(0.61, 0.015, 0.785));
        assert!(!moved_in_images(&t, &blob, part, cams, 0.6));
        // Too little of it seen, or unlike in the two cameras: not trusted.
        assert!(!moved_in_images(&t, &blob, pushed, cams, 0.4));
        let lopsided = SegmentPercept {
            pixels: [80, 40],
            ..blob.clone()
        };
        assert!(!moved_in_images(&t, &lopsided, pushed, cams, 0.85));
    }
}
