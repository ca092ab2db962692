#!/usr/bin/env python3
"""Exact log evidence of the two radiata regression models (tests/data/README.md): alpha and beta
integrated out in closed form given sigma^2, then Simpson's rule over s = log sigma^2.
Plain Python 3, no packages: python3 tests/data/radiata_exact_log_evidence.py"""
import math
import os

here = os.path.dirname(os.path.abspath(__file__))
rows = []
with open(os.path.join(here, "radiata.csv")) as f:
    lines = [l.strip() for l in f if l.strip() and not l.startswith("#")]
for line in lines[1:]:  # lines[0] is the header
    rows.append([float(v) for v in line.split(",")])
y = [r[0] for r in rows]
n = len(y)
alpha0, var_alpha = 3000.0, 1000.0**2
beta0, var_beta = 185.0, 100.0**2
shape, scale = 3.0, 180000.0

for k in (1, 2):
    x = [r[k] for r in rows]
    xbar = sum(x) / n
    xc = [v - xbar for v in x]
    sxx = sum(v * v for v in xc)
    r = [yi - alpha0 - beta0 * c for yi, c in zip(y, xc)]
    rr, r1, rx = sum(v * v for v in r), sum(r), sum(v * c for v, c in zip(r, xc))

    def log_lik(s2):
        # Covariance s2 I + var_alpha 11' + var_beta xc xc': 1 and xc are orthogonal eigenvectors.
        la, lb = s2 + n * var_alpha, s2 + sxx * var_beta
        q = rr / s2 - r1 * r1 / n * (1 / s2 - 1 / la) - rx * rx / sxx * (1 / s2 - 1 / lb)
        log_det = (n - 2) * math.log(s2) + math.log(la) + math.log(lb)
        return -0.5 * (n * math.log(2 * math.pi) + log_det + q)

    def log_prior_s(s):  # Inverse-Gamma on sigma^2 = e^s, with the Jacobian e^s
        return shape * math.log(scale) - math.lgamma(shape) - shape * s - scale * math.exp(-s)

    lo, hi, intervals = math.log(1e3), math.log(1e7), 200000
    h = (hi - lo) / intervals
    logs = [log_lik(math.exp(lo + i * h)) + log_prior_s(lo + i * h) for i in range(intervals + 1)]
    peak = max(logs)
    weights = [1 if i in (0, intervals) else (4 if i % 2 else 2) for i in range(intervals + 1)]
    integral = sum(w * math.exp(v - peak) for w, v in zip(weights, logs)) * h / 3
    print(f"model {k} (x{k}): log Z = {peak + math.log(integral):.4f}"
          f"  (integrand at the ends: {logs[0] - peak:.0f}, {logs[-1] - peak:.0f} in log below its peak)")
