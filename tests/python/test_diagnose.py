"""diagnose gives the command's report (the JSON `diagnose --json` writes) for the same seed."""

import json

import pytest

import ssrfleet

OPTIONS = ["--particles", 32, "--draws", 10, "--candidates", "sensor_gain", "--seed", 3]


def without_times(value):
    """The report without its wall-clock times, which differ from run to run."""
    if isinstance(value, dict):
        return {k: without_times(v) for k, v in value.items() if not k.endswith("wall_s")}
    if isinstance(value, list):
        return [without_times(v) for v in value]
    return value


@pytest.fixture(scope="module")
def diagnosed(cli, tmp_path_factory):
    folder = tmp_path_factory.mktemp("diagnose")
    log = folder / "log.csv"
    cli("simulate", "--trucks", 10, "--seed", 4, "--effect", "sensor_gain:sensor=3,gain=1.15", "--out", log, "-q")
    report = folder / "report.json"
    cli("diagnose", log, *OPTIONS, "--no-plots", "--json", report, "--posterior-out", folder / "ends.json", "-q")
    with open(report) as f:
        return log, json.load(f), folder / "ends.json"


def test_diagnose_gives_the_commands_report(diagnosed, tmp_path):
    log, expected, ends = diagnosed
    written = tmp_path / "report.json"
    got = ssrfleet.diagnose(str(log), particles=32, draws=10, candidates="sensor_gain", seed=3, json=written,
                            posterior_out=tmp_path / "ends.json")
    assert without_times(dict(got)) == without_times(expected)
    with open(written) as f:
        assert without_times(json.load(f)) == without_times(expected)
    # The report's parts a user reads first, and the posterior it ends with (the command's file).
    assert [c["name"] for c in got["candidates"]] == ["sensor_gain"]
    assert got["model"] == expected["model"] and got["verdict"] == expected["verdict"]
    # The posterior is the chosen model's, a gain's sensor fixed where the checks point.
    assert got.posterior.info()["model"] == got["model"]
    assert got["model"] == ("sensor_gain:sensor=3" if got["effect"] == "sensor_gain" else "base")
    with open(ends) as a, open(tmp_path / "ends.json") as b:
        assert a.read() == b.read()


def test_diagnose_of_arrays_equals_diagnose_of_the_file(diagnosed, site):
    log, expected, _ = diagnosed
    from conftest import read_log_csv
    got = ssrfleet.diagnose(read_log_csv(log), site, particles=32, draws=10, candidates=["sensor_gain"], seed=3)
    assert without_times(dict(got)) == without_times(expected)


def test_diagnose_checks_its_arguments(diagnosed):
    log, _, _ = diagnosed
    with pytest.raises(ssrfleet.UsageError, match="particles"):
        ssrfleet.diagnose(str(log), particles=1)
    with pytest.raises(TypeError, match="candidates"):
        ssrfleet.diagnose(str(log), candidates=3)
    with pytest.raises(ssrfleet.UsageError, match="wind"):
        ssrfleet.diagnose(str(log), candidates="wind", particles=8)
