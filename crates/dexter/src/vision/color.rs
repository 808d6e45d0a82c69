//! Colour conversions, the 64-bin HSV colour histogram of §5.1.2.1 and the colour terms
//! ([`schema::percept::COLOR_TERMS`]) the procedural model counts.

use control_basis::math::Vec3;

/// Number of colours L in the discrete colour feature (§5.1.2.1: "one of L=64 colors").
pub const HISTOGRAM_BINS: usize = 64;

/// Bins per HSV axis: 4 × 4 × 4 = 64, the uniform partition of HSV space.
pub const BINS_PER_AXIS: usize = 4;

/// HSV (`[h_deg, s, v]`, h in [0, 360), s and v in [0, 1]) to RGB in [0, 1].
pub fn hsv_to_rgb(hsv: [f64; 3]) -> [f64; 3] {
    let h = hsv[0].rem_euclid(360.0) / 60.0;
    let s = hsv[1].clamp(0.0, 1.0);
    let v = hsv[2].clamp(0.0, 1.0);
    let c = v * s;
    let x = c * (1.0 - ((h % 2.0) - 1.0).abs());
    let m = v - c;
    let (r, g, b) = match h as u32 {
        0 => (c, x, 0.0),
        1 => (x, c, 0.0),
        2 => (0.0, c, x),
        3 => (0.0, x, c),
        4 => (x, 0.0, c),
        _ => (c, 0.0, x),
    };
    [r + m, g + m, b + m]
}

/// RGB in [0, 1] to HSV (`[h_deg, s, v]`); grey has hue 0.
pub fn rgb_to_hsv(rgb: [f64; 3]) -> [f64; 3] {
    let [r, g, b] = rgb;
    let max = r.max(g).max(b);
    let min = r.min(g).min(b);
    let d = max - min;
    let h = if d <= 0.0 {
        0.0
    } else if max == r {
        60.0 * ((g - b) / d).rem_euclid(6.0)
    } else if max == g {
        60.0 * ((b - r) / d + 2.0)
    } else {
        60.0 * ((r - g) / d + 4.0)
    };
    let s = if max > 0.0 { d / max } else { 0.0 };
    [h.rem_euclid(360.0), s, max]
}

/// The histogram bin (0..64) of an HSV colour: `16·h_bin + 4·s_bin + v_bin`, each axis cut into 4
/// equal intervals (hue [0°, 90°), [90°, 180°), …; s and v [0, 0.25), …, [0.75, 1]).
#[inline]
pub fn hsv_bin(hsv: [f64; 3]) -> usize {
    let n = BINS_PER_AXIS as f64;
    let q = |x: f64| ((x * n) as usize).min(BINS_PER_AXIS - 1);
    let h = q(hsv[0].rem_euclid(360.0) / 360.0);
    let s = q(hsv[1].clamp(0.0, 1.0));
    let v = q(hsv[2].clamp(0.0, 1.0));
    (h * BINS_PER_AXIS + s) * BINS_PER_AXIS + v
}

/// The histogram bin of an 8-bit RGB pixel (exact conversion to HSV, then [`hsv_bin`]).
#[inline]
pub fn rgb8_bin(rgb: [u8; 3]) -> usize {
    hsv_bin(rgb_to_hsv([
        rgb[0] as f64 / 255.0,
        rgb[1] as f64 / 255.0,
        rgb[2] as f64 / 255.0,
    ]))
}

/// The centre of a histogram bin as HSV (for drawing histograms).
pub fn bin_center_hsv(bin: usize) -> [f64; 3] {
    let n = BINS_PER_AXIS;
    let (h, s, v) = ((bin / (n * n)) % n, (bin / n) % n, bin % n);
    let c = |i: usize| (i as f64 + 0.5) / n as f64;
    [360.0 * c(h), c(s), c(v)]
}

/// Counts of the 64 HSV colours over a segment's pixels (§5.1.2.1).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ColorHistogram {
    /// Pixel count per bin, indexed by [`hsv_bin`].
    pub counts: [u32; HISTOGRAM_BINS],
}

impl Default for ColorHistogram {
    fn default() -> Self {
        Self {
            counts: [0; HISTOGRAM_BINS],
        }
    }
}

impl ColorHistogram {
    /// Total number of pixels counted.
    pub fn total(&self) -> u64 {
        self.counts.iter().map(|&c| c as u64).sum()
    }

    /// The raw histogram normalised to sum 1 (all zeros if empty).
    pub fn normalized(&self) -> [f64; HISTOGRAM_BINS] {
        let t = self.total();
        let mut out = [0.0; HISTOGRAM_BINS];
        if t > 0 {
            for (o, &c) in out.iter_mut().zip(&self.counts) {
                *o = c as f64 / t as f64;
            }
        }
        out
    }

    /// Histogram intersection Σ_l min(p_l, q_l) of the two normalised histograms, in [0, 1]
    /// (1 = same colour distribution; Swain & Ballard 1991).
    pub fn intersection(&self, other: &Self) -> f64 {
        let (a, b) = (self.normalized(), other.normalized());
        a.iter().zip(&b).map(|(x, y)| x.min(*y)).sum()
    }

    /// The count threshold of the 20th-percentile rule: the 20th percentile (nearest rank,
    /// ⌈0.2·n⌉-th smallest) of the n non-zero bin counts; 0 if the histogram is empty.
    pub fn percentile20_threshold(&self) -> u32 {
        percentile20_threshold(&self.counts)
    }

    /// The colours kept by the 20th-percentile rule of §5.1.2.1, as a bit mask (bit l = colour l).
    ///
    /// The seed: "The histogram of colors is sorted in descending order, and the colors in the
    /// 20^th percentile and higher are included in the feature vector. The 20^th percentile boundary
    /// helps to reduce noise in the feature vector. Since the number of colors in the object segment
    /// varies for each object, the length of the feature vector õ_m may vary for each object m."
    ///
    /// Reading used here: among the colours that occur in the segment (non-zero bins), a colour is
    /// kept when its count is at or above the 20th percentile of those counts
    /// ([`Self::percentile20_threshold`]), so roughly the rarest fifth of the colours present is
    /// dropped as noise. The kept colours are the multinomial observations õ_i of (5.16)–(5.18).
    pub fn kept_mask(&self) -> u64 {
        let t = self.percentile20_threshold();
        if t == 0 {
            return 0;
        }
        self.counts
            .iter()
            .enumerate()
            .filter(|&(_, &c)| c >= t)
            .fold(0u64, |m, (i, _)| m | (1u64 << i))
    }

    /// The kept colours (bin indices, ascending) — the variable-length feature vector õ_m of §5.1.2.1.
    pub fn kept_bins(&self) -> impl Iterator<Item = usize> + use<> {
        let mask = self.kept_mask();
        (0..HISTOGRAM_BINS).filter(move |&i| mask & (1u64 << i) != 0)
    }

    /// The kept colours sorted by descending count (ties by bin index), as the seed describes them.
    pub fn kept_bins_by_count(&self) -> Vec<usize> {
        let mut v: Vec<usize> = self.kept_bins().collect();
        v.sort_by(|&a, &b| self.counts[b].cmp(&self.counts[a]).then(a.cmp(&b)));
        v
    }
}

/// Hue boundaries (degrees) between the chromatic terms, half-way between their focal hues (red
/// 0°, orange 30°, yellow 55°, green 120°, blue 220°, purple 275°, pink 330°).
const HUE_BOUNDS: [(f64, u8); 7] = [
    (15.0, 3),
    (42.0, 4),
    (85.0, 5),
    (170.0, 6),
    (248.0, 7),
    (302.0, 8),
    (345.0, 9),
];

/// Below this HSV saturation a colour of red hue is named pink, however bright.
///
/// Pink is not a hue but the light, desaturated region of red: the ISCC–NBS colour names give the
/// pinks the reds of high Munsell value and low-to-moderate chroma, and Berlin & Kay's pink focal
/// is a pale red. HSV saturation is the cue that diffuse shading leaves alone (it scales R, G and B
/// together), so the boundary is a saturation; 0.70 is half-way between the pink (s = 0.55) and the
/// red (s = 0.85) of the built-in catalog (`assets/objects/household.toml`, the tuning catalog).
/// With the hue alone, a pale pink at 350° counted as red: pink objects scored as red ones. There
/// is no bound on the value: the side of a pink object in shade is as pink as its lit top (with
/// pixels below value ½ named red, a pink bottle read 10–35 % red). Removing that bound lifted
/// relevance (red + blue, generated development catalogs 201–205, three examples) 0.944 → 0.947
/// and eight-colour sorting at one example 0.821 → 0.827.
pub const PINK_MAX_SATURATION: f64 = 0.70;

/// The least chroma (max − min of R, G, B in [0, 1], = s·v) that a dark colour (v < ¼) needs to keep
/// its hue's name instead of black: 8 × the head cameras' default pixel noise σ = 0.01, so noise alone
/// (whose range over three channels stays below 5σ in 99.9 % of pixels) never names a hue. Navy is
/// blue and maroon red to a person: darkness alone does not make a colour black, the lack of chroma
/// does (a shaded side of a saturated object keeps its chroma ratio s, and only its value drops).
pub const DARK_MIN_CHROMA: f64 = 0.08;

/// The colour term (index into [`schema::percept::COLOR_TERMS`]) of an HSV colour (`[h_deg, s, v]`, s and v in
/// [0, 1]): black when v < ¼ and its chroma s·v < [`DARK_MIN_CHROMA`], grey or white when s < ¼ (by
/// v < ¾), otherwise the hue's term — except that a red hue at saturation < [`PINK_MAX_SATURATION`]
/// is pink.
///
/// **Why terms, not the 64 histogram bins.** The seed's uniform 4 × 4 × 4 HSV partition
/// (§5.1.2.1) cuts hue into 90° cells starting at 0°: red and orange (and yellow) share one cell
/// and a red surface straddles two. The model of ch. 5 needs colour *categories* that shading
/// does not move an object between and that a teacher would name, so it counts pixels by the
/// hue regions people name (the histogram stays for stereo matching and display).
#[inline]
pub fn color_term(hsv: [f64; 3]) -> u8 {
    let (h, s, v) = (hsv[0].rem_euclid(360.0), hsv[1], hsv[2]);
    if v < 0.25 && s * v < DARK_MIN_CHROMA {
        0
    } else if s < 0.25 {
        if v < 0.75 { 1 } else { 2 }
    } else {
        let term = HUE_BOUNDS.iter().find(|b| h < b.0).map_or(3, |b| b.1);
        if term == 3 && s < PINK_MAX_SATURATION { 9 } else { term }
    }
}

/// The count threshold of the 20th-percentile rule of §5.1.2.1: the 20th percentile (nearest
/// rank, the ⌈0.2·n⌉-th smallest) of the n non-zero counts; 0 when every count is 0. No
/// allocation (a rank count per value, for the few dozen bins of a colour feature).
pub fn percentile20_threshold(counts: &[u32]) -> u32 {
    let n = counts.iter().filter(|&&c| c > 0).count();
    if n == 0 {
        return 0;
    }
    let rank = (0.2 * n as f64).ceil().max(1.0) as usize;
    counts
        .iter()
        .copied()
        .filter(|&c| {
            let below = counts.iter().filter(|&&o| o > 0 && o < c).count();
            let upto = counts.iter().filter(|&&o| o > 0 && o <= c).count();
            c > 0 && below < rank && rank <= upto
        })
        .min()
        .unwrap_or(0)
}

/// The kept colour terms of per-term pixel counts: the 20th-percentile rule of §5.1.2.1 (terms
/// whose count is below the ⌈0.2·n⌉-th smallest of the n non-zero counts are dropped), as
/// (term, share of the kept pixels), ascending by term.
pub fn kept_color_terms(counts: &[u32; 10]) -> Vec<(u8, f64)> {
    let threshold = percentile20_threshold(counts);
    if threshold == 0 {
        return Vec::new();
    }
    let kept: Vec<(u8, u32)> = counts
        .iter()
        .enumerate()
        .filter(|(_, c)| **c > 0 && **c >= threshold)
        .map(|(t, &c)| (t as u8, c))
        .collect();
    let total: f64 = kept.iter().map(|k| f64::from(k.1)).sum();
    kept.into_iter().map(|(t, c)| (t, f64::from(c) / total)).collect()
}

/// How far (m) outside a measured footprint the ray of a top-face pixel may meet the top's plane
/// ([`surface_color_terms`]): the footprint's own measurement error.
const TOP_FACE_SLACK: f64 = 0.005;

/// Bands along a round object's axis (its height for a sphere, its length for a thing lying on
/// its side) that [`surface_color_terms`] weighs equally.
const SURFACE_BANDS: usize = 6;

/// The fewest pixels of a band for its colours to count ([`surface_color_terms`]).
const MIN_BAND_PIXELS: u32 = 3;

/// How far (m) beyond the measured radius a pixel's ray may pass and still be taken as seeing the
/// round surface ([`surface_color_terms`]): the measurement's own error.
const ROUND_SLACK: f64 = 0.006;

/// The colour-term counts of a view `seg` of a measured object (in the camera `cam`, whose `image`
/// and `segmenter` made it), weighted by the surface each pixel stands for: a teacher names the
/// colour that covers most of an object's surface, and the head, looking down, sees its top out
/// of proportion (a peanut-butter jar with a blue lid and a red label looked blue; a white
/// sugar-cube box with a blue top, blue; a white ball with a blue cap, blue).
///
/// * **A flat top** (`prism`, `standing_whole`: the measured top on a table at `table_z`): each
///   pixel's ray meets the plane of the top inside the footprint — a top pixel — or not — a side
///   pixel; the top's pixels then carry the top's share of the surface, A_top / (A_top + A_sides) =
///   a·b / (a·b + (a + b)·h) for half extents a, b and height h (the same for a box and a
///   cylinder), and the sides' pixels the rest, each face's colours taken as the visible part shows
///   them.
/// * **Round** (`round`, a ball of the measured radius on the table; `lying`, a round
///   cross-section lying along the footprint's major axis): each pixel's ray meets the fitted
///   surface at a height on the ball (a position along the lying thing's axis); the axis is cut
///   into [`SURFACE_BANDS`] equal bands, each band's colours are taken as its visible pixels show
///   them, and the bands seen count equally — a ball's zones of equal height have equal area
///   (Archimedes), as do a cylinder's of equal length — so the cap the head looks down on counts
///   for its share of the surface, not of the image.
///
/// Of a view cut by the image border or the robot's body too: the shares come from the measured
/// extent, not from the pixels. `None` (keep the pixel counts) for other extents, a view that is
/// not the segmenter's own segment (split by colour, say), a flat top without pixels of both
/// faces, or a round view whose pixels mostly miss the fitted surface or that shows fewer than
/// two bands.
pub fn surface_color_terms(
    seg: &crate::vision::Segment,
    segmenter: &crate::vision::Segmenter,
    image: &crate::vision::Image,
    cam: &crate::vision::Camera,
    extent: &schema::SeenExtent,
    table_z: f64,
) -> Option<[u32; 10]> {
    let shape = match extent.model.as_str() {
        "prism" | "standing_whole" => Fitted::FlatTop,
        "round" => Fitted::Ball,
        "lying" => Fitted::Lying,
        _ => return None,
    };
    let label = segmenter.segments().iter().position(|s| s == seg)? as u32 + 1;
    let comp = segmenter.component_map();
    let w = image.width as usize;
    if comp.len() != image.pixel_count() {
        return None;
    }
    let (a, b, h) = (extent.half_major, extent.half_minor, extent.height);
    if !(a > 0.0 && b > 0.0 && h > 0.0) {
        return None;
    }
    let axis = [extent.major_axis[0], extent.major_axis[1]];
    let top_z = table_z + h;
    // A round fit: its radius, its axis — vertical through the ball's centre, or horizontal along
    // the footprint's major axis at the lying thing's mid-height — and the half length banded.
    let r = 0.5 * h + ROUND_SLACK;
    let e = match shape {
        Fitted::Ball => Vec3::new(0.0, 0.0, 1.0),
        _ => Vec3::new(axis[0], axis[1], 0.0),
    };
    let c = Vec3::new(extent.center[0], extent.center[1], table_z + 0.5 * h);
    let half = match shape {
        Fitted::Ball => 0.5 * h,
        _ => a,
    };
    // Flat top: [top, sides]; round: one row per band.
    let mut faces = [[0u32; 10]; SURFACE_BANDS];
    let (mut n, mut missed) = (0u32, 0u32);
    for v in seg.bbox[1]..=seg.bbox[3] {
        for u in seg.bbox[0]..=seg.bbox[2] {
            let i = v as usize * w + u as usize;
            if comp.get(i) != Some(&label) {
                continue;
            }
            n += 1;
            let (o, d) = cam.ray(f64::from(u), f64::from(v));
            let face = match shape {
                Fitted::FlatTop => {
                    let on_top = d.z < -1e-9 && {
                        let t = (top_z - o.z) / d.z;
                        let (x, y) = (o.x + t * d.x - extent.center[0], o.y + t * d.y - extent.center[1]);
                        let along = x * axis[0] + y * axis[1];
                        let across = -x * axis[1] + y * axis[0];
                        along.abs() <= a + TOP_FACE_SLACK && across.abs() <= b + TOP_FACE_SLACK
                    };
                    usize::from(!on_top)
                }
                Fitted::Ball | Fitted::Lying => {
                    let wv = o - c;
                    let (dp, wp) = (d - e * d.dot(&e), wv - e * wv.dot(&e));
                    let (qa, qb, qc) = match shape {
                        // A ball: the full distance to the centre.
                        Fitted::Ball => (1.0, wv.dot(&d), wv.dot(&wv) - r * r),
                        _ => (dp.dot(&dp), wp.dot(&dp), wp.dot(&wp) - r * r),
                    };
                    let disc = qb * qb - qa * qc;
                    if !(disc >= 0.0 && qa > 1e-12) {
                        missed += 1;
                        continue;
                    }
                    let t = (-qb - disc.sqrt()) / qa;
                    let along = (wv + d * t).dot(&e);
                    let x = ((along + half) / (2.0 * half)).clamp(0.0, 1.0 - 1e-9);
                    (x * SURFACE_BANDS as f64) as usize
                }
            };
            let rgb = image.px(i).map(|c| f64::from(c) / 255.0);
            faces[face][usize::from(color_term(rgb_to_hsv(rgb)))] += 1;
        }
    }
    let count = |f: &[u32; 10]| f.iter().sum::<u32>();
    let weights: Vec<(usize, f64)> = match shape {
        Fitted::FlatTop => {
            if count(&faces[0]) == 0 || count(&faces[1]) == 0 {
                return None;
            }
            let top_share = a * b / (a * b + (a + b) * h);
            vec![(0, top_share), (1, 1.0 - top_share)]
        }
        _ => {
            let seen: Vec<usize> = (0..SURFACE_BANDS)
                .filter(|&k| count(&faces[k]) >= MIN_BAND_PIXELS)
                .collect();
            if 2 * missed > n || seen.len() < 2 {
                return None;
            }
            let each = 1.0 / seen.len() as f64;
            seen.into_iter().map(|k| (k, each)).collect()
        }
    };
    let n = f64::from(n - missed);
    Some(std::array::from_fn(|t| {
        let share: f64 = weights
            .iter()
            .map(|&(k, wk)| wk * f64::from(faces[k][t]) / f64::from(count(&faces[k])))
            .sum();
        (share * n).round() as u32
    }))
}

/// The shape [`surface_color_terms`] fits to a measured extent.
#[derive(Clone, Copy)]
enum Fitted {
    /// A flat top over vertical sides.
    FlatTop,
    /// A ball resting on the table.
    Ball,
    /// A round cross-section lying along the footprint's major axis.
    Lying,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hsv_round_trip() {
        for &hsv in &[
            [0.0, 1.0, 1.0],
            [120.0, 0.5, 0.8],
            [240.0, 0.9, 0.3],
            [300.0, 0.2, 0.6],
            [45.0, 0.0, 0.5],
        ] {
            let back = rgb_to_hsv(hsv_to_rgb(hsv));
            let dh = if hsv[1] == 0.0 { 0.0 } else { (back[0] - hsv[0]).abs() };
            assert!(
                dh < 1e-9 && (back[1] - hsv[1]).abs() < 1e-12 && (back[2] - hsv[2]).abs() < 1e-12,
                "{hsv:?} {back:?}"
            );
        }
    }

    #[test]
    fn bins_partition_uniformly() {
        assert_eq!(hsv_bin([0.0, 0.0, 0.0]), 0);
        assert_eq!(hsv_bin([359.9, 1.0, 1.0]), 63);
        assert_eq!(hsv_bin([90.0, 0.25, 0.5]), 16 + 4 + 2);
        for b in 0..HISTOGRAM_BINS {
            assert_eq!(hsv_bin(bin_center_hsv(b)), b);
        }
    }

    #[test]
    fn percentile_rule_drops_rarest_fifth() {
        let mut h = ColorHistogram::default();
        // ten colours with counts 1..=10: the 20th percentile (2nd smallest) is 2, so 1 is dropped.
        for i in 0..10 {
            h.counts[i * 3] = i as u32 + 1;
        }
        assert_eq!(h.percentile20_threshold(), 2);
        assert_eq!(h.kept_bins().count(), 9);
        assert!(h.kept_mask() & 1 == 0);
        assert_eq!(h.kept_bins_by_count()[0], 27);
        assert_eq!(ColorHistogram::default().kept_mask(), 0);
        let mut one = ColorHistogram::default();
        one.counts[5] = 3;
        assert_eq!(one.kept_mask(), 1 << 5);
    }
}

#[cfg(test)]
mod term_tests {
    use super::*;
    use schema::percept::{COLOR_TERM_HSV, COLOR_TERMS};

    #[test]
    fn colour_terms_name_the_catalog_colours() {
        let name = |hsv| COLOR_TERMS[usize::from(color_term(hsv))];
        // Red wraps around 0°: both sides are red; orange and paprika are orange, not red (the
        // 4 × 4 × 4 histogram puts red, orange and yellow in one hue cell).
        assert_eq!(name([2.0, 0.85, 0.8]), "red");
        assert_eq!(name([358.0, 0.85, 0.8]), "red");
        assert_eq!(name([28.0, 0.9, 0.95]), "orange");
        assert_eq!(name([16.0, 0.88, 0.85]), "orange");
        assert_eq!(name([52.0, 0.85, 0.95]), "yellow");
        assert_eq!(name([95.0, 0.7, 0.85]), "green");
        assert_eq!(name([140.0, 0.75, 0.4]), "green");
        assert_eq!(name([200.0, 0.65, 0.92]), "blue");
        assert_eq!(name([220.0, 0.85, 0.75]), "blue");
        assert_eq!(name([275.0, 0.7, 0.7]), "purple");
        assert_eq!(name([335.0, 0.55, 0.92]), "pink");
        // Pink is a pale red: the same hue is red when saturated, pink when pale (at any red hue),
        // in light or in shade (diffuse shading lowers the value, not the saturation).
        assert_eq!(name([350.0, 0.85, 0.7]), "red");
        assert_eq!(name([350.0, 0.45, 0.9]), "pink");
        assert_eq!(name([5.0, 0.5, 0.85]), "pink");
        assert_eq!(name([5.0, 0.5, 0.4]), "pink");
        assert_eq!(name([350.0, 0.85, 0.4]), "red");
        // Dark: black without chroma, the hue's name with it (navy, maroon, a shaded side).
        assert_eq!(name([230.0, 0.55, 0.2]), "blue");
        assert_eq!(name([350.0, 0.85, 0.15]), "red");
        assert_eq!(name([230.0, 0.3, 0.15]), "black");
        assert_eq!(name([0.0, 1.0, 0.05]), "black");
        // Achromatic: value first, then saturation; hue is ignored.
        assert_eq!(name([220.0, 0.15, 0.10]), "black");
        assert_eq!(name([210.0, 0.06, 0.5]), "grey");
        assert_eq!(name([40.0, 0.04, 0.96]), "white");
        for (t, hsv) in COLOR_TERM_HSV.iter().enumerate() {
            assert_eq!(usize::from(color_term(*hsv)), t, "{}", COLOR_TERMS[t]);
        }
    }

    #[test]
    fn kept_terms_follow_the_20th_percentile_rule() {
        assert!(kept_color_terms(&[0; 10]).is_empty());
        // Five non-zero counts: the rule's threshold is the smallest (rank ⌈0.2·5⌉ = 1), so all
        // five are kept; with six, rank 2 drops the smallest.
        let five = kept_color_terms(&[1, 0, 10, 30, 0, 0, 0, 50, 0, 9]);
        assert_eq!(five.iter().map(|t| t.0).collect::<Vec<_>>(), [0, 2, 3, 7, 9]);
        let six = kept_color_terms(&[1, 2, 10, 30, 0, 0, 0, 50, 0, 9]);
        assert_eq!(six.iter().map(|t| t.0).collect::<Vec<_>>(), [1, 2, 3, 7, 9]);
        let total: f64 = six.iter().map(|t| t.1).sum();
        assert!((total - 1.0).abs() < 1e-12);
        assert!((six[3].1 - 50.0 / 101.0).abs() < 1e-12);
    }
}
