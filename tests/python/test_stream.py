"""Stream: the command's state directory, to the posterior bit; resuming each other; quarantined
records; one writer per state (BusyError)."""

import filecmp
import os
import signal
import subprocess
import time

import numpy as np
import pytest

import ssrfleet

TRUCKS, PARTICLES, SEED = 12, 32, 2


def rows(arrays, begin, end):
    """Rows [begin, end) of simulate()'s arrays, as a log of their own."""
    return {k: v[begin:end] for k, v in arrays.items() if k in ("truck_id", "speed_mps", "sprung_mass_kg",
                                                                  "impact_factor")}


@pytest.fixture(scope="module")
def streamed(cli, tmp_path_factory):
    """A simulated log, and the command's stream of it into a fresh state."""
    folder = tmp_path_factory.mktemp("stream")
    log = folder / "log.csv"
    cli("simulate", "--trucks", TRUCKS, "--seed", 4, "--out", log, "-q")
    state = folder / "cli_state"
    cli("stream", "--state", state, "--input", log, "--particles", PARTICLES, "--seed", SEED, "-q")
    return log, state, ssrfleet.simulate(trucks=TRUCKS, seed=4)


def same_posterior(a, b):
    return filecmp.cmp(os.path.join(a, "posterior.json"), os.path.join(b, "posterior.json"), shallow=False)


def test_pushing_arrays_gives_the_commands_posterior_file(streamed, tmp_path):
    _, expected, arrays = streamed
    with ssrfleet.Stream(tmp_path / "state", particles=PARTICLES, seed=SEED) as s:
        counts = s.push(arrays)
        assert not s.resumed
    assert (counts["absorbed"], counts["rejected"], counts["skipped"], counts["total_absorbed"]) == (TRUCKS, 0, 0, TRUCKS)
    assert counts["rejects"] == []
    assert same_posterior(tmp_path / "state", expected)


def test_pushing_a_file_in_two_streams_resumes_to_the_same_bits(streamed, tmp_path):
    log, expected, arrays = streamed
    state = tmp_path / "state"
    with ssrfleet.Stream(state, particles=PARTICLES, seed=SEED) as s:
        assert s.push(rows(arrays, 0, 5))["absorbed"] == 5
    with ssrfleet.Stream(state, particles=PARTICLES, seed=SEED) as s:
        assert s.resumed
        counts = s.push(str(log))  # the first five are already in the posterior
    assert (counts["absorbed"], counts["skipped"], counts["total_absorbed"]) == (TRUCKS - 5, 5, TRUCKS)
    assert same_posterior(state, expected)


def test_the_command_and_a_stream_resume_each_other(streamed, cli, tmp_path):
    log, expected, arrays = streamed
    # The command first, on the first rows; the module then goes on with the rest as arrays.
    head = tmp_path / "head.csv"
    with open(log) as f:
        lines = f.readlines()
    data = [i for i, line in enumerate(lines) if not line.startswith("#")]
    with open(head, "w") as f:
        f.writelines(lines[:data[0] + 1 + 6])  # comments, header and six records
    state = tmp_path / "state"
    cli("stream", "--state", state, "--input", head, "--particles", PARTICLES, "--seed", SEED, "-q")
    with ssrfleet.Stream(state, particles=PARTICLES, seed=SEED) as s:
        assert s.resumed
        assert s.push(rows(arrays, 6, 11))["total_absorbed"] == 11
    # And the command finishes what the module left.
    cli("stream", "--state", state, "--input", log, "--particles", PARTICLES, "--seed", SEED, "-q")
    assert same_posterior(state, expected)
    # The posterior object is the file's, and predicts as Posterior.predict does.
    with ssrfleet.Stream(state, particles=PARTICLES, seed=SEED) as s:
        posterior = s.posterior()
        assert posterior.info()["trucks_seen"] == TRUCKS
        a = s.predict(draws=4, trucks_per_draw=5, seed=9)
        b = ssrfleet.read_posterior(str(expected)).predict(draws=4, trucks_per_draw=5, seed=9)
        for key in a:
            assert np.array_equal(a[key], b[key]), key


def test_bad_records_are_quarantined_with_their_row_and_field(streamed, tmp_path):
    _, _, arrays = streamed
    bad = rows(arrays, 0, 8)
    bad["impact_factor"] = bad["impact_factor"].copy()
    bad["impact_factor"][2, 5] = np.nan
    bad["sprung_mass_kg"] = bad["sprung_mass_kg"].copy()
    bad["sprung_mass_kg"][6] = -1.0
    state = tmp_path / "state"
    with ssrfleet.Stream(state, particles=PARTICLES, seed=SEED) as s:
        counts = s.push(bad)
        assert (counts["absorbed"], counts["rejected"]) == (6, 2)
        assert [(r["row"], r["line"], r["field"]) for r in counts["rejects"]] == [(2, 4, "if_6"), (6, 8, "sprung_mass_kg")]
        assert counts["rejects"][0]["record"].startswith(str(arrays["truck_id"][2]) + ",")
        # Pushed again: the good ones are already in, the bad ones quarantined again.
        again = s.push(bad)
        assert (again["absorbed"], again["skipped"], again["rejected"], again["total_absorbed"]) == (0, 6, 2, 6)
    with open(state / "rejects.csv") as f:
        text = f.read()
    assert text.count("# line 4: if_6: ") == 2 and text.count("# line 8: sprung_mass_kg: ") == 2


def test_a_second_stream_on_a_state_in_use_is_busy(tmp_path, streamed):
    _, _, arrays = streamed
    state = tmp_path / "state"
    first = ssrfleet.Stream(state, particles=PARTICLES, seed=SEED)
    with pytest.raises(ssrfleet.BusyError) as e:
        ssrfleet.Stream(state, particles=PARTICLES, seed=SEED)
    assert isinstance(e.value, RuntimeError)
    assert e.value.pid == os.getpid() and e.value.state_dir == str(state)
    assert str(state) in str(e.value) and f"process {os.getpid()}" in str(e.value)
    first.close()
    assert first.closed
    with pytest.raises(ssrfleet.UsageError, match="closed"):
        first.push(rows(arrays, 0, 2))
    with ssrfleet.Stream(state, particles=PARTICLES, seed=SEED) as second:  # free again
        assert second.push(rows(arrays, 0, 2))["absorbed"] == 2


def test_a_state_the_command_streams_into_is_busy(streamed, cli, tmp_path):
    log, _, _ = streamed
    state = tmp_path / "state"
    command = os.environ["SSRFLEET_CLI"]
    holder = subprocess.Popen([command, "stream", "--state", str(state), "--input", str(log), "--follow",
                               "--particles", "16", "-q"], stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 20
        while _holder(state) != holder.pid or not (state / "posterior.json").exists():  # a truck in: a state to resume
            assert holder.poll() is None, holder.stderr.read()
            assert time.monotonic() < deadline, "the command never took the lock and absorbed a truck"
            time.sleep(0.05)
        with pytest.raises(ssrfleet.BusyError) as e:
            ssrfleet.Stream(state, particles=16)
        assert e.value.pid == holder.pid and e.value.state_dir == str(state)
        assert f"process {holder.pid}" in str(e.value)
    finally:
        holder.send_signal(signal.SIGTERM)  # the command ends after the record in hand, its state saved
        holder.wait(timeout=30)
    with ssrfleet.Stream(state, particles=16) as s:
        assert s.resumed


def _holder(state):
    try:
        with open(state / "lock") as f:
            return int(f.read().strip())
    except (OSError, ValueError):
        return None


def test_stream_arguments_are_checked(tmp_path):
    with pytest.raises(TypeError, match="particles"):
        ssrfleet.Stream(tmp_path / "s", particles="many")
    with pytest.raises(ssrfleet.UsageError, match="particles"):
        ssrfleet.Stream(tmp_path / "s", particles=1)
    with pytest.raises(ssrfleet.UsageError, match="no truck"):
        with ssrfleet.Stream(tmp_path / "s2") as s:
            s.posterior()
