//! The sampler's view of the data: one row per demonstrated grasp, datum (b_mi, x_mi, w_mi) of §6.3.

use nalgebra::{Matrix2, Vector3};

use crate::corpus::{Corpus, validate_spd2};
use crate::error::{GraspError, Result, check_finite, invalid};
use crate::math::{a2, det2, inv2, m2};
use crate::orientation::CanonicalOrientations;

/// Flattened, validated training data: per datum the object index m, appearance b (2×2 SPD),
/// position x (m, object frame) and canonical orientation index w < Q.
///
/// The seed's model has one appearance b per datum (6.11); when a corpus gives one b per object,
/// every grasp of that object carries it, so an object's appearance weighs in once per grasp.
#[derive(Debug, Clone)]
pub struct Dataset {
    pub(crate) object: Vec<u32>,
    pub(crate) x: Vec<Vector3<f64>>,
    pub(crate) b: Vec<Matrix2<f64>>,
    pub(crate) b_inv: Vec<Matrix2<f64>>,
    pub(crate) ln_det_b: Vec<f64>,
    pub(crate) w: Vec<u32>,
    pub(crate) num_objects: usize,
    pub(crate) num_orientations: usize,
}

impl Dataset {
    /// Builds a dataset from parallel arrays (validated: equal lengths, `object[i] < num_objects`,
    /// `w[i] < num_orientations`, finite positions, SPD appearances, at least one datum).
    pub fn new(
        object: &[usize],
        x: &[Vector3<f64>],
        b: &[Matrix2<f64>],
        w: &[usize],
        num_objects: usize,
        num_orientations: usize,
    ) -> Result<Self> {
        let n = object.len();
        if n == 0 {
            return Err(GraspError::EmptyCorpus {
                reason: "no grasps".into(),
            });
        }
        for (f, len) in [("x", x.len()), ("b", b.len()), ("w", w.len())] {
            if len != n {
                return Err(GraspError::DimensionMismatch {
                    field: format!("dataset.{f} (one per datum)"),
                    expected: n,
                    got: len,
                });
            }
        }
        if num_orientations == 0 {
            return Err(invalid("dataset.num_orientations", "must be ≥ 1"));
        }
        let mut d = Self {
            object: Vec::with_capacity(n),
            x: Vec::with_capacity(n),
            b: Vec::with_capacity(n),
            b_inv: Vec::with_capacity(n),
            ln_det_b: Vec::with_capacity(n),
            w: Vec::with_capacity(n),
            num_objects,
            num_orientations,
        };
        for i in 0..n {
            if object[i] >= num_objects {
                return Err(invalid(
                    format!("dataset.object[{i}]"),
                    format!("{} is not < {num_objects} objects", object[i]),
                ));
            }
            if w[i] >= num_orientations {
                return Err(invalid(
                    format!("dataset.w[{i}]"),
                    format!("{} is not < Q = {num_orientations}", w[i]),
                ));
            }
            check_finite(|| format!("dataset.x[{i}]"), x[i].as_slice())?;
            validate_spd2(&format!("dataset.b[{i}]"), &a2(&b[i]))?;
            d.object.push(object[i] as u32);
            d.x.push(x[i]);
            d.b.push(b[i]);
            d.b_inv.push(inv2(&b[i]));
            d.ln_det_b.push(det2(&b[i]).ln());
            d.w.push(w[i] as u32);
        }
        Ok(d)
    }

    /// Flattens a corpus, replacing each orientation by the nearest canonical one (§6.2.2).
    pub fn from_corpus(corpus: &Corpus, canonical: &CanonicalOrientations) -> Result<Self> {
        corpus.validate()?;
        let mut object = Vec::new();
        let mut x = Vec::new();
        let mut b = Vec::new();
        let mut w = Vec::new();
        for (m, o) in corpus.objects.iter().enumerate() {
            for g in &o.grasps {
                object.push(m);
                x.push(g.position());
                b.push(m2(g.appearance.as_ref().unwrap_or(&o.appearance)));
                w.push(canonical.nearest(&g.orientation()));
            }
        }
        Self::new(&object, &x, &b, &w, corpus.objects.len(), canonical.len())
    }

    /// Number of data (grasps).
    pub fn len(&self) -> usize {
        self.x.len()
    }

    /// Whether there are no data (never true for a validated dataset).
    pub fn is_empty(&self) -> bool {
        self.x.is_empty()
    }

    /// Number of objects M.
    pub fn num_objects(&self) -> usize {
        self.num_objects
    }

    /// Number of canonical orientations Q.
    pub fn num_orientations(&self) -> usize {
        self.num_orientations
    }

    /// Object index of datum `i`.
    pub fn object(&self, i: usize) -> usize {
        self.object[i] as usize
    }

    /// Position of datum `i` (m, object frame).
    pub fn position(&self, i: usize) -> Vector3<f64> {
        self.x[i]
    }

    /// Appearance of datum `i`.
    pub fn appearance(&self, i: usize) -> Matrix2<f64> {
        self.b[i]
    }

    /// Canonical orientation index of datum `i`.
    pub fn orientation(&self, i: usize) -> usize {
        self.w[i] as usize
    }

    /// Replaces datum `i`'s observations (used by simulation-based checks such as Geweke's test,
    /// which redraw the data given the assignments). Validated like [`Dataset::new`].
    pub fn set_datum(&mut self, i: usize, x: Vector3<f64>, b: Matrix2<f64>, w: usize) -> Result<()> {
        if i >= self.len() {
            return Err(invalid("dataset index", format!("{i} ≥ {}", self.len())));
        }
        if w >= self.num_orientations {
            return Err(invalid(
                format!("dataset.w[{i}]"),
                format!("{w} is not < Q = {}", self.num_orientations),
            ));
        }
        check_finite(|| format!("dataset.x[{i}]"), x.as_slice())?;
        validate_spd2(&format!("dataset.b[{i}]"), &a2(&b))?;
        self.x[i] = x;
        self.b[i] = b;
        self.b_inv[i] = inv2(&b);
        self.ln_det_b[i] = det2(&b).ln();
        self.w[i] = w as u32;
        Ok(())
    }
}
