//! Colour conversions and the 64-bin HSV colour histogram of §5.1.2.1.

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
        schema::percept::percentile20_threshold(&self.counts)
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
