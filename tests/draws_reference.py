#!/usr/bin/env python3
"""Opens ssrfleet's draws files with the tools a researcher uses and checks them against the
posterior file they came from (docs/draws.md).

    tests/draws_reference.py SSRFLEET_BINARY

makes a tiny fit of each sampler (10 simulated trucks: the SMC with 64 particles and 2 pooled
final sweeps, the SMC as 2 independent runs (--runs 2), the batch MCMC with 2 chains of 100 kept
sweeps), writes the draws as NetCDF
(`fit --draws-out`) and as CSV (`ssrfleet draws`), then:
  - lists the NetCDF file's groups with netCDF4 and opens every one with xarray;
  - recomputes the equal-weight draws here from the JSON's cloud (systematic resampling at offset
    1/2, chain by chain, with numpy's cumsum and searchsorted) and requires the same source
    indices and the same values, bit for bit, in `posterior`, with dims (chain, draw);
  - checks `sample_stats` (the log evidence, the weights' ESS, the chains' or runs' R-hat and the
    runs' equivalent ESS) against the JSON, and
    `observed_data.if` (truck, sensor) and `constant_data` against the log read by numpy;
  - checks each group's attributes (created_at an ISO time, inference_library, the model spec);
  - reads the CSV with numpy and requires the NetCDF file's values;
  - reopens the two files in turn while other handles on them are open, as xarray's cache does.
Exit 0 when all agree, 1 otherwise (or when a module is missing), saying what differs.
"""
import datetime
import json
import os
import subprocess
import sys
import tempfile

MISSING = []
try:
    import numpy as np
except ImportError:
    MISSING.append("numpy (python3-numpy)")
try:
    import xarray as xr
except ImportError:
    MISSING.append("xarray (python3-xarray)")
try:
    import netCDF4
except ImportError:
    MISSING.append("netCDF4 (python3-netcdf4)")
if MISSING:
    print("draws_reference: python modules missing: " + ", ".join(MISSING) +
          "; scripts/setup-debian.sh installs them with the test packages")
    sys.exit(1)

FAILURES = []


def check(condition, what):
    if not condition:
        FAILURES.append(what)
        print("FAIL: " + what)


def run(binary, *args):
    result = subprocess.run([binary, *args], capture_output=True, text=True)
    if result.returncode != 0:
        print("draws_reference: ssrfleet " + " ".join(args) + " failed:\n" + result.stderr)
        sys.exit(1)


def equal_weight_sources(weights, chains):
    """The draws' cloud columns: per chain, draw i is the particle whose cumulative weight first
    exceeds (i + 1/2) / D."""
    per_chain = len(weights) // chains
    sources = np.empty((chains, per_chain), dtype=np.int64)
    for c in range(chains):
        w = np.asarray(weights[c * per_chain:(c + 1) * per_chain], dtype=float)
        cumulative = np.cumsum(w / w.sum())
        points = (np.arange(per_chain) + 0.5) / per_chain
        picked = np.minimum(np.searchsorted(cumulative, points, side="right"), per_chain - 1)
        sources[c] = c * per_chain + picked
    return sources


HYPER = ["K", "sigma_k", "Kt", "sigma_kt", "Z", "sigma_z", "sigma_if"]


def check_fit(name, posterior_path, nc_path, csv_path, log_path):
    post = json.load(open(posterior_path))
    theta = np.asarray(post["cloud"]["theta"], dtype=float)
    chains = post.get("chains", 1)  # MCMC chains or SMC runs
    expected = equal_weight_sources(post["cloud"]["weights"], chains)
    draws = expected.shape[1]

    with netCDF4.Dataset(nc_path) as root:
        groups = sorted(root.groups)
    check(groups == ["constant_data", "observed_data", "posterior", "posterior_predictive", "sample_stats"],
          f"{name}: groups {groups}")
    opened = {g: xr.open_dataset(nc_path, group=g) for g in groups}
    for g, ds in opened.items():
        check(ds.attrs.get("inference_library") == "ssrfleet", f"{name}: {g} inference_library")
        check(bool(ds.attrs.get("inference_library_version")), f"{name}: {g} inference_library_version")
        check(ds.attrs.get("model_spec") == post["model"], f"{name}: {g} model_spec")
        check(ds.attrs.get("method") == post["method"], f"{name}: {g} method")
        try:
            datetime.datetime.fromisoformat(ds.attrs["created_at"])
        except (KeyError, ValueError):
            check(False, f"{name}: {g} created_at is not an ISO time")

    p = opened["posterior"]
    check(dict(p.sizes) == {"chain": chains, "draw": draws}, f"{name}: posterior sizes {dict(p.sizes)}")
    check(np.array_equal(p["chain"].values, np.arange(chains)), f"{name}: chain coordinate")
    check(np.array_equal(p["draw"].values, np.arange(draws)), f"{name}: draw coordinate")
    stats = opened["sample_stats"]
    check(np.array_equal(stats["source_index"].values, expected),
          f"{name}: source_index differs from numpy's systematic draws in "
          f"{int((stats['source_index'].values != expected).sum())} places")
    for h, var in enumerate(HYPER):
        check(p[var].dims == ("chain", "draw"), f"{name}: {var} dims {p[var].dims}")
        check(np.array_equal(p[var].values, theta[expected, h]), f"{name}: {var} values differ from the JSON's")
    if post["method"] == "smc":
        # One run: by chain; several runs: the pooled posterior's, as scalars.
        shape = (1,) if chains == 1 else ()
        evidence = stats["log_marginal_likelihood"].values
        weight_ess = stats["weight_ess"].values
        check(evidence.shape == shape and evidence.ravel().tolist() == [post["log_evidence"]], f"{name}: log evidence")
        check(weight_ess.shape == shape and weight_ess.ravel().tolist() == [post["weight_ess"]], f"{name}: weight ESS")
    if chains > 1:
        rhat = dict(zip(stats["parameter"].values.tolist(), stats["rhat"].values.tolist()))
        for var in HYPER:
            check(rhat[var] == post["convergence"][var]["rhat"], f"{name}: rhat of {var}")
        if post["method"] == "smc":
            ess = dict(zip(stats["parameter"].values.tolist(), stats["ess_equivalent"].values.tolist()))
            for var in HYPER:
                check(ess[var] == post["convergence"][var]["ess_equivalent"], f"{name}: ess_equivalent of {var}")

    with open(log_path) as f:
        lines = [line for line in f if not line.startswith("#")]  # the log's comment lines come first
    log = np.genfromtxt(lines, delimiter=",", names=True, dtype=None, encoding="utf-8")
    if_columns = [c for c in log.dtype.names if c.startswith("if_")]
    observed = np.column_stack([log[c] for c in if_columns])
    y = opened["observed_data"]["if"]
    check(y.dims == ("truck", "sensor"), f"{name}: observed if dims {y.dims}")
    check(np.array_equal(y.values, observed), f"{name}: observed if differs from the log")
    check(y["truck"].values.tolist() == log["truck_id"].tolist(), f"{name}: truck ids")
    check(y["sensor"].values.tolist() == [int(c[3:]) for c in if_columns], f"{name}: sensors numbered as the log's if_ columns")
    check(np.array_equal(opened["constant_data"]["speed_mps"].values, log["speed_mps"]), f"{name}: speeds")

    pp = opened["posterior_predictive"]["if"]
    n = min(100, draws)
    check(pp.dims == ("chain", "draw", "truck", "sensor"), f"{name}: posterior_predictive dims {pp.dims}")
    check(pp.shape == (chains, n, len(log), len(if_columns)), f"{name}: posterior_predictive shape {pp.shape}")
    check(np.array_equal(pp["draw"].values, np.floor((np.arange(n) + 0.5) * draws / n).astype(np.int64)),
          f"{name}: posterior_predictive draw numbers")
    check(pp["truck"].values.tolist() == log["truck_id"].tolist(), f"{name}: posterior_predictive trucks")
    # Each sensor's mean impact factor over the log's trucks, against its posterior predictive: one
    # replicate of the log per (chain, draw), whose trucks share that draw's θ, so the replicates'
    # means spread by the posterior's uncertainty and the log's sampling noise together. The log's
    # mean lies within 5 of their sds unless the model or the file is wrong (a posterior predictive
    # check; for a normal spread 16 sensors all pass with probability 1 - 1e-5).
    replicate_means = pp.values.mean(axis=2).reshape(-1, len(if_columns))
    error = replicate_means.std(axis=0, ddof=1)
    worst = np.max(np.abs(replicate_means.mean(axis=0) - observed.mean(axis=0)) / error)
    check(worst < 5.0, f"{name}: a sensor's mean is {worst:.1f} predictive sds from its posterior predictive's")

    rows = np.genfromtxt(csv_path, delimiter=",", names=True)
    check(list(rows.dtype.names) == ["chain", "draw"] + HYPER, f"{name}: CSV columns {rows.dtype.names}")
    check(np.array_equal(rows["chain"], np.repeat(np.arange(chains), draws)), f"{name}: CSV chain column")
    check(np.array_equal(rows["draw"], np.tile(np.arange(draws), chains)), f"{name}: CSV draw column")
    for var in HYPER:
        check(np.array_equal(rows[var], p[var].values.reshape(-1)), f"{name}: CSV {var} differs from the NetCDF")
    for ds in opened.values():
        ds.close()
    print(f"draws_reference: {name}: {chains} chain(s) x {draws} draws, {len(groups)} groups checked")


def check_reopen(first, second):
    """Opens and closes handles on two draws files in the order xarray's file cache may, reopening
    each while another handle on it is still open (libnetcdf 4.9.0 with HDF5 1.10 fails this on a
    file that holds variable-length strings, so the draws files hold none)."""
    try:
        a = netCDF4.Dataset(first)
        b = netCDF4.Dataset(first)
        a.close()
        c = netCDF4.Dataset(second)
        b.close()
        d = netCDF4.Dataset(second)
        c.close()
        e = netCDF4.Dataset(first)
        f = netCDF4.Dataset(second)
        for h in (d, e, f):
            h.close()
    except (OSError, RuntimeError) as error:
        check(False, f"reopening {os.path.basename(first)} and {os.path.basename(second)} in turn: {error}")


def main():
    if len(sys.argv) != 2:
        print("usage: draws_reference.py SSRFLEET_BINARY")
        return 2
    binary = sys.argv[1]
    with tempfile.TemporaryDirectory() as tmp:
        log = os.path.join(tmp, "log.csv")
        run(binary, "simulate", "--trucks", "10", "--seed", "3", "--out", log)
        fits = {
            "smc": ["--particles", "64", "--final-sweeps", "2"],
            "smc-runs": ["--particles", "32", "--final-sweeps", "1", "--runs", "2"],
            "mcmc": ["--method", "mcmc", "--chains", "2", "--iterations", "300", "--burn-in", "100", "--thin", "2"],
        }
        for name, options in fits.items():
            posterior = os.path.join(tmp, name + ".json")
            nc = os.path.join(tmp, name + ".nc")
            csv = os.path.join(tmp, name + ".csv")
            run(binary, "fit", log, *options, "--seed", "1", "-q", "--out", posterior, "--draws-out", nc)
            run(binary, "draws", posterior, "-q", "--out", csv)
            check_fit(name, posterior, nc, csv, log)
        check_reopen(os.path.join(tmp, "smc.nc"), os.path.join(tmp, "mcmc.nc"))
    if FAILURES:
        print(f"draws_reference: {len(FAILURES)} check(s) failed")
        return 1
    print("draws_reference: all checks passed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
