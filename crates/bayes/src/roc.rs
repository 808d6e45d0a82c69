//! Receiver operating characteristic of a scored binary decision: the ROC curve and the area under
//! it (AUC), as used for task relevance (Sweeney 2011, Figs. 5.8, 5.10).

/// Area under the ROC curve of `(score, positive)` pairs (higher score = more positive), ties
/// counted half: the Mann–Whitney U statistic over n₊·n₋, computed from ranks in O(n log n). NaN when
/// either class is empty.
pub fn auc(scores: &[(f64, bool)]) -> f64 {
    let n_pos = scores.iter().filter(|s| s.1).count();
    let n_neg = scores.len() - n_pos;
    if n_pos == 0 || n_neg == 0 {
        return f64::NAN;
    }
    let mut s: Vec<(f64, bool)> = scores.to_vec();
    s.sort_by(|a, b| a.0.total_cmp(&b.0));
    // Mid-ranks of tied groups, summed over the positives.
    let mut rank_sum = 0.0;
    let mut i = 0;
    while i < s.len() {
        let mut j = i;
        while j + 1 < s.len() && s[j + 1].0 == s[i].0 {
            j += 1;
        }
        let mid = (i + j) as f64 / 2.0 + 1.0;
        rank_sum += mid * s[i..=j].iter().filter(|x| x.1).count() as f64;
        i = j + 1;
    }
    let u = rank_sum - (n_pos * (n_pos + 1)) as f64 / 2.0;
    u / (n_pos * n_neg) as f64
}

/// ROC points (false-positive rate, true-positive rate) from the highest threshold down, one per
/// distinct score, starting at (0, 0) and ending at (1, 1).
pub fn roc(scores: &[(f64, bool)]) -> Vec<(f64, f64)> {
    let mut s = scores.to_vec();
    s.sort_by(|a, b| b.0.total_cmp(&a.0));
    let np = s.iter().filter(|x| x.1).count().max(1) as f64;
    let nn = s.iter().filter(|x| !x.1).count().max(1) as f64;
    let (mut tp, mut fp) = (0.0, 0.0);
    let mut out = vec![(0.0, 0.0)];
    for (i, &(score, pos)) in s.iter().enumerate() {
        if pos {
            tp += 1.0;
        } else {
            fp += 1.0;
        }
        if i + 1 == s.len() || s[i + 1].0 != score {
            out.push((fp / nn, tp / np));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The pairwise definition: P(score₊ > score₋) + ½ P(tie).
    fn auc_pairs(scores: &[(f64, bool)]) -> f64 {
        let (mut sum, mut n) = (0.0, 0.0);
        for p in scores.iter().filter(|s| s.1) {
            for q in scores.iter().filter(|s| !s.1) {
                sum += if p.0 > q.0 {
                    1.0
                } else if p.0 == q.0 {
                    0.5
                } else {
                    0.0
                };
                n += 1.0;
            }
        }
        sum / n
    }

    #[test]
    fn auc_from_ranks_equals_the_pairwise_definition() {
        let s = [
            (0.1, false),
            (0.4, true),
            (0.35, false),
            (0.8, true),
            (0.4, false),
            (0.4, true),
            (-1.0, true),
        ];
        assert!((auc(&s) - auc_pairs(&s)).abs() < 1e-12);
        // sklearn.metrics.roc_auc_score([0,0,1,1], [0.1,0.4,0.35,0.8]) = 0.75
        assert!((auc(&[(0.1, false), (0.4, false), (0.35, true), (0.8, true)]) - 0.75).abs() < 1e-12);
        assert!(auc(&[(1.0, true)]).is_nan());
    }

    #[test]
    fn roc_runs_from_origin_to_one_one() {
        let r = roc(&[(0.9, true), (0.8, false), (0.7, true), (0.1, false)]);
        assert_eq!(r.first(), Some(&(0.0, 0.0)));
        assert_eq!(r.last(), Some(&(1.0, 1.0)));
        assert_eq!(r[1], (0.0, 0.5));
    }
}
