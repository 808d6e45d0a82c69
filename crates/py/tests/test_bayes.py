"""pbd.bayes: HMMs against hmmlearn's values, conjugate models and Bayes factors."""

import json
import math

import numpy as np
import pytest

import pbd
from pbd import bayes
from conftest import BAYES_DATA


def num(x):
    """Decodes the reference files' non-finite floats ("-inf", "inf", "nan")."""
    if isinstance(x, list):
        return [num(v) for v in x]
    return float(x) if isinstance(x, str) else x


def scaled_diff(a, b):
    if a == b:
        return 0.0
    return abs(a - b) / max(1.0, abs(b))


def hmm_cases():
    data = json.loads((BAYES_DATA / "hmm_forward.json").read_text())
    for c in data["cases"]:
        hmm = bayes.Hmm(np.array(num(c["startprob"])), np.array(num(c["transmat"])))
        with np.errstate(divide="ignore"):
            log_emis = np.log(np.array(num(c["emissionprob"])))
        e = bayes.categorical_log_emissions(log_emis, np.array(c["obs"]))
        yield c, hmm, e


def test_hmm_forward_matches_hmmlearn():
    n = 0
    for c, hmm, e in hmm_cases():
        got = hmm.forward(e)
        if c["impossible"]:
            assert got == -math.inf
            continue
        assert scaled_diff(got, c["log_prob"]) <= 1e-12, (c["kind"], got, c["log_prob"])
        n += 1
    assert n >= 30


def test_hmm_viterbi_matches_hmmlearn():
    for c, hmm, e in hmm_cases():
        got = hmm.viterbi(e)
        if c["impossible"]:
            assert got is None
            continue
        path, log_prob = got
        assert path.dtype == np.int64 and path.shape == (c["T"],)
        assert scaled_diff(log_prob, c["viterbi_log_prob"]) <= 1e-12
        assert path.tolist() == c["viterbi_path"]


def test_hmm_smoothing_rows_sum_to_one():
    for c, hmm, e in hmm_cases():
        got = hmm.forward_backward(e)
        if c["impossible"]:
            assert got is None
            continue
        ll, post = got
        assert post.shape == (c["T"], c["n_states"])
        assert np.allclose(post.sum(axis=1), 1.0, atol=1e-12)
        assert scaled_diff(ll, hmm.forward(e)) <= 1e-12


def test_nig_incremental_equals_batch_and_matches_closed_form():
    prior = bayes.NormalInverseGamma(10.0, 0.1, 2.0, 4.0)
    xs = np.array([12.0, 13.5, 11.8])
    batch = bayes.GaussianStats(xs)
    inc = bayes.GaussianStats()
    for x in xs:
        inc.update(x)
    assert batch.n == 3 and math.isclose(batch.mean, xs.mean())
    a, b = prior.posterior_predictive(batch), prior.posterior_predictive(inc)
    assert math.isclose(a.log_pdf(12.5), b.log_pdf(12.5), rel_tol=1e-12)
    grid = a.log_pdf(np.array([12.5, 30.0]))
    assert grid.shape == (2,) and grid[0] > grid[1]
    post = prior.posterior(batch)
    # (A.5): κ_n = κ + n, μ_n = (κ μ + n x̄) / κ_n, α_n = α + n/2
    assert math.isclose(post.kappa, 3.1)
    assert math.isclose(post.mu, (0.1 * 10.0 + 3 * xs.mean()) / 3.1)
    assert math.isclose(post.alpha, 3.5)
    assert math.isfinite(prior.log_marginal_likelihood(batch))


def test_dirichlet_predictive_and_bayes_factor():
    prior = bayes.SymmetricDirichlet(3, 1.0)
    counts = bayes.CategoryCounts([2, 0, 1])
    # (5.15): (n_k + γ) / (N + Kγ)
    assert np.allclose(prior.predictive_probs(counts), [3 / 6, 1 / 6, 2 / 6])
    places = bayes.SymmetricDirichlet(2, 1.0)
    place_counts = bayes.CategoryCounts([3, 3])
    colours = bayes.SymmetricDirichlet(4, 0.5)
    per_place = [bayes.CategoryCounts([9, 0, 0, 0]), bayes.CategoryCounts([0, 9, 0, 0])]
    task = bayes.categorical_bayes_factor(places, place_counts, colours, per_place, [0, 0])
    other = bayes.categorical_bayes_factor(places, place_counts, colours, per_place, [3, 3])
    assert task["log_b10"] > 0 > other["log_b10"]
    assert math.isclose(task["log_b10"], task["log_p_task"] - task["log_p_background"])
    nig = bayes.NormalInverseGamma(15.0, 0.01, 1.0, 1.0)
    stats = [bayes.GaussianStats([5.0, 5.2, 4.9]), bayes.GaussianStats([30.0, 31.0, 29.5])]
    g = bayes.gaussian_bayes_factor(places, place_counts, nig, stats, nig, [5.1], mode="joint")
    assert g["log_b10"] > 0
    with pytest.raises(pbd.PbdValueError, match="mode"):
        bayes.gaussian_bayes_factor(places, place_counts, nig, stats, nig, [5.1], mode="other")
