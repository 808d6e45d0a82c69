"""Reference values for bayes::special, computed by mpmath at 60 digits and rounded once.

Run: python3 make_special.py > special.json   (mpmath 1.3.0, Python 3.11)
Inputs are exact f64 values (their repr), so each output is the correctly rounded truth.
"""
import json, sys
import mpmath as mp

mp.mp.dps = 60

def r(x):
    x = float(x)
    if x != x: return "nan"
    if x == float("inf"): return "inf"
    if x == float("-inf"): return "-inf"
    return x

xs = [1e-300, 1e-10, 1e-3, 0.1, 0.25, 0.5, 0.75, 0.999, 1.0, 1.001, 1.25, 1.4616321449683622, 1.5, 1.9, 2.0,
      2.1, 2.5, 3.7, 5.5, 7.25, 9.999, 10.0, 10.5, 12.3, 25.0, 99.5, 1000.25, 1e5 + 0.3, 1e10 + 0.5, 3e15, 1e300,
      -0.5, -1.5, -2.25, -10.7]
ln_gamma = [{"x": x, "value": r(mp.log(abs(mp.gamma(mp.mpf(x)))))} for x in xs]
digamma = [{"x": x, "value": r(mp.digamma(mp.mpf(x)))} for x in xs if x < 1e200]
diffs = []
for x in [1e-3, 0.5, 3.0, 9.5, 10.0, 12.5, 100.0, 5e3, 2.5e7, 5e9, 5e9 + 0.25]:
    for d in [0.5, 1.0, 1.5, 3.0, 17.5, -0.25, 1000.0, 1e6]:
        if x + d <= 0: continue
        v = mp.loggamma(mp.mpf(x) + mp.mpf(d)) - mp.loggamma(mp.mpf(x))
        diffs.append({"x": x, "d": d, "value": r(v)})
multigamma = []
for p in [1, 2, 3, 5]:
    for a in [(p - 1) / 2 + 0.01, (p - 1) / 2 + 0.5, 3.3, 12.0, 2373.2]:
        v = p * (p - 1) / 4 * mp.log(mp.pi) + mp.fsum(mp.loggamma(mp.mpf(a) + mp.mpf(1 - j) / 2) for j in range(1, p + 1))
        multigamma.append({"p": p, "a": a, "value": r(v)})
gq = []
for a in [0.5, 1.0, 1.5, 2.5, 3.5, 10.0, 50.0, 400.5]:
    for x in [1e-8, 0.01, 0.5, 1.0, 2.0, 3.0, 8.0, 20.0, 60.0, 150.0, 400.0, 700.0]:
        gq.append({"a": a, "x": x, "q": r(mp.gammainc(a, x, mp.inf, regularized=True)),
                   "p": r(mp.gammainc(a, 0, x, regularized=True))})
json.dump({"generator": "make_special.py", "versions": {"mpmath": mp.__version__, "python": sys.version.split()[0]},
           "description": "mpmath 60-digit values rounded once: ln|Gamma|, digamma, lnGamma(x+d)-lnGamma(x), "
                          "log multivariate gamma, regularised incomplete gamma P and Q",
           "ln_gamma": ln_gamma, "digamma": digamma, "ln_gamma_diff": diffs, "ln_multigamma": multigamma,
           "gamma_inc": gq}, sys.stdout, indent=0)
