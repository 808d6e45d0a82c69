//! The input of the procedural model: an object's observed features (colour terms, histogram,
//! segment size) and its colour draws under the chromatic rule; one demonstration as an [`Example`].

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::error::SchemaError;
use crate::percept::{COLOR_TERMS, SegmentPercept};

/// Number of bins of the HSV histogram (4 hue × 4 saturation × 4 value bins, §5.1.2.1), which
/// the features carry for display and stereo matching.
pub const COLOR_BINS: usize = 64;
/// Number of colours L of the colour unit: the colour terms ([`COLOR_TERMS`]).
pub const COLORS: usize = COLOR_TERMS.len();
/// The achromatic colour terms (black, grey, white): indices below this.
const ACHROMATIC_TERMS: u8 = 3;

/// Largest measured dimension of an object (m): the size feature is for things a hand picks up.
pub const MAX_DIMENSION: f64 = 10.0;

/// Where errors about in-memory input are reported (no file).
pub(super) const INPUT: &str = "<input>";

/// The perceptual neighbours of each colour term, in [`COLOR_TERMS`] order: the hue circle red –
/// orange – yellow – green – blue – purple – pink – red, and the lightness scale black – grey –
/// white. Chromatic terms neighbour only chromatic ones, so spreading never undoes the chromatic
/// rule of [`Features::color_draws`].
pub const COLOR_NEIGHBOURS: [&[u8]; COLORS] = [
    &[1],
    &[0, 2],
    &[1],
    &[9, 4],
    &[3, 5],
    &[4, 6],
    &[5, 7],
    &[6, 8],
    &[7, 9],
    &[8, 3],
];

/// Spreads the shares `weights` of the colour terms `terms` to their [`COLOR_NEIGHBOURS`]: each
/// term keeps 1 − k·ε of its share and gives ε to each of its k neighbours. Returns the terms with
/// a positive share, ascending, and their shares (the same total). ε = 0 returns the input.
fn smooth_to_neighbours(terms: &[(u8, f64)], weights: &[f64], eps: f64) -> (Vec<(u8, f64)>, Vec<f64>) {
    if eps <= 0.0 {
        return (terms.to_vec(), weights.to_vec());
    }
    let mut out = [0.0f64; COLORS];
    for (&(t, _), &w) in terms.iter().zip(weights) {
        let t = usize::from(t);
        let neighbours = COLOR_NEIGHBOURS[t];
        out[t] += w * (1.0 - eps * neighbours.len() as f64);
        for &u in neighbours {
            out[usize::from(u)] += w * eps;
        }
    }
    let kept: Vec<(u8, f64)> = (0..COLORS)
        .filter(|&t| out[t] > 0.0)
        .map(|t| (t as u8, out[t]))
        .collect();
    let shares = kept.iter().map(|k| k.1).collect();
    (kept, shares)
}

/// One object's colour draws, (bin, count) ascending by bin.
pub type ObjectDraws = Vec<(usize, u64)>;

/// The observed features of one object (mirrors [`SegmentPercept`]).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Features {
    /// The kept bins of the 64-bin HSV histogram as (bin, weight) (§5.1.2.1); carried for display
    /// and inspection, the colour unit reads [`Features::colors`].
    pub histogram: Vec<(u8, f64)>,
    /// Segment size in pixels in the left and right camera; 0 = not seen by that camera.
    pub pixels: [u32; 2],
    /// The kept colour terms as (term, share) ([`SegmentPercept::colors`],
    /// `dexter::vision::color::color_term`): the colour observations of the colour unit
    /// ([`Features::color_draws`]). Empty in features written before the terms were added, which
    /// the model refuses with a message to re-run `pbd infer`.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub colors: Vec<(u8, f64)>,
    /// The object's measured bounding box (m): its footprint's length and width on the support
    /// plane and its height above it ([`SegmentPercept::extent`]); the size feature in centimetres
    /// is their geometric mean ([`Features::size_cm`]). Absent when vision did not measure it (a
    /// recording made before extents were added).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dimensions: Option<[f64; 3]>,
}

impl From<&SegmentPercept> for Features {
    fn from(s: &SegmentPercept) -> Self {
        Features {
            histogram: s.histogram.clone(),
            pixels: s.pixels,
            colors: s.colors.clone(),
            // A coarse extent (a disc of the silhouette's area at the triangulated range, twice the
            // centroid's height) is kept: at decision time in new scenes most small objects have
            // only that, and it tells small from large (development seed 1: without it no object
            // of a size task was decided on). Where a measured view exists, `pbd infer` prefers it.
            dimensions: s
                .extent
                .as_ref()
                .map(|e| [2.0 * e.half_major, 2.0 * e.half_minor, e.height]),
        }
    }
}

impl Features {
    /// Checks bins (< 64, no duplicates), terms (< 10, no duplicates) and weights (finite, ≥ 0);
    /// `field` prefixes error fields.
    pub fn validate(&self, field: &str) -> Result<(), SchemaError> {
        self.validate_in(INPUT, field)
    }

    /// [`Features::validate`] for features read from the file `path` (named in the message).
    pub fn validate_in(&self, path: &str, field: &str) -> Result<(), SchemaError> {
        let mut seen = 0u64;
        for (i, &(bin, w)) in self.histogram.iter().enumerate() {
            if usize::from(bin) >= COLOR_BINS {
                return Err(SchemaError::invalid(
                    path,
                    format!("{field}histogram[{i}]"),
                    format!("bin {bin} out of range 0..{COLOR_BINS}"),
                ));
            }
            if seen & (1u64 << bin) != 0 {
                return Err(SchemaError::invalid(
                    path,
                    format!("{field}histogram[{i}]"),
                    format!("bin {bin} appears twice"),
                ));
            }
            seen |= 1u64 << bin;
            if !(w.is_finite() && w >= 0.0) {
                return Err(SchemaError::invalid(
                    path,
                    format!("{field}histogram[{i}]"),
                    format!("weight {w} is not a finite number >= 0"),
                ));
            }
        }
        for (i, &(term, w)) in self.colors.iter().enumerate() {
            if self.colors[..i].iter().any(|c| c.0 == term) {
                return Err(SchemaError::invalid(
                    path,
                    format!("{field}colors[{i}]"),
                    format!("term {term} appears twice"),
                ));
            }
            if usize::from(term) >= COLOR_TERMS.len() || !(w.is_finite() && w >= 0.0) {
                return Err(SchemaError::invalid(
                    path,
                    format!("{field}colors[{i}]"),
                    format!(
                        "({term}, {w}): the term must be < {} and the share a finite number >= 0",
                        COLOR_TERMS.len()
                    ),
                ));
            }
        }
        if let Some(d) = self.dimensions
            && d.iter().any(|x| !(x.is_finite() && *x > 0.0 && *x <= MAX_DIMENSION))
        {
            return Err(SchemaError::invalid(
                path,
                format!("{field}dimensions"),
                format!("{d:?}: each must be a finite length in metres, > 0 and <= {MAX_DIMENSION}"),
            ));
        }
        Ok(())
    }

    /// The colour draws of this object as (term, count), ascending by term: its `draws_per_object`
    /// colour observations, shared among its colour terms in proportion to their pixel shares
    /// (largest remainder, ties to the lower term; equal shares when all shares are 0).
    ///
    /// **The chromatic rule.** Black, grey and white pixels are on every object — shading, specular
    /// highlights, labels, lids — so when the chromatic terms cover at least `chromatic_share` of
    /// the object's kept pixels, only they are drawn from: a red mug with a white rim is *red*. An
    /// object with less colour than that (a white box with a small red print) keeps all its terms.
    /// `chromatic_share` = 1 turns the rule off (only an all-chromatic object then qualifies, and
    /// for it the rule changes nothing). Empty when the object has no colour terms.
    pub fn color_draws(&self, draws_per_object: u32, chromatic_share: f64) -> Vec<(usize, u64)> {
        self.color_draws_with(draws_per_object, chromatic_share, 0.0)
    }

    /// [`Features::color_draws`] with each term's share first spread to its perceptual neighbours
    /// ([`COLOR_NEIGHBOURS`]): every term keeps 1 − k·`neighbour_share` of its share and gives
    /// `neighbour_share` to each of its k neighbours (0 ≤ `neighbour_share` ≤ ½; 0 = no spreading,
    /// the draws of [`Features::color_draws`]). See [`Hyper::color_neighbour_share`](super::hyper::Hyper::color_neighbour_share).
    pub fn color_draws_with(
        &self,
        draws_per_object: u32,
        chromatic_share: f64,
        neighbour_share: f64,
    ) -> Vec<(usize, u64)> {
        let total: f64 = self.colors.iter().map(|c| c.1).sum();
        let chromatic: f64 = self
            .colors
            .iter()
            .filter(|c| c.0 >= ACHROMATIC_TERMS)
            .map(|c| c.1)
            .sum();
        let use_chromatic = total > 0.0 && chromatic > 0.0 && chromatic >= chromatic_share * total;
        let terms: Vec<(u8, f64)> = self
            .colors
            .iter()
            .filter(|c| !use_chromatic || c.0 >= ACHROMATIC_TERMS)
            .copied()
            .collect();
        if terms.is_empty() {
            return Vec::new();
        }
        let sum: f64 = terms.iter().map(|t| t.1).sum();
        let weights: Vec<f64> = if sum > 0.0 && sum.is_finite() {
            terms.iter().map(|t| t.1 / sum).collect()
        } else {
            vec![1.0 / terms.len() as f64; terms.len()]
        };
        let (terms, weights) = smooth_to_neighbours(&terms, &weights, neighbour_share);
        let w = f64::from(draws_per_object);
        let mut shares: Vec<(u64, f64, u8)> = terms
            .iter()
            .zip(&weights)
            .map(|(&(t, _), &q)| {
                let x = q * w;
                (x.floor() as u64, x - x.floor(), t)
            })
            .collect();
        let given: u64 = shares.iter().map(|s| s.0).sum();
        let mut order: Vec<usize> = (0..shares.len()).collect();
        order.sort_by(|&i, &j| shares[j].1.total_cmp(&shares[i].1).then(shares[i].2.cmp(&shares[j].2)));
        for &i in order
            .iter()
            .cycle()
            .take(u64::from(draws_per_object).saturating_sub(given) as usize)
        {
            shares[i].0 += 1;
        }
        let mut out: BTreeMap<usize, u64> = BTreeMap::new();
        for (n, _, t) in shares {
            if n > 0 {
                *out.entry(usize::from(t)).or_insert(0) += n;
            }
        }
        out.into_iter().collect()
    }

    /// The size observation in half-pixels: left + right when both cameras saw the object, twice
    /// the one count otherwise, `None` when neither did.
    pub fn size_half_pixels(&self) -> Option<u64> {
        match self.pixels {
            [0, 0] => None,
            [l, 0] => Some(2 * u64::from(l)),
            [0, r] => Some(2 * u64::from(r)),
            [l, r] => Some(u64::from(l) + u64::from(r)),
        }
    }

    /// The size observation in deci-pixels (§5.1.2.2): mean pixel count over the cameras / 10.
    pub fn deci_pixels(&self) -> Option<f64> {
        self.size_half_pixels().map(|h| h as f64 / 20.0)
    }

    /// The metric size observation (cm): the geometric mean of [`Features::dimensions`], `None`
    /// when they were not measured.
    pub fn size_cm(&self) -> Option<f64> {
        self.dimensions.map(|[l, w, h]| 100.0 * (l * w * h).cbrt())
    }
}

/// One demonstrated Pick-And-Place: the features of the object and the place it was put.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Example {
    /// What the robot saw of the object.
    pub features: Features,
    /// The place (task-dependent reference) the teacher put it, e.g. `bin_left`.
    pub reference: String,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::procedural::hyper::Hyper;

    const BLACK: u8 = 0;
    const WHITE: u8 = 2;
    const RED: u8 = 3;

    #[test]
    fn the_chromatic_rule_drops_black_grey_white_only_on_coloured_objects() {
        let f = |colors: Vec<(u8, f64)>| Features {
            histogram: Vec::new(),
            pixels: [1, 1],
            colors,
            dimensions: None,
        };
        // A red mug with a white rim is red.
        assert_eq!(f(vec![(WHITE, 0.6), (RED, 0.4)]).color_draws(30, 0.3), vec![(3, 30)]);
        // A white box with a small red print keeps both.
        assert_eq!(
            f(vec![(WHITE, 0.8), (RED, 0.2)]).color_draws(30, 0.3),
            vec![(2, 24), (3, 6)]
        );
        // Off: every term, largest remainder.
        assert_eq!(
            f(vec![(BLACK, 0.5), (WHITE, 0.25), (RED, 0.25)]).color_draws(10, 2.0),
            vec![(0, 5), (2, 3), (3, 2)]
        );
        assert!(f(vec![]).color_draws(30, 0.3).is_empty());
    }

    #[test]
    fn neighbour_spreading_gives_each_neighbour_its_share_and_keeps_the_total() {
        let f = |colors: Vec<(u8, f64)>| Features {
            histogram: Vec::new(),
            pixels: [1, 1],
            colors,
            dimensions: None,
        };
        const PINK: u8 = 9;
        // A pink object with ε = 0.05: 0.9 stays pink, 0.05 goes to red and 0.05 to purple (the
        // neighbours of pink on the hue circle); of 40 draws, 36 / 2 / 2.
        assert_eq!(
            f(vec![(PINK, 1.0)]).color_draws_with(40, 0.3, 0.05),
            vec![(3, 2), (8, 2), (9, 36)]
        );
        // The chromatic rule comes first: the white rim is dropped, then red spreads to orange and
        // pink (never to an achromatic term).
        assert_eq!(
            f(vec![(WHITE, 0.6), (RED, 0.4)]).color_draws_with(20, 0.3, 0.1),
            vec![(3, 16), (4, 2), (9, 2)]
        );
        // Black has one neighbour (grey), so it keeps 1 − ε.
        assert_eq!(
            f(vec![(BLACK, 1.0)]).color_draws_with(10, 0.3, 0.1),
            vec![(0, 9), (1, 1)]
        );
        // ε = 0 is the plain draws.
        let o = f(vec![(BLACK, 0.5), (WHITE, 0.25), (RED, 0.25)]);
        assert_eq!(o.color_draws_with(10, 2.0, 0.0), o.color_draws(10, 2.0));
        for d in [1, 7, 30, 200] {
            let n: u64 = o.color_draws_with(d, 2.0, 0.2).iter().map(|x| x.1).sum();
            assert_eq!(n, u64::from(d));
        }
        let bad = Hyper {
            color_neighbour_share: 0.6,
            ..Hyper::default()
        };
        assert!(bad.validate().is_err());
    }
}
