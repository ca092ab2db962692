#!/usr/bin/env python3
"""Checks ssrfleet's convergence diagnostics (lib/util/convergence.*) against an independent numpy
implementation written from the equations of Vehtari, Gelman, Simpson, Carpenter & Bürkner (2021),
"Rank-normalization, folding, and localization: an improved R-hat for assessing convergence of
MCMC", Bayesian Analysis 16(2).

    tests/convergence_reference.py TESTS_BINARY

runs the test binary's case [convergence-reference], which writes fixed draws (four
well-mixed AR(1) chains, four chains one of which is shifted by 3 sd, heavy-tailed chains whose
bulk and tail mix differently, odd lengths, ties, one chain) with the library's summary of each,
recomputes every diagnostic here and requires agreement to 1e-8 relative. Exit 0 when all agree,
1 otherwise (or when numpy is missing), with a message saying which value of which case differs.

Nothing is shared with the C++ code but the definitions: the autocovariances here are direct
sums (the library uses an FFT), ranks come from numpy's sort and unique, the normal quantile is
Python's statistics.NormalDist, the sample quantile numpy's, and the beta quantile is solved
here from a continued fraction of the regularised incomplete beta function.
"""
import json
import math
import os
import statistics
import subprocess
import sys
import tempfile

try:
    import numpy as np
except ImportError:
    print("convergence_reference: numpy is missing: install python3-numpy "
          "(scripts/setup-debian.sh installs it with the test packages)")
    sys.exit(1)

RELATIVE_TOLERANCE = 1e-8


# ---- definitions -------------------------------------------------------------------------------

def split(draws):
    """Draws × chains -> the first and second halves of every chain, floor(N/2) draws each (the
    middle draw of an odd N is not used)."""
    n = draws.shape[0]
    half = n // 2
    return np.hstack([draws[:half, :], draws[n - half:, :]])


def average_ranks(values):
    """1-based ranks of all entries together, ties sharing their average rank."""
    flat = values.ravel()
    unique, inverse, counts = np.unique(flat, return_inverse=True, return_counts=True)
    below = np.concatenate([[0], np.cumsum(counts)[:-1]])  # entries smaller than each unique value
    rank_of_unique = below + (counts + 1) / 2.0
    return rank_of_unique[inverse].reshape(values.shape)


def rank_normalise(values):
    """z = Phi^-1((r - 3/8) / (S + 1/4)), r the average rank among all S entries."""
    s = values.size
    u = (average_ranks(values) - 0.375) / (s + 0.25)
    inv = statistics.NormalDist().inv_cdf
    return np.vectorize(inv)(u)


def basic_rhat(chains):
    """sqrt(var+ / W): W the mean within-chain variance, var+ = (N-1)/N W + B/N, B/N the variance
    of the chain means (divisor M-1)."""
    n = chains.shape[0]
    w = np.mean(np.var(chains, axis=0, ddof=1))
    b_over_n = np.var(np.mean(chains, axis=0), ddof=1)
    return math.sqrt(((n - 1) / n * w + b_over_n) / w)


def autocovariances(chain):
    """gamma(t) = 1/N sum_{i < N-t} (x_i - mean)(x_{i+t} - mean), t = 0..N-1, by direct sums."""
    n = chain.size
    centred = chain - chain.mean()
    return np.array([np.dot(centred[:n - t], centred[t:]) for t in range(n)]) / n


def ess(chains):
    """Geyer's initial monotone sequence on the multi-chain autocorrelation
    rho(t) = 1 - (W - mean_m gamma_m(t)) / var+ (t > 0; rho(0) = 1), S / tau with
    tau = -1 + 2 sum_{k<K} P_k + rho(2K), P_k = rho(2k) + rho(2k+1) made monotone (each the
    minimum of those before it), K the first pair not taken: pairs are taken while the previous
    one's sum is positive and its even lag is below N - 5; rho(2K) counts when positive or when
    pair K's sum is not negative. tau >= 1 / log10(S)."""
    n, m = chains.shape
    gamma = np.mean([autocovariances(chains[:, c]) for c in range(m)], axis=0)
    w = gamma[0] * n / (n - 1)
    var_plus = w * (n - 1) / n + (np.var(np.mean(chains, axis=0), ddof=1) if m > 1 else 0.0)

    def rho(t):  # an autocorrelation: 1 at lag 0 by definition (the formula gives 1 - O(1/N) there)
        return 1.0 if t == 0 else 1.0 - (w - gamma[t]) / var_plus

    k = 0
    even, odd = 1.0, rho(1)
    while 2 * k < n - 5 and even + odd > 0:
        k += 1
        even, odd = rho(2 * k), rho(2 * k + 1)
    pairs = np.minimum.accumulate(np.array([rho(2 * j) + rho(2 * j + 1) for j in range(k)])) \
        if k > 0 else np.zeros(0)
    last = even if (even + odd >= 0 or even > 0) else 0.0
    s = n * m
    tau = max(-1.0 + 2.0 * pairs.sum() + last, 1.0 / math.log10(s))
    return s / tau


def quantile(draws, p):
    return float(np.quantile(draws.ravel(), p))  # linear interpolation: Hyndman & Fan type 7


def regularised_incomplete_beta(x, a, b):
    """I_x(a, b) by the continued fraction of Abramowitz & Stegun 26.5.8 (modified Lentz), on the
    side where it converges fast."""
    if x <= 0.0:
        return 0.0
    if x >= 1.0:
        return 1.0
    if x > (a + 1.0) / (a + b + 2.0):
        return 1.0 - regularised_incomplete_beta(1.0 - x, b, a)
    log_front = (math.lgamma(a + b) - math.lgamma(a) - math.lgamma(b)
                 + a * math.log(x) + b * math.log1p(-x))
    tiny = 1e-300
    c, d = 1.0, 1.0 - (a + b) * x / (a + 1.0)
    d = 1.0 / (d if abs(d) > tiny else tiny)
    fraction = d
    for j in range(1, 10000):
        # even step d_{2j}, then odd step d_{2j+1}
        for numerator in (j * (b - j) * x / ((a + 2 * j - 1) * (a + 2 * j)),
                          -(a + j) * (a + b + j) * x / ((a + 2 * j) * (a + 2 * j + 1))):
            d = 1.0 + numerator * d
            d = 1.0 / (d if abs(d) > tiny else tiny)
            c = 1.0 + numerator / c
            c = c if abs(c) > tiny else tiny
            fraction *= c * d
        if abs(c * d - 1.0) < 3e-16:
            break
    return math.exp(log_front) * fraction / a


def beta_quantile(probability, a, b):
    """x with I_x(a, b) = probability, by bisection to the last bit."""
    lo, hi = 0.0, 1.0
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if mid <= lo or mid >= hi:
            break
        if regularised_incomplete_beta(mid, a, b) < probability:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


PHI_MINUS_ONE = 0.5 * math.erfc(1.0 / math.sqrt(2.0))  # Phi(-1)
PHI_PLUS_ONE = 1.0 - PHI_MINUS_ONE


def ess_quantile(draws, p):
    below = (draws <= quantile(draws, p)).astype(float)
    return ess(split(below))


def mcse_quantile(draws, p, ess_p):
    """Half the width of [theta_(max(floor(a- S), 1)), theta_(min(ceil(a+ S), S))], a-/a+ the
    Phi(-1)/Phi(1) quantiles of Beta(E p + 1, E (1 - p) + 1), E the ESS of the quantile."""
    a, b = ess_p * p + 1.0, ess_p * (1.0 - p) + 1.0
    lower = beta_quantile(PHI_MINUS_ONE, a, b)
    upper = beta_quantile(PHI_PLUS_ONE, a, b)
    ordered = np.sort(draws.ravel())
    s = ordered.size
    i = max(math.floor(lower * s), 1)
    j = min(math.ceil(upper * s), s)
    return (ordered[j - 1] - ordered[i - 1]) / 2.0


def summary(draws):
    out = {}
    out["mean"] = float(np.mean(draws))
    out["sd"] = float(np.std(draws, ddof=1))
    for name, p in (("q05", 0.05), ("q50", 0.5), ("q95", 0.95)):
        out[name] = quantile(draws, p)
    out["rhat_bulk"] = basic_rhat(rank_normalise(split(draws)))
    folded = np.abs(draws - np.median(draws))
    out["rhat_tail"] = basic_rhat(rank_normalise(split(folded)))
    out["rhat"] = max(out["rhat_bulk"], out["rhat_tail"])
    # Independent runs' unordered draws: the same, of the chains as they are (not split).
    out["rhat_unsplit"] = max(basic_rhat(rank_normalise(draws)), basic_rhat(rank_normalise(folded)))
    out["ess_bulk"] = ess(rank_normalise(split(draws)))
    out["ess_q05"] = ess_quantile(draws, 0.05)
    out["ess_q95"] = ess_quantile(draws, 0.95)
    out["ess_tail"] = min(out["ess_q05"], out["ess_q95"])
    out["ess_mean"] = ess(split(draws))
    out["mcse_mean"] = out["sd"] / math.sqrt(out["ess_mean"])
    out["mcse_q05"] = mcse_quantile(draws, 0.05, out["ess_q05"])
    out["mcse_q95"] = mcse_quantile(draws, 0.95, out["ess_q95"])
    return out


# ---- the check ---------------------------------------------------------------------------------

def main():
    if len(sys.argv) != 2:
        print("usage: convergence_reference.py TESTS_BINARY")
        return 2
    binary = sys.argv[1]
    with tempfile.TemporaryDirectory() as scratch:
        path = os.path.join(scratch, "cases.json")
        env = dict(os.environ, SSRFLEET_CONVERGENCE_CASES=path)
        run = subprocess.run([binary, "[convergence-reference]"], env=env, capture_output=True, text=True)
        if run.returncode != 0 or not os.path.exists(path):
            print(f"convergence_reference: {binary} [convergence-reference] failed "
                  f"(exit {run.returncode}):\n{run.stdout}{run.stderr}")
            return 1
        with open(path) as f:
            cases = json.load(f)["cases"]

    failures = []
    print(f"{'case':44} {'value':10} {'C++':>22} {'numpy':>22} {'rel. diff':>9}")
    for case in cases:
        draws = np.array(case["chains"], dtype=float).T  # draws × chains
        mine = summary(draws)
        sd = mine["sd"]
        for name, expected in mine.items():
            got = case["summary"][name]
            if got is None and math.isnan(expected):
                continue  # undefined in both (R-hat of a single chain not split)
            if got is None:
                failures.append(f"{case['name']}: {name} is NaN in C++, {expected!r} here")
                continue
            # A mean near 0 is judged on the scale of the draws, every other value on its own.
            scale = max(abs(expected), sd) if name == "mean" else abs(expected)
            diff = abs(got - expected) / scale if scale > 0 else abs(got - expected)
            print(f"{case['name'][:44]:44} {name:10} {got:22.15g} {expected:22.15g} {diff:9.1e}")
            if not diff <= RELATIVE_TOLERANCE:
                failures.append(f"{case['name']}: {name} is {got!r} in C++ but {expected!r} from the "
                                f"equations (relative difference {diff:.3g} > {RELATIVE_TOLERANCE:g})")

    # The cases are built to show what the diagnostics are for; say so if they stop doing it.
    by_name = {c["name"]: summary(np.array(c["chains"], dtype=float).T) for c in cases[:3]}
    well, shifted, heavy = (by_name[c["name"]] for c in cases[:3])
    if not well["rhat"] < 1.01:
        failures.append(f"well-mixed chains: R-hat {well['rhat']:.4f}, not below 1.01")
    if not shifted["rhat"] > 1.3:
        failures.append(f"shifted chain: R-hat {shifted['rhat']:.4f}, not far above 1")
    if not shifted["rhat_unsplit"] > 1.3:
        failures.append(f"shifted chain: unsplit R-hat {shifted['rhat_unsplit']:.4f}, not far above 1")
    if not heavy["ess_tail"] < 0.5 * heavy["ess_bulk"]:
        failures.append(f"heavy tails: tail-ESS {heavy['ess_tail']:.1f} not below half the bulk-ESS "
                        f"{heavy['ess_bulk']:.1f}")

    if failures:
        print("\nconvergence_reference: FAILED")
        for f in failures:
            print("  " + f)
        return 1
    print(f"\nconvergence_reference: {len(cases)} cases, every value within {RELATIVE_TOLERANCE:g} relative")
    return 0


if __name__ == "__main__":
    sys.exit(main())
