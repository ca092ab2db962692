#!/usr/bin/env python3
"""A researcher's analysis with ssrfleet, as a script (cells marked `# %%` open as a notebook in
editors that know them).

    PYTHONPATH=build/python python3 examples/notebook.py [OUTDIR]

simulates a WIM site, fits the fleet posterior two ways (the SMC as independent runs, the batch
MCMC as chains), plots the SSR pattern with its 95 % limits and the MCMC chains' traces with
matplotlib, and opens the draws with xarray. It writes ssr.png, trace.png, draws.nc and
posterior.json to OUTDIR (default: examples-out/) and prints what a reader checks: the R-hat of
the runs and of the chains, and the SSR peak. About half a minute on 2 cores.
"""
# %% Set-up
import os
import sys

import matplotlib

matplotlib.use("Agg")  # files, not windows: the script runs unattended
import matplotlib.pyplot as plt
import numpy as np
import xarray as xr

import ssrfleet

out = sys.argv[1] if len(sys.argv) > 1 else "examples-out"
os.makedirs(out, exist_ok=True)

# %% A site and a simulated log: the paper's Table 1 fleet over the AS1 road, 16 sensors from 76 m.
site = ssrfleet.Site(road="AS1")
log = ssrfleet.simulate(site, trucks=40, seed=1)
print(f"simulated {len(log['truck_id'])} trucks x {log['impact_factor'].shape[1]} sensors; "
      f"mean impact factor {log['impact_factor'].mean():.4f}")

# %% The SMC, as 4 independent runs: their agreement is the posterior's Monte Carlo error.
smc = ssrfleet.fit(log, site=site, seed=2, particles=256, runs=4)
print("SMC posterior (4 runs):")
for name, s in smc.summary().items():
    c = smc.convergence()[name]
    print(f"  {name:9s} mean {s['mean']:12.6g}  sd {s['sd']:10.4g}  R-hat {c['rhat']:.4f}  "
          f"equivalent ESS {c['ess_equivalent']:8.0f}")
smc.to_json(os.path.join(out, "posterior.json"))

# %% The SSR pattern along the sensor array, every 5 cm, with the 95 % limits of one truck's impact
# factor and the 95 % band of the fleet's mean.
positions = np.arange(76.0, 98.55, 0.05)
ssr = smc.predict(positions=positions, draws=100, trucks_per_draw=50, seed=3)
fig, ax = plt.subplots(figsize=(9, 4))
ax.fill_between(ssr["position_m"], ssr["lower95"], ssr["upper95"], color="0.85", label="95 % of trucks")
ax.fill_between(ssr["position_m"], ssr["mean_lower95"], ssr["mean_upper95"], color="tab:blue", alpha=0.35,
                label="95 % band of the mean")
ax.plot(ssr["position_m"], ssr["mean_if"], color="tab:blue", label="mean impact factor")
ax.plot(site.sensor_positions_m, log["impact_factor"].mean(axis=0), "o", color="black", ms=4,
        label="observed mean at the sensors")
ax.set_xlabel("position along the road (m)")
ax.set_ylabel("impact factor")
ax.set_title("SSR pattern on AS1 (40 simulated trucks)")
ax.legend(loc="upper right", fontsize=8)
fig.tight_layout()
fig.savefig(os.path.join(out, "ssr.png"), dpi=110)
peak = int(np.argmax(ssr["mean_if"]))
print(f"SSR peak: mean impact factor {ssr['mean_if'][peak]:.4f} at {ssr['position_m'][peak]:.2f} m")

# %% The batch MCMC as 2 chains from over-dispersed starts: their traces, and R-hat.
mcmc = ssrfleet.fit(log, site=site, method="mcmc", seed=4, chains=2, iterations=1500, burn_in=500, thin=2)
draws, names = mcmc.draws()  # (chain, draw, parameter)
fig, axes = plt.subplots(len(names), 1, figsize=(9, 1.6 * len(names)), sharex=True)
for p, (name, ax) in enumerate(zip(names, axes)):
    for chain in range(draws.shape[0]):
        ax.plot(draws[chain, :, p], lw=0.6, label=f"chain {chain}")
    ax.set_ylabel(name, fontsize=8)
axes[0].legend(loc="upper right", fontsize=7)
axes[-1].set_xlabel("kept sweep")
fig.suptitle("batch MCMC: traces of the fleet hyperparameters")
fig.tight_layout()
fig.savefig(os.path.join(out, "trace.png"), dpi=90)
rhat = {name: c["rhat"] for name, c in mcmc.convergence().items()}
print("MCMC R-hat: " + ", ".join(f"{name} {r:.3f}" for name, r in rhat.items()))
if max(rhat.values()) > 1.01:
    # 1,500 sweeps a chain keep this example quick; the command's default is 20,000.
    print("  (R-hat above 1.01: these short chains disagree; fit with more iterations before trusting them)")

# %% The draws as ArviZ reads them: NetCDF4 groups, opened with xarray.
nc = os.path.join(out, "draws.nc")
smc.to_netcdf(nc)
posterior = xr.open_dataset(nc, group="posterior")
observed = xr.open_dataset(nc, group="observed_data")
print(f"draws.nc: posterior {dict(posterior.sizes)}, observed_data if {observed['if'].shape}")
print(f"  K from the draws: {float(posterior['K'].mean()):.6g} N/m "
      f"(posterior file: {smc.summary()['K']['mean']:.6g})")
posterior.close()
observed.close()
print(f"wrote {out}/ssr.png, {out}/trace.png, {out}/draws.nc, {out}/posterior.json")
