"""simulate gives the command's numbers for the same seed, as arrays or a DataFrame."""

import numpy as np
import pytest

import ssrfleet
from conftest import read_log_csv


def test_simulate_matches_the_command_to_the_bit(small_log):
    path, arrays = small_log
    expected = read_log_csv(path)  # the command writes full precision: every number reads back to its bits
    assert list(arrays["truck_id"]) == list(expected["truck_id"])
    for key in ("speed_mps", "sprung_mass_kg", "impact_factor"):
        assert arrays[key].dtype == np.float64
        assert np.array_equal(arrays[key], expected[key]), key
    assert arrays["impact_factor"].shape == (8, 16)


def test_simulate_with_other_options_matches_the_command(cli, tmp_path):
    site = ssrfleet.Site(road="AS2", sensors=(70.0, 2.0, 6))
    path = tmp_path / "log.csv"
    cli("simulate", "--road", "AS2", "--sensors", "70,2,6", "--trucks", 5, "--seed", 11, "--noise", 0.05,
        "--k-mean", 450e3, "--out", path, "-q")
    arrays = ssrfleet.simulate(site, trucks=5, seed=11, noise=0.05, k_mean=450e3)
    expected = read_log_csv(path)
    assert np.array_equal(arrays["impact_factor"], expected["impact_factor"])
    assert np.array_equal(arrays["speed_mps"], expected["speed_mps"])


def test_simulate_as_frame_has_the_log_files_columns():
    pytest.importorskip("pandas")
    frame = ssrfleet.simulate(trucks=4, seed=2, as_frame=True)
    assert list(frame.columns)[:3] == ["truck_id", "speed_mps", "sprung_mass_kg"]
    assert [c for c in frame.columns if c.startswith("if_")] == [f"if_{j}" for j in range(1, 17)]
    assert frame.shape == (4, 19)
    arrays = ssrfleet.simulate(trucks=4, seed=2)
    assert np.array_equal(frame["if_3"].to_numpy(), arrays["impact_factor"][:, 2])


def test_site_reports_its_sensors():
    site = ssrfleet.Site(sensors="76,1.5,4")
    assert site.sensors == 4
    assert np.allclose(site.sensor_positions_m, [76.0, 77.5, 79.0, 80.5])
    assert site.road_name == "AS1"
    assert ssrfleet.road("AS1").name == "AS1"
