//! Special functions: log-gamma, the log-gamma *difference* that the conjugate marginals need,
//! the multivariate log-gamma Γ_p, digamma and the regularised incomplete gamma functions
//! (χ² p-values).
//!
//! Everything is implemented here (no `statrs`): the Stirling series with upward recurrence for
//! `ln Γ`, the asymptotic series with recurrence for ψ, and the series / Lentz continued fraction
//! for `P(a, x)` / `Q(a, x)` (Numerical Recipes §6.2). They are checked against mpmath at 60
//! digits (`tests/data/special.json`).
//!
//! The one subtle piece is [`ln_gamma_diff`]: the Student-t density needs
//! `ln Γ((ν+1)/2) − ln Γ(ν/2)` for ν up to 1e10, where each term is ~1e11 and the difference ~11,
//! so subtracting two correctly rounded `ln Γ` values would lose 10 digits. Subtracting the
//! Stirling expansions *analytically* keeps full relative accuracy.

use std::f64::consts::PI;

/// ½ ln(2π).
const LN_SQRT_2PI: f64 = 0.918_938_533_204_672_8;
/// ln π.
const LN_PI: f64 = 1.144_729_885_849_400_2;
/// Below this argument `ln Γ` is reached by upward recurrence; above it the Stirling series
/// (8 terms) is accurate to < 1e-17 absolute.
const STIRLING_MIN: f64 = 10.0;

/// Σ_{k=1..8} B_{2k} / (2k(2k−1) x^{2k−1}): the tail of Stirling's series for ln Γ(x), x ≥ 10.
fn stirling_tail(x: f64) -> f64 {
    let r = 1.0 / x;
    let r2 = r * r;
    r * (1.0 / 12.0
        + r2 * (-1.0 / 360.0
            + r2 * (1.0 / 1260.0
                + r2 * (-1.0 / 1680.0
                    + r2 * (1.0 / 1188.0
                        + r2 * (-691.0 / 360_360.0 + r2 * (1.0 / 156.0 + r2 * (-3617.0 / 122_400.0))))))))
}

/// ln Γ(x) for x ≥ [`STIRLING_MIN`].
fn ln_gamma_stirling(x: f64) -> f64 {
    (x - 0.5) * x.ln() - x + LN_SQRT_2PI + stirling_tail(x)
}

/// ζ(k) − 1 for k = 2..=30 (mpmath, 50 digits, rounded once).
const ZETA_MINUS_ONE: [f64; 29] = [
    0.6449340668482264,
    0.2020569031595943,
    0.08232323371113819,
    0.03692775514336993,
    0.01734306198444914,
    0.008349277381922827,
    0.00407735619794434,
    0.0020083928260822143,
    0.0009945751278180853,
    0.0004941886041194645,
    0.0002460865533080483,
    0.00012271334757848915,
    6.124813505870483e-05,
    3.058823630702049e-05,
    1.528225940865187e-05,
    7.637197637899763e-06,
    3.81729326499984e-06,
    1.908212716553939e-06,
    9.539620338727962e-07,
    4.769329867878064e-07,
    2.38450502727733e-07,
    1.1921992596531106e-07,
    5.960818905125948e-08,
    2.980350351465228e-08,
    1.4901554828365043e-08,
    7.45071178983543e-09,
    3.725334024788457e-09,
    1.862659723513049e-09,
    9.313274324196682e-10,
];
/// The Euler–Mascheroni constant γ.
const EULER_GAMMA: f64 = 0.5772156649015329;

/// ln Γ(1 + z) for |z| ≤ ½ by the Taylor series about 1, with the ζ(k) = 1 part summed in
/// closed form: `−γz + (z − ln1p z) + Σ_{k≥2} (−1)^k (ζ(k)−1) z^k / k`. The remaining terms
/// shrink like 4^−k, and the result keeps full *relative* accuracy near the zero at z = 0.
fn ln_gamma_1p(z: f64) -> f64 {
    let mut acc = 0.0;
    for (i, c) in ZETA_MINUS_ONE.iter().enumerate().rev() {
        let k = (i + 2) as f64;
        let sign = if (i + 2) % 2 == 0 { 1.0 } else { -1.0 };
        acc = acc * z + sign * c / k;
    }
    acc * z * z + (z - z.ln_1p()) - EULER_GAMMA * z
}

/// Natural log of |Γ(x)|.
///
/// `+inf` at the poles (0, −1, −2, …) and at `+inf`; NaN for NaN. For 0 < x < 10 the argument
/// is moved by recurrence into [½, 2½) and the Taylor series about 1 (or 2) is used, which keeps
/// full relative accuracy near the zeros at 1 and 2; from 10 on, Stirling's series. Checked
/// against mpmath to a few ulp (`tests/special.rs`).
pub fn ln_gamma(x: f64) -> f64 {
    if x.is_nan() {
        return f64::NAN;
    }
    if x == f64::INFINITY {
        return f64::INFINITY;
    }
    if x <= 0.0 {
        if x == x.floor() {
            return f64::INFINITY;
        }
        // Reflection: Γ(x)Γ(1−x) = π / sin(πx); |sin(πx)| has period 1, and reducing first
        // keeps πx from rounding at large |x|.
        let s = (PI * (x - x.floor())).sin().abs();
        return LN_PI - s.ln() - ln_gamma(1.0 - x);
    }
    if x >= STIRLING_MIN {
        return ln_gamma_stirling(x);
    }
    if x < 0.5 {
        // Γ(x) = Γ(1+x)/x, with z = x exact (no rounding of 1 + x).
        return ln_gamma_1p(x) - x.ln();
    }
    if x < 1.5 {
        return ln_gamma_1p(x - 1.0);
    }
    // x in [1.5, 10): Γ(x) = (x−1)(x−2)…(r) Γ(r), r in [1.5, 2.5); Γ(2+z) = (1+z) Γ(1+z).
    let mut r = x;
    let mut prod = 1.0;
    while r >= 2.5 {
        r -= 1.0;
        prod *= r;
    }
    let z = r - 2.0;
    prod.ln() + z.ln_1p() + ln_gamma_1p(z)
}

/// ln Γ(x + d) − ln Γ(x), accurate even when both terms are huge and nearly equal.
///
/// Requires x > 0 and x + d > 0 (otherwise NaN). When both arguments are ≥ 10 the Stirling
/// expansions are subtracted analytically:
/// `d·ln x + (x+d−½)·ln1p(d/x) − d + tail(x+d) − tail(x)`; otherwise the plain difference is
/// already accurate because at least one term is small.
///
/// Used for the Student-t normaliser (ν up to 1e10), the Normal–Inverse-Gamma marginal
/// (α₀ large) and the Dirichlet–multinomial marginal (γ large), eqs. (5.14), (5.18).
pub fn ln_gamma_diff(x: f64, d: f64) -> f64 {
    let y = x + d;
    if x.is_nan() || d.is_nan() || x <= 0.0 || y <= 0.0 {
        return f64::NAN;
    }
    if d == 0.0 {
        return 0.0;
    }
    if x.is_infinite() || y.is_infinite() {
        // Γ grows without bound; only the sign of d matters.
        return if d > 0.0 { f64::INFINITY } else { f64::NEG_INFINITY };
    }
    if x.min(y) >= STIRLING_MIN {
        d * x.ln() + (y - 0.5) * (d / x).ln_1p() - d + (stirling_tail(y) - stirling_tail(x))
    } else {
        ln_gamma(y) - ln_gamma(x)
    }
}

/// Log of the multivariate gamma function Γ_p(a) (scipy's `multigammaln`):
/// `p(p−1)/4 · ln π + Σ_{j=1..p} ln Γ(a + (1−j)/2)`.
///
/// Defined for a > (p−1)/2; below that an argument reaches a pole or a negative value and the
/// result is `+inf` or the log of |Γ|, which is not a meaningful Γ_p. `p = 0` gives 0.
pub fn ln_multigamma(p: usize, a: f64) -> f64 {
    let pf = p as f64;
    let mut sum = pf * (pf - 1.0) / 4.0 * LN_PI;
    for j in 1..=p {
        sum += ln_gamma(a + (1.0 - j as f64) / 2.0);
    }
    sum
}

/// The digamma function ψ(x) = d/dx ln Γ(x).
///
/// NaN at the poles (0, −1, −2, …) and for NaN; `+inf` at `+inf`. Absolute error below
/// ~2e-15 for x > 0.
pub fn digamma(x: f64) -> f64 {
    if x.is_nan() {
        return f64::NAN;
    }
    if x == f64::INFINITY {
        return f64::INFINITY;
    }
    if x <= 0.0 {
        if x == x.floor() {
            return f64::NAN;
        }
        // ψ(1−x) − ψ(x) = π cot(πx).
        return digamma(1.0 - x) - PI / (PI * (x - x.floor())).tan();
    }
    let mut acc = 0.0;
    let mut y = x;
    while y < STIRLING_MIN {
        acc -= 1.0 / y;
        y += 1.0;
    }
    let r2 = 1.0 / (y * y);
    let tail = r2
        * (1.0 / 12.0
            + r2 * (-1.0 / 120.0
                + r2 * (1.0 / 252.0
                    + r2 * (-1.0 / 240.0 + r2 * (1.0 / 132.0 + r2 * (-691.0 / 32760.0 + r2 * (1.0 / 12.0)))))));
    acc + y.ln() - 0.5 / y - tail
}

/// Iteration cap for the incomplete-gamma series and continued fraction; ample for a ≤ 1e8.
const MAX_ITER: usize = 100_000;

/// The regularised lower incomplete gamma function P(a, x) = γ(a, x) / Γ(a).
///
/// a > 0 and x ≥ 0 (NaN otherwise). P(a, +inf) = 1.
pub fn gamma_p(a: f64, x: f64) -> f64 {
    match incomplete_gamma(a, x) {
        Some((p, q, lower)) => {
            if lower {
                p
            } else {
                1.0 - q
            }
        }
        None => f64::NAN,
    }
}

/// The regularised upper incomplete gamma function Q(a, x) = Γ(a, x) / Γ(a) = 1 − P(a, x).
///
/// Computed directly by continued fraction when x ≥ a + 1, so tiny tail probabilities keep
/// their relative accuracy (down to the underflow at ~1e-308). a > 0 and x ≥ 0 (NaN otherwise).
pub fn gamma_q(a: f64, x: f64) -> f64 {
    match incomplete_gamma(a, x) {
        Some((p, q, lower)) => {
            if lower {
                1.0 - p
            } else {
                q
            }
        }
        None => f64::NAN,
    }
}

/// Survival function of the χ² distribution with `dof` degrees of freedom:
/// `Q(dof/2, x/2)`; 1 for x ≤ 0. NaN when dof ≤ 0 or an argument is NaN.
pub fn chi2_sf(x: f64, dof: f64) -> f64 {
    if x.is_nan() || dof.is_nan() || dof <= 0.0 {
        return f64::NAN;
    }
    if x <= 0.0 {
        return 1.0;
    }
    gamma_q(dof / 2.0, x / 2.0)
}

/// Returns (P, Q, which-is-valid): the series gives P when x < a + 1, the continued fraction
/// gives Q otherwise. None for invalid arguments.
fn incomplete_gamma(a: f64, x: f64) -> Option<(f64, f64, bool)> {
    if a.is_nan() || x.is_nan() || a <= 0.0 || x < 0.0 || a.is_infinite() {
        return None;
    }
    if x == 0.0 {
        return Some((0.0, 1.0, true));
    }
    if x.is_infinite() {
        return Some((1.0, 0.0, true));
    }
    let ln_prefactor = ln_gamma_prefactor(a, x);
    if x < a + 1.0 {
        // P(a,x) = x^a e^{-x} / Γ(a+1) · Σ_n x^n / ((a+1)…(a+n))
        let mut term = 1.0 / a;
        let mut sum = term;
        let mut ap = a;
        for _ in 0..MAX_ITER {
            ap += 1.0;
            term *= x / ap;
            sum += term;
            if term.abs() < sum.abs() * f64::EPSILON * 0.5 {
                break;
            }
        }
        let p = (ln_prefactor + sum.ln()).exp();
        Some((p.min(1.0), 0.0, true))
    } else {
        // Q(a,x) by the modified Lentz continued fraction (NR 6.2.7).
        const TINY: f64 = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / TINY;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..=MAX_ITER {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < TINY {
                d = TINY;
            }
            c = b + an / c;
            if c.abs() < TINY {
                c = TINY;
            }
            d = 1.0 / d;
            let del = d * c;
            h *= del;
            if (del - 1.0).abs() < f64::EPSILON * 0.5 {
                break;
            }
        }
        let q = (ln_prefactor + h.ln()).exp();
        Some((0.0, q.min(1.0), false))
    }
}

/// ln(x^a e^{−x} / Γ(a)). For a ≥ 10 the Stirling form
/// `a·(ln1p δ − δ) + ½ ln a − ½ ln 2π − tail(a)`, δ = (x−a)/a, avoids subtracting terms of size
/// a·ln x (which would cost ~a·eps of relative accuracy in Q near the median).
fn ln_gamma_prefactor(a: f64, x: f64) -> f64 {
    if a < STIRLING_MIN {
        return a * x.ln() - x - ln_gamma(a);
    }
    let delta = (x - a) / a;
    // Far from the median there is no cancellation, and x/a must not go through 1 + δ.
    let a_log1pmx = if delta.abs() > 0.5 {
        a * (x / a).ln() - (x - a)
    } else {
        a * log1pmx(delta)
    };
    a_log1pmx + 0.5 * a.ln() - LN_SQRT_2PI - stirling_tail(a)
}

/// ln(1 + δ) − δ, accurate for small δ: with u = δ/(2+δ), ln(1+δ) = 2 atanh u, so
/// ln(1+δ) − δ = −uδ + 2(u³/3 + u⁵/5 + …).
fn log1pmx(delta: f64) -> f64 {
    if delta.abs() > 0.5 {
        return delta.ln_1p() - delta;
    }
    let u = delta / (2.0 + delta);
    let u2 = u * u;
    let mut term = u * u2;
    let mut sum = 0.0_f64;
    let mut k = 3.0;
    while term.abs() > 1e-18 * sum.abs().max(1e-300) && k < 200.0 {
        sum += term / k;
        term *= u2;
        k += 2.0;
    }
    -u * delta + 2.0 * sum
}

/// log(Σ exp(xᵢ)) without overflow; `-inf` for an empty slice or when every xᵢ is `-inf`.
/// A NaN element gives NaN; a `+inf` element gives `+inf`.
pub fn log_sum_exp(xs: &[f64]) -> f64 {
    let m = xs.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if m.is_infinite() {
        return if xs.iter().any(|v| v.is_nan()) { f64::NAN } else { m };
    }
    let s: f64 = xs.iter().map(|&v| (v - m).exp()).sum();
    m + s.ln()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ln_gamma_small_integers_are_log_factorials() {
        let mut f = 1.0_f64;
        for n in 1..30 {
            assert!(
                (ln_gamma(n as f64) - f.ln()).abs() <= 4e-15 * f.ln().max(1.0),
                "n = {n}"
            );
            f *= n as f64;
        }
    }

    #[test]
    fn ln_gamma_poles_and_nan() {
        assert_eq!(ln_gamma(0.0), f64::INFINITY);
        assert_eq!(ln_gamma(-3.0), f64::INFINITY);
        assert!(ln_gamma(f64::NAN).is_nan());
        assert!((ln_gamma(0.5) - 0.5 * PI.ln()).abs() < 1e-15);
        // Γ(−0.5) = −2√π
        assert!((ln_gamma(-0.5) - (2.0 * PI.sqrt()).ln()).abs() < 1e-14);
    }

    #[test]
    fn ln_gamma_diff_matches_plain_difference_where_that_is_safe() {
        for &(x, d) in &[
            (0.3, 0.5),
            (3.0, 2.5),
            (12.0, 0.5),
            (20.0, -5.0),
            (50.0, 100.0),
            (9.0, 3.0),
        ] {
            let plain = ln_gamma(x + d) - ln_gamma(x);
            assert!((ln_gamma_diff(x, d) - plain).abs() < 1e-13, "x = {x}, d = {d}");
        }
        assert!(ln_gamma_diff(-1.0, 0.5).is_nan());
        assert_eq!(ln_gamma_diff(5.0, 0.0), 0.0);
    }

    #[test]
    fn digamma_known_values() {
        let euler = 0.577_215_664_901_532_9;
        assert!((digamma(1.0) + euler).abs() < 1e-15);
        assert!((digamma(0.5) + euler + 2.0 * 2f64.ln()).abs() < 1e-15);
        assert!(digamma(0.0).is_nan());
    }

    #[test]
    fn incomplete_gamma_edges() {
        assert_eq!(gamma_q(2.0, 0.0), 1.0);
        assert_eq!(gamma_q(2.0, f64::INFINITY), 0.0);
        assert!(gamma_q(0.0, 1.0).is_nan());
        // Q(1, x) = e^{-x}
        for &x in &[0.1, 1.0, 5.0, 50.0, 700.0] {
            let rel = (gamma_q(1.0, x) - (-x).exp()).abs() / (-x).exp();
            assert!(rel < 1e-14, "x = {x}: {rel}");
        }
        assert!((gamma_p(3.0, 2.0) + gamma_q(3.0, 2.0) - 1.0).abs() < 1e-15);
        assert_eq!(chi2_sf(0.0, 3.0), 1.0);
    }

    #[test]
    fn log_sum_exp_handles_infinities() {
        assert_eq!(log_sum_exp(&[]), f64::NEG_INFINITY);
        assert_eq!(log_sum_exp(&[f64::NEG_INFINITY; 3]), f64::NEG_INFINITY);
        assert!((log_sum_exp(&[0.0, 0.0]) - 2f64.ln()).abs() < 1e-16);
        assert!((log_sum_exp(&[-1000.0, -1000.0]) - (-1000.0 + 2f64.ln())).abs() < 1e-12);
    }
}
