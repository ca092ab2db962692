"""Random shapes, values and dtypes thrown at simulate, fit, predict, damage, Stream.push and diagnose:
each call succeeds or raises a ValueError or TypeError (ssrfleet's own classes derive from them),
never crashes the interpreter. Seeded, so a failure is repeatable; a few hundred cases in a few
seconds."""

import numpy as np
import pytest

import ssrfleet

CASES = 150


def random_value(rng):
    """Something an argument might wrongly be given."""
    kind = rng.integers(0, 12)
    if kind == 0:
        return None
    if kind == 1:
        return [-1, 0, 1, 2, 3, 2 ** 64, -(2 ** 70), 2 ** 80][int(rng.integers(0, 8))]
    if kind == 2:
        return float(rng.choice([np.nan, np.inf, -np.inf, 0.0, -1.5, 1e300, 2.5]))
    if kind == 3:
        return ["", "x", "3", "base", "AS1", "1,2", "-1", "A=1"][int(rng.integers(0, 8))]
    if kind == 4:
        return bool(rng.integers(0, 2))
    if kind == 5:
        return random_array(rng)
    if kind == 6:
        return [random_value(rng)] if rng.random() < 0.5 else (1, 2, 3)
    if kind == 7:
        return {"a": 1}
    if kind == 8:
        return complex(1, 2)
    if kind == 9:
        return object()
    if kind == 10:
        return np.float32(rng.normal())
    return int(rng.integers(1, 6))


def random_array(rng, like=None):
    ndim = int(rng.integers(0, 4)) if like is None or rng.random() < 0.3 else like.ndim
    shape = tuple(int(rng.integers(0, 5)) for _ in range(ndim))
    if like is not None and rng.random() < 0.5:
        shape = like.shape
    dtype = rng.choice(["float64", "float32", "int64", "bool", "complex", "str", "object", "uint8"])
    values = rng.normal(1.0, 2.0, size=shape)
    special = rng.random(size=shape) < 0.1
    values = np.where(special, rng.choice([np.nan, np.inf, -1e9, 0.0, 1e9]), values)
    if dtype == "str":
        return values.astype(str)
    if dtype == "object":
        a = values.astype(object)
        if a.size and rng.random() < 0.5:
            a.flat[0] = "x"
        return a
    if dtype in ("int64", "uint8", "bool"):
        return np.nan_to_num(values, nan=0.0, posinf=0.0, neginf=0.0).astype(dtype)
    return values.astype(dtype)


def call(f, *args, **kwargs):
    try:
        return f(*args, **kwargs)
    except (ValueError, TypeError):
        return None


@pytest.fixture(scope="module")
def base_log():
    return ssrfleet.simulate(trucks=3, seed=1)


@pytest.fixture(scope="module")
def posterior(base_log):
    return ssrfleet.fit(base_log, particles=8, final_sweeps=0, seed=1)


def test_simulate_survives_random_arguments():
    rng = np.random.default_rng(20261128)
    for _ in range(CASES):
        kwargs = {}
        for key in ("trucks", "seed", "noise", "model", "k_mean", "speed_sd"):
            if rng.random() < 0.15:
                kwargs[key] = random_value(rng)
        if "trucks" not in kwargs or rng.random() < 0.5:
            kwargs["trucks"] = int(rng.integers(1, 4))  # keep the successes small
        result = call(ssrfleet.simulate, **kwargs)
        if result is not None:
            assert result["impact_factor"].shape == (kwargs["trucks"], 16)


def test_fit_survives_random_logs_and_options(base_log):
    rng = np.random.default_rng(1128)
    succeeded = 0
    for _ in range(CASES * 2 // 3):  # a third of them fit: the slowest entry point
        log = dict(base_log)
        if rng.random() < 0.8:  # one column changed
            key = ["truck_id", "speed_mps", "sprung_mass_kg", "impact_factor", "time_s", "class"][int(rng.integers(0, 6))]
            r = rng.random()
            if r < 0.15:
                log.pop(key, None)
            elif r < 0.45:  # values edited in place: the reader's limits, NaN, infinities
                numeric = key if key in ("speed_mps", "sprung_mass_kg", "impact_factor") else "speed_mps"
                key = numeric
                like = np.array(base_log[numeric], dtype=float, copy=True)
                like.flat[int(rng.integers(0, like.size))] = [np.nan, np.inf, -1.0, 0.0, 1e7, 5.0, 1e-3][int(rng.integers(0, 7))]
                log[key] = like
            elif r < 0.85:
                log[key] = random_array(rng, like=base_log.get(key) if key in base_log
                                        and isinstance(base_log[key], np.ndarray) else None)
            else:
                log[key] = random_value(rng)
        options = {"particles": 8, "final_sweeps": 0}
        if rng.random() < 0.3:
            options[str(rng.choice(["particles", "seed", "method", "model", "threads", "runs", "chains", "cess",
                                    "core", "older_sweeps"]))] = random_value(rng)
        if rng.random() < 0.3:
            options["particles"] = 8
        if rng.random() < 0.1:
            log = random_value(rng)
        if isinstance(log, str) and log:  # a path: leave files out of this test
            continue
        if isinstance(options.get("method"), str) and options["method"] == "mcmc":
            options.update(iterations=20, burn_in=5, thin=1, chains=2)
        if isinstance(options.get("runs"), int) and options["runs"] > 2:
            options["runs"] = 2
        if call(ssrfleet.fit, log, **options) is not None:
            succeeded += 1
    assert succeeded > 0  # the generator does reach a fit that runs


def test_predict_survives_random_arguments(posterior):
    rng = np.random.default_rng(281126)
    for _ in range(CASES):
        kwargs = {"draws": 2, "trucks_per_draw": 1}
        for key in ("positions", "draws", "trucks_per_draw", "seed", "vehicle_class", "mix", "new_road"):
            if rng.random() < 0.12:
                kwargs[key] = random_value(rng)
        if isinstance(kwargs["draws"], int) and kwargs["draws"] > 4:
            kwargs["draws"] = 4
        if isinstance(kwargs["trucks_per_draw"], int) and kwargs["trucks_per_draw"] > 4:
            kwargs["trucks_per_draw"] = 4
        if rng.random() < 0.3:
            kwargs["positions"] = np.sort(rng.uniform(0.0, 400.0, size=int(rng.integers(0, 6))))
        result = call(posterior.predict, **kwargs)
        if result is not None:
            assert result["mean_if"].shape == result["position_m"].shape
        if rng.random() < 0.3:
            kwargs.pop("mix", None)
            kwargs["powers"] = random_value(rng) if rng.random() < 0.5 else [float(rng.uniform(-1.0, 8.0))]
            kwargs["threshold"] = random_value(rng) if rng.random() < 0.3 else 1.1
            result = call(posterior.damage, **kwargs)
            if result is not None:
                assert result["a4"].shape == result["position_m"].shape


def random_log(rng, base_log):
    """base_log with one column changed (dropped, edited, replaced), or something else altogether."""
    log = dict(base_log)
    key = ["truck_id", "speed_mps", "sprung_mass_kg", "impact_factor", "time_s", "class"][int(rng.integers(0, 6))]
    r = rng.random()
    if r < 0.15:
        log.pop(key, None)
    elif r < 0.45:
        numeric = key if key in ("speed_mps", "sprung_mass_kg", "impact_factor") else "impact_factor"
        like = np.array(base_log[numeric], dtype=float, copy=True)
        like.flat[int(rng.integers(0, like.size))] = [np.nan, np.inf, -1.0, 0.0, 1e7, 5.0, 1e-3][int(rng.integers(0, 7))]
        log[numeric] = like
    elif r < 0.85:
        log[key] = random_array(rng, like=base_log.get(key) if key in base_log
                                and isinstance(base_log[key], np.ndarray) else None)
    else:
        log[key] = random_value(rng)
    if rng.random() < 0.1:
        log = random_value(rng)
    return log


def test_stream_push_survives_random_records(base_log, tmp_path):
    """A bad value in a record is quarantined (as the command does), a bad shape or type raised; the
    stream's counts always add up, and it goes on taking records."""
    rng = np.random.default_rng(112826)
    with ssrfleet.Stream(tmp_path / "state", particles=8, seed=1) as stream:
        for i in range(CASES // 5):
            log = random_log(rng, base_log)
            if isinstance(log, str) and log:  # a path: leave files out of this test
                continue
            if isinstance(log, dict) and isinstance(log.get("truck_id"), np.ndarray) and log["truck_id"].dtype.kind == "U":
                log["truck_id"] = np.char.add(log["truck_id"], f"-{i}")  # new trucks each time, so some are absorbed
            counts = call(stream.push, log)
            if counts is not None:
                assert counts["absorbed"] + counts["rejected"] + counts["skipped"] >= 1
                assert counts["rejected"] == len(counts["rejects"])
        total = stream.push({k: base_log[k] for k in ("truck_id", "speed_mps", "sprung_mass_kg", "impact_factor")})
        assert total["total_absorbed"] >= 3


def test_diagnose_survives_random_arguments():
    rng = np.random.default_rng(2811)
    diagnosable = ssrfleet.simulate(trucks=8, seed=1)  # diagnose needs 8 trucks
    succeeded = 0
    for _ in range(CASES // 10):  # a successful call refits: the slowest entry point
        log = random_log(rng, diagnosable) if rng.random() < 0.7 else diagnosable
        if isinstance(log, str) and log:
            continue
        options = {"particles": 8, "draws": 10, "candidates": ["sensor_gain"], "max_effects": 1}
        for key in ("particles", "seed", "alpha", "min_log_bf", "holdout", "candidates", "max_effects", "draws",
                    "threads"):
            if rng.random() < 0.12:
                options[key] = random_value(rng)
        if isinstance(options["particles"], int) and options["particles"] > 8:
            options["particles"] = 8
        if isinstance(options["draws"], int) and options["draws"] > 10:
            options["draws"] = 10
        if options["candidates"] is None:  # every effect: too slow for this test
            options["candidates"] = ["sensor_gain"]
        result = call(ssrfleet.diagnose, log, **options)
        if result is not None:
            assert "verdict" in result and result.posterior.info()["trucks_seen"] >= 1
            succeeded += 1
    assert succeeded > 0
