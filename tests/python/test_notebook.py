"""examples/notebook.py, the researcher's example, run as a script: it ends cleanly within a minute
and leaves what it says it writes, and what it wrote holds together (the draws against the
posterior file, the SSR prediction against the data it was fitted to)."""

import os
import subprocess
import sys
import time

import numpy as np
import pytest

import ssrfleet

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def test_the_notebook_writes_its_plots_and_draws_and_they_agree(tmp_path):
    import xarray as xr
    start = time.monotonic()
    done = subprocess.run([sys.executable, os.path.join(REPO, "examples", "notebook.py"), str(tmp_path)],
                          capture_output=True, text=True, timeout=300)
    seconds = time.monotonic() - start
    assert done.returncode == 0, done.stderr
    assert seconds < 60.0, f"the example took {seconds:.1f} s"
    for name in ("ssr.png", "trace.png"):
        data = (tmp_path / name).read_bytes()
        assert data.startswith(PNG_SIGNATURE), f"{name} is not a PNG"
        assert len(data) > 10_000, f"{name} is only {len(data)} bytes"

    posterior = ssrfleet.read_posterior(str(tmp_path / "posterior.json"))
    assert posterior.info()["chains"] == 4  # the 4 SMC runs
    with xr.open_dataset(tmp_path / "draws.nc", group="posterior") as draws, \
            xr.open_dataset(tmp_path / "draws.nc", group="observed_data") as observed:
        assert dict(draws.sizes) == {"chain": 4, "draw": draws.sizes["draw"]}
        y = observed["if"].values
        assert y.shape == (40, 16)
        # The equal-weight draws estimate the weighted posterior mean to well within the posterior
        # sd over the square root of their number (systematic resampling adds less than iid draws).
        k = draws["K"].values.ravel()
        summary = posterior.summary()["K"]
        assert abs(k.mean() - summary["mean"]) < 3.0 * summary["sd"] / np.sqrt(k.size)
    # The SSR pattern at the sensors follows the log's mean impact factor per sensor: the pattern
    # varies by about 0.045 from sensor to sensor, the means of 40 trucks by about 0.01 about it, so
    # their correlation is near 0.97; 0.9 fails only when the prediction has lost the road.
    ssr = posterior.predict(draws=50, trucks_per_draw=50, seed=1)
    r = np.corrcoef(ssr["mean_if"], y.mean(axis=0))[0, 1]
    assert r > 0.9, f"correlation {r:.3f} between the predicted and the observed pattern"
