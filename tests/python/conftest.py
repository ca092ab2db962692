"""Shared pieces of the Python module's tests: the command to compare with, and small logs.

The module comes from PYTHONPATH (CTest sets it to the build's python/ folder) and the command from
SSRFLEET_CLI (CTest: the ssrfleet it built); run by hand:
  PYTHONPATH=build/python SSRFLEET_CLI=build/ssrfleet python3 -m pytest tests/python
"""

import os
import subprocess

import numpy as np
import pytest

import ssrfleet

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


@pytest.fixture(scope="session")
def cli():
    path = os.environ.get("SSRFLEET_CLI", os.path.join(REPO, "build", "ssrfleet"))
    if not os.path.exists(path):
        pytest.fail(f"the ssrfleet command is not at {path}: build it, or set SSRFLEET_CLI")

    def run(*args):
        done = subprocess.run([path, *map(str, args)], capture_output=True, text=True)
        if done.returncode != 0:
            raise AssertionError(f"ssrfleet {' '.join(map(str, args))} failed ({done.returncode}): {done.stderr}")
        return done.stdout

    return run


@pytest.fixture(scope="session")
def site():
    return ssrfleet.Site()


@pytest.fixture(scope="session")
def small_log(site, tmp_path_factory, cli):
    """Eight trucks on the default site, seed 5: the command's log file and the module's arrays."""
    path = tmp_path_factory.mktemp("log") / "log.csv"
    cli("simulate", "--trucks", 8, "--seed", 5, "--out", path, "-q")
    return path, ssrfleet.simulate(site, trucks=8, seed=5)


def read_log_csv(path):
    """A WIM log file as the module's arrays (comment lines skipped)."""
    with open(path) as f:
        lines = [line.rstrip("\n") for line in f if not line.startswith("#")]
    header = lines[0].split(",")
    rows = [line.split(",") for line in lines[1:]]
    column = {name: [r[i] for r in rows] for i, name in enumerate(header)}
    sensors = [name for name in header if name.startswith("if_")]
    return {
        "truck_id": np.array(column["truck_id"]),
        "speed_mps": np.array(column["speed_mps"], dtype=float),
        "sprung_mass_kg": np.array(column["sprung_mass_kg"], dtype=float),
        "impact_factor": np.array([[float(r[header.index(s)]) for s in sensors] for r in rows]),
    }
