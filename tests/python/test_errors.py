"""Errors arrive as Python exceptions: the library's classes with their attributes, and bad arrays as a
ValueError or TypeError naming the argument, the row and the column."""

import numpy as np
import pytest

import ssrfleet


def test_the_exception_classes_derive_from_the_builtin_ones():
    assert issubclass(ssrfleet.DataError, ValueError) and issubclass(ssrfleet.DataError, ssrfleet.Error)
    assert issubclass(ssrfleet.UsageError, ValueError)
    assert issubclass(ssrfleet.MissingInputError, FileNotFoundError)
    assert issubclass(ssrfleet.IoError, OSError)
    assert issubclass(ssrfleet.BusyError, ssrfleet.Error)


def test_a_bad_log_file_is_a_data_error_with_file_line_and_field(tmp_path):
    path = tmp_path / "bad.csv"
    rows = ["truck_id,speed_mps,sprung_mass_kg," + ",".join(f"if_{j}" for j in range(1, 17))]
    rows.append("T1,23.0,4400," + ",".join(["1.0"] * 16))
    rows.append("T2,-5.0,4400," + ",".join(["1.0"] * 16))  # a negative speed on line 3
    path.write_text("\n".join(rows) + "\n")
    with pytest.raises(ssrfleet.DataError) as caught:
        ssrfleet.fit(str(path), particles=8)
    e = caught.value
    assert e.file == str(path) and e.line == 3 and e.field == "speed_mps"
    assert e.reason and str(path) in str(e)


def test_a_log_with_the_wrong_sensor_count_names_the_column():
    log = ssrfleet.simulate(trucks=3, seed=1)
    log["impact_factor"] = log["impact_factor"][:, :5]
    with pytest.raises(ssrfleet.DataError) as caught:
        ssrfleet.fit(log, particles=8)
    assert caught.value.field == "if_5" and "16" in str(caught.value)


def test_an_array_value_the_reader_refuses_names_its_row():
    log = ssrfleet.simulate(trucks=4, seed=1)
    log["sprung_mass_kg"] = log["sprung_mass_kg"].copy()
    log["sprung_mass_kg"][2] = 1e7  # beyond the log's limits
    with pytest.raises(ssrfleet.DataError) as caught:
        ssrfleet.fit(log, particles=8)
    assert caught.value.field == "sprung_mass_kg" and caught.value.row == 2 and caught.value.line == 4


def test_nan_names_the_argument_row_and_column():
    log = ssrfleet.simulate(trucks=4, seed=1)
    log["impact_factor"] = log["impact_factor"].copy()
    log["impact_factor"][1, 7] = np.nan
    with pytest.raises(ValueError, match=r"impact_factor.*row 1, column 7"):
        ssrfleet.fit(log, particles=8)


def test_wrong_dtype_and_shape():
    log = ssrfleet.simulate(trucks=4, seed=1)
    with pytest.raises(TypeError, match="speed_mps"):
        ssrfleet.fit(dict(log, speed_mps=np.array(["a", "b", "c", "d"])), particles=8)
    with pytest.raises(ValueError, match="sprung_mass_kg.*3 rows"):
        ssrfleet.fit(dict(log, sprung_mass_kg=log["sprung_mass_kg"][:3]), particles=8)
    with pytest.raises(ValueError, match="impact_factor.*dimension"):
        ssrfleet.fit(dict(log, impact_factor=log["impact_factor"][0]), particles=8)
    with pytest.raises(TypeError, match="log"):
        ssrfleet.fit(42)


def test_usage_errors():
    log = ssrfleet.simulate(trucks=3, seed=1)
    with pytest.raises(ssrfleet.UsageError, match="particles"):
        ssrfleet.fit(log, particles=1)
    with pytest.raises(ssrfleet.UsageError, match="smc or mcmc"):
        ssrfleet.fit(log, method="gibbs", particles=8)
    with pytest.raises(ssrfleet.UsageError, match="chains"):
        ssrfleet.fit(log, chains=2, particles=8)
    with pytest.raises(ssrfleet.UsageError):
        ssrfleet.simulate(trucks=0)
    with pytest.raises(ssrfleet.UsageError, match="sensors"):
        ssrfleet.Site(sensors="76,1.5")
    with pytest.raises(TypeError):
        ssrfleet.simulate(trucks=2.5)
    with pytest.raises(TypeError, match="unknown argument"):
        ssrfleet.simulate(trucks=2, k_meen=1.0)


def test_missing_files():
    with pytest.raises(ssrfleet.MissingInputError):
        ssrfleet.read_posterior("/nonexistent/posterior.json")
    with pytest.raises(FileNotFoundError):
        ssrfleet.fit("/nonexistent/log.csv")
    with pytest.raises(ssrfleet.MissingInputError):
        ssrfleet.road("/nonexistent/road.csv")
