"""Ctrl-C: a long call (fit, predict, diagnose, Stream.push) ends with KeyboardInterrupt within a
second or so of the signal, and the module works as before afterwards."""

import _thread
import filecmp
import os
import signal
import threading
import time

import pytest

import ssrfleet

DELAY_S = 0.5  # the signal comes this long after the call starts
LIMIT_S = 1.5  # and the call must be over this long after it


def interrupted(call, send):
    """Runs call() with a SIGINT sent after DELAY_S by `send` (a real signal, or interrupt_main); returns
    the seconds from the signal to the KeyboardInterrupt, which the call must raise."""
    sent = []

    def fire():
        sent.append(time.monotonic())
        send()

    timer = threading.Timer(DELAY_S, fire)
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            call()
        return time.monotonic() - sent[0]
    finally:
        timer.cancel()
        timer.join()


def by_signal():
    os.kill(os.getpid(), signal.SIGINT)


@pytest.fixture(scope="module")
def long_log():
    """Enough trucks that the calls below take many seconds unless stopped."""
    return ssrfleet.simulate(trucks=300, seed=7)


def test_fit_stops_within_a_second_and_the_module_goes_on(long_log, small_log, tmp_path):
    _, arrays = small_log
    before = tmp_path / "before.json"
    ssrfleet.fit(arrays, particles=16, final_sweeps=0, seed=3).to_json(before)
    after_s = interrupted(lambda: ssrfleet.fit(long_log, particles=4096, seed=1), by_signal)
    assert after_s < LIMIT_S
    after = tmp_path / "after.json"
    ssrfleet.fit(arrays, particles=16, final_sweeps=0, seed=3).to_json(after)  # the same bits as before the stop
    assert filecmp.cmp(before, after, shallow=False)


def test_mcmc_chains_stop_within_a_second(long_log):
    after_s = interrupted(lambda: ssrfleet.fit(long_log, method="mcmc", chains=2, iterations=10_000_000, seed=1),
                          _thread.interrupt_main)
    assert after_s < LIMIT_S


def test_predict_stops_within_a_second(small_log):
    _, arrays = small_log
    posterior = ssrfleet.fit(arrays, particles=16, final_sweeps=0, seed=3)
    # One class's simulated passes run to their end: many draws of few trucks keep each pass short.
    after_s = interrupted(lambda: [posterior.predict(draws=200, trucks_per_draw=100, seed=s) for s in range(1000)],
                          by_signal)
    assert after_s < LIMIT_S
    assert posterior.predict(draws=4, trucks_per_draw=5)["mean_if"].shape == (16,)


def test_diagnose_stops_within_a_second(long_log):
    after_s = interrupted(lambda: ssrfleet.diagnose(long_log, particles=2048, seed=1), by_signal)
    assert after_s < LIMIT_S


def test_a_stream_push_stops_after_the_record_in_hand_and_goes_on_to_the_same_bits(long_log, tmp_path):
    n = 24  # each truck's state is saved: tens of ms a truck, whatever the particles
    records = {k: long_log[k][:n] for k in ("truck_id", "speed_mps", "sprung_mass_kg", "impact_factor")}
    with ssrfleet.Stream(tmp_path / "whole", particles=16, seed=3) as s:
        s.push(records)
    with ssrfleet.Stream(tmp_path / "stopped", particles=16, seed=3) as s:
        after_s = interrupted(lambda: s.push(records), by_signal)
        assert after_s < LIMIT_S
        held = s.posterior().info()["trucks_seen"]
        assert 0 < held < n  # stopped part way, its state saved
        counts = s.push(records)  # the same Stream goes on
        assert (counts["skipped"], counts["absorbed"], counts["total_absorbed"]) == (held, n - held, n)
    assert filecmp.cmp(tmp_path / "whole" / "posterior.json", tmp_path / "stopped" / "posterior.json", shallow=False)
