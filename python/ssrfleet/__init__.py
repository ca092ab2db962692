"""ssrfleet from Python: roads, sites, simulate, fit, posteriors, SSR prediction, diagnose and streams.

The compiled part (ssrfleet._core) runs the library and the commands' own code, so a seed gives the
numbers `ssrfleet simulate`, `ssrfleet fit` and `ssrfleet predict` give. This file checks the
arguments (a wrong shape, dtype or a NaN is a ValueError or TypeError naming the argument, the row
and the column) and converts to and from numpy arrays and pandas DataFrames. The long calls (fit,
diagnose, predict, damage, Stream.push) run with the GIL released and end within a second of Ctrl-C
with KeyboardInterrupt. docs/python.md is the guide.
"""

import json as _json
import math
import operator
import os
import re

import numpy as _np

from . import _core
from ._core import (BusyError, DataError, Error, IoError, MissingInputError, NumericalError, Road,
                    UsageError, __version__)

__all__ = ["road", "Site", "simulate", "fit", "read_posterior", "Posterior", "diagnose", "Diagnosis", "Stream",
           "Road", "Error", "UsageError",
           "DataError", "MissingInputError", "IoError", "BusyError", "NumericalError", "__version__"]

# The fleet distribution's defaults (the paper's Table 1), as `ssrfleet simulate` has them.
_FLEET_DEFAULTS = (("m2_mean", 4450.0), ("m2_sd", 445.0), ("k_mean", 500e3), ("k_sd", 50e3),
                   ("kt_mean", 1950e3), ("kt_sd", 195e3), ("speed_mean", 23.43), ("speed_sd", 2.08),
                   ("z_mean", 1.50), ("z_sd", 0.50))
_SEED_MAX = 2 ** 64 - 1
_INT_MAX = 2 ** 31 - 1
_LONG_MAX = 2 ** 63 - 1


# --- argument checks ---------------------------------------------------------------------------

def _text(name, value):
    if isinstance(value, os.PathLike):
        value = os.fspath(value)
    if not isinstance(value, str):
        raise TypeError(f"{name}: expected a string or path, not {type(value).__name__}")
    return value


def _integer(name, value, low, high):
    if isinstance(value, (bool, _np.bool_)):
        raise TypeError(f"{name}: expected a whole number, not a bool")
    try:
        value = operator.index(value)
    except TypeError:
        raise TypeError(f"{name}: expected a whole number, not {type(value).__name__}") from None
    if not low <= value <= high:
        raise UsageError(f"{name}={value}: must be between {low} and {high}")
    return value


def _real(name, value):
    if isinstance(value, (bool, _np.bool_)) or not isinstance(value, (int, float, _np.integer, _np.floating)):
        raise TypeError(f"{name}: expected a number, not {type(value).__name__}")
    value = float(value)
    if not math.isfinite(value):
        raise UsageError(f"{name}={value}: must be a finite number")
    return value


def _seed(value, name="seed"):
    return _integer(name, value, 0, _SEED_MAX)


def _numbers(name, value, ndim, finite=True):
    """A float64 array of `ndim` dimensions holding finite numbers only (finite=False: NaN and inf pass)."""
    try:
        array = _np.asarray(value)
    except Exception as e:  # a ragged list, an object numpy cannot take
        raise ValueError(f"{name}: not an array of numbers ({e})") from None
    if array.dtype.kind == "O":
        try:
            array = array.astype(_np.float64)
        except (TypeError, ValueError):
            raise TypeError(f"{name}: holds values that are not numbers") from None
    if array.dtype.kind not in "iuf":
        raise TypeError(f"{name}: dtype {array.dtype} is not a real number type")
    if array.ndim != ndim:
        raise ValueError(f"{name}: expected {ndim} dimension(s), got shape {array.shape}")
    array = _np.ascontiguousarray(array, dtype=_np.float64)
    bad = ~_np.isfinite(array)
    if finite and bad.any():
        where = tuple(int(i) for i in _np.argwhere(bad)[0])
        at = f"row {where[0]}" if ndim == 1 else f"row {where[0]}, column {where[1]}"
        raise ValueError(f"{name}: {at} is {array[where]!r}, not a finite number")
    return array


def _labels(name, value, n):
    if isinstance(value, (str, bytes)):
        raise TypeError(f"{name}: expected one label per truck, not a single string")
    try:
        items = list(value)
    except TypeError:
        raise TypeError(f"{name}: expected a sequence of labels, not {type(value).__name__}") from None
    if len(items) != n:
        raise ValueError(f"{name}: {len(items)} entries for {n} trucks")
    out = []
    for i, item in enumerate(items):
        if isinstance(item, (_np.str_, str)):
            text = str(item)
        elif isinstance(item, (int, _np.integer)) and not isinstance(item, (bool, _np.bool_)):
            text = str(int(item))
        else:
            raise TypeError(f"{name}: row {i} is {type(item).__name__}, not a string")
        if not text or any(c in text for c in ',"\r\n'):
            raise ValueError(f"{name}: row {i} is {text!r}: a label must be non-empty, without commas, quotes or "
                             "line breaks")
        out.append(text)
    return out


def _log_arrays(log, finite=True, name="log"):
    """A log given as arrays: a dict like simulate()'s, or a DataFrame with the log file's columns.
    finite=False lets NaN and inf through (a stream quarantines such a record, as it does in a file)."""
    if hasattr(log, "columns") and hasattr(log, "to_numpy"):  # a pandas DataFrame
        columns = [str(c) for c in log.columns]
        sensors = sorted((int(c[3:]) for c in columns if c.startswith("if_") and c[3:].isdigit()))
        if not sensors or sensors != list(range(1, len(sensors) + 1)):
            raise ValueError(f"{name}: a DataFrame needs the columns if_1..if_M (M the site's sensors)")
        get = {c: log[c].to_numpy() for c in ("truck_id", "speed_mps", "sprung_mass_kg", "time_s", "class")
               if c in columns}
        get["impact_factor"] = log[[f"if_{j}" for j in sensors]].to_numpy()
    elif isinstance(log, dict):
        get = log
    else:
        raise TypeError(f"{name}: expected a path, a dict of arrays or a DataFrame, not {type(log).__name__}")
    for key in ("truck_id", "speed_mps", "sprung_mass_kg", "impact_factor"):
        if key not in get:
            raise ValueError(f"{name}: missing {key!r}")
    impact = _numbers(f"{name}['impact_factor']", get["impact_factor"], 2, finite)
    n = impact.shape[0]
    if n == 0:
        raise ValueError(f"{name}: no trucks")
    truck_id = _labels(f"{name}['truck_id']", get["truck_id"], n)
    arrays = {}
    for key in ("speed_mps", "sprung_mass_kg", "time_s"):
        if key in get and get[key] is not None:
            arrays[key] = _numbers(f"{name}[{key!r}]", get[key], 1, finite)
            if arrays[key].shape[0] != n:
                raise ValueError(f"{name}[{key!r}]: {arrays[key].shape[0]} rows for {n} trucks (impact_factor's rows)")
    classes = None
    if "class" in get and get["class"] is not None:
        classes = _labels(f"{name}['class']", get["class"], n)
    return (truck_id, arrays.get("time_s"), arrays["speed_mps"], arrays["sprung_mass_kg"], impact, classes)


# --- roads and sites ---------------------------------------------------------------------------

_preset_roads = {}


def road(name_or_path="AS1"):
    """A road: a preset (AS1, AS2, AS3) or a road file (road CSV or OpenCRG), as --road takes it."""
    name = _text("name_or_path", name_or_path)
    if name in ("AS1", "AS2", "AS3"):  # presets are made, not read: made once per process
        if name not in _preset_roads:
            _preset_roads[name] = _core._road(name)
        return _preset_roads[name]
    return _core._road(name)


class Site:
    """A WIM site: a road and a sensor array, with the vehicle constants the quarter-car model uses.

    The defaults are the commands' (--sensors 76,1.5,16 --envelopment 0.3 --m1 420 --cb 20e3 --ct 0).
    sensors: "FIRST,SPACING,COUNT" or a tuple (first_m, spacing_m, count).
    """

    def __init__(self, road="AS1", sensors="76,1.5,16", envelopment=0.3, m1=420.0, cb=20e3, ct=0.0):
        surface = road if isinstance(road, Road) else globals()["road"](road)
        if isinstance(sensors, tuple):
            if len(sensors) != 3:
                raise UsageError("sensors: expected (first_m, spacing_m, count)")
            first, spacing = _real("sensors[0]", sensors[0]), _real("sensors[1]", sensors[1])
            count = _integer("sensors[2]", sensors[2], 1, _INT_MAX)
            sensors = f"{first!r},{spacing!r},{count}"
        sensors = _text("sensors", sensors)
        self._handle = _core._make_site(surface, sensors, _real("envelopment", envelopment), _real("m1", m1),
                                        _real("cb", cb), _real("ct", ct))

    road_name = property(lambda self: self._handle.road_name)
    sensors = property(lambda self: self._handle.sensors, doc="the number of sensors")
    sensor_positions_m = property(lambda self: self._handle.sensor_positions_m)
    lateral_range_m = property(lambda self: self._handle.lateral_range_m)
    fingerprint = property(lambda self: self._handle.fingerprint)

    def __repr__(self):
        h = self._handle
        return (f"<ssrfleet.Site road {h.road_name}, sensors {h.sensor_spec}, envelopment {h.envelopment_m}, "
                f"m1 {h.m1_kg}, cb {h.cb_nspm}, ct {h.ct_nspm}>")


_default_site = None


def _site(site):
    global _default_site
    if site is None:
        if _default_site is None:
            _default_site = Site()
        return _default_site
    if not isinstance(site, Site):
        raise TypeError(f"site: expected an ssrfleet.Site, not {type(site).__name__}")
    return site


# --- simulate ----------------------------------------------------------------------------------

def _frame(columns):
    try:
        import pandas
    except ImportError:
        raise ImportError("as_frame=True needs pandas (apt-get install python3-pandas)") from None
    return pandas.DataFrame(columns)


def simulate(site=None, trucks=100, seed=1, noise=0.02, model=None, as_frame=False, **fleet):
    """Simulate a WIM log, as `ssrfleet simulate` (the same numbers for the same seed).

    fleet: the fleet distribution (paper Table 1), any of m2_mean, m2_sd, k_mean, k_sd, kt_mean, kt_sd,
    speed_mean, speed_sd, z_mean, z_sd. Returns a dict of numpy arrays (truck_id, speed_mps,
    sprung_mass_kg, impact_factor of shape (trucks, sensors), lift_offs), or with as_frame=True a
    pandas DataFrame with the log file's columns (truck_id, speed_mps, sprung_mass_kg, if_1..if_M).
    """
    site = _site(site)
    known = dict(_FLEET_DEFAULTS)
    for key in fleet:
        if key not in known:
            raise TypeError(f"simulate: unknown argument {key!r} (fleet parameters: {', '.join(known)})")
    values = [_real(key, fleet.get(key, default)) for key, default in _FLEET_DEFAULTS]
    model = "" if model is None else _text("model", model)
    out = _core._simulate(site._handle, _integer("trucks", trucks, 1, 10_000_000), _seed(seed),
                          _real("noise", noise), model, values)
    out["truck_id"] = _np.array(out["truck_id"], dtype=str)
    if not as_frame:
        return out
    columns = {"truck_id": out["truck_id"]}
    if "time_s" in out:
        columns["time_s"] = out["time_s"]
    columns["speed_mps"] = out["speed_mps"]
    columns["sprung_mass_kg"] = out["sprung_mass_kg"]
    for j in range(out["impact_factor"].shape[1]):
        columns[f"if_{j + 1}"] = out["impact_factor"][:, j]
    return _frame(columns)


# --- fit and the posterior ---------------------------------------------------------------------

class Posterior:
    """A fitted posterior (fit) or one read from a posterior file (read_posterior)."""

    def __init__(self, handle, site=None):
        self._handle = handle
        self._site = site

    @property
    def vehicle_classes(self):
        """The vehicle classes' labels ([""] for a log without a class column)."""
        return self._handle.labels

    def info(self, vehicle_class=None):
        """method, model, chains, trucks_seen, particles, weight_ess, min_ess, log_evidence, road_name, ..."""
        return self._handle.info(vehicle_class)

    def summary(self, vehicle_class=None):
        """Per parameter: mean, sd, q025, q975 (the posterior file's summary)."""
        return self._handle.summary(vehicle_class)

    def draws(self, vehicle_class=None):
        """(draws, names): equal-weight draws as an array (chain, draw, parameter), and the parameters' names."""
        return self._handle.draws(vehicle_class)

    def convergence(self, vehicle_class=None):
        """Per parameter over several chains (MCMC) or runs (SMC): rhat, ess_bulk, ess_tail, ess_equivalent,
        mcse_mean, mcse_q05, mcse_q95. Empty for a single chain or run."""
        return self._handle.convergence(vehicle_class)

    def to_json(self, path):
        """Write the posterior file, the very bytes `ssrfleet fit --out` writes for the same fit."""
        self._handle.to_json(_text("path", path))

    def to_netcdf(self, path, vehicle_class=None):
        """Write the draws as NetCDF4 in ArviZ's layout (docs/draws.md); path must end in .nc."""
        path = _text("path", path)
        if not path.endswith(".nc"):
            raise UsageError(f"to_netcdf: '{path}' must end in .nc")
        self._handle.write_draws(path, vehicle_class)

    def to_csv(self, path, vehicle_class=None):
        """Write the equal-weight draws as CSV, one row a draw (docs/draws.md); path must end in .csv."""
        path = _text("path", path)
        if not path.endswith(".csv"):
            raise UsageError(f"to_csv: '{path}' must end in .csv")
        self._handle.write_draws(path, vehicle_class)

    def predict(self, positions=None, draws=200, trucks_per_draw=100, seed=1, site=None, new_road=False,
                fixed_traffic=False, vehicle_class=None, mix=None, out=None, as_frame=False):
        """The SSR prediction, as `ssrfleet predict`: per position the mean IF, the 95 % prediction limits
        (lower95, upper95) and the 95 % band of the mean pattern (mean_lower95, mean_upper95).

        positions: metres along the road, strictly increasing (None: the sensors). site: where to
        predict (default: the fitted site, or the default Site() for a posterior read from a file).
        out: also write the prediction CSV there (the command's bytes)."""
        if site is None:
            site = self._site
        site = _site(site)
        if positions is None:
            positions = []
        else:
            positions = _numbers("positions", positions, 1).tolist()
        result = self._handle.predict(site._handle, positions, _integer("draws", draws, 2, _INT_MAX),
                                      _integer("trucks_per_draw", trucks_per_draw, 1, _INT_MAX), _seed(seed),
                                      bool(fixed_traffic), bool(new_road),
                                      None if vehicle_class is None else _text("vehicle_class", vehicle_class),
                                      "" if mix is None else _mix_text(mix),
                                      None if out is None else _text("out", out))
        return _frame(result) if as_frame else result

    def damage(self, positions=None, powers=(), threshold=1.1, draws=200, trucks_per_draw=100, seed=1, site=None,
               new_road=False, fixed_traffic=False, vehicle_class=None, mix=None, out=None):
        """The damage along the road, as `ssrfleet damage`: per position the DLC, the damage
        amplification a_n = E[IF^n] for n = 1, 4 and any further `powers` (keys a1, a1_q025, a1_q975,
        a4, ...), hot_spot (a_4's 95th percentile above `threshold`), ESAL per million trucks with its
        95 % limits; and static_esal_per_million, lift_off_passes, simulated_passes. Arguments as predict;
        out also writes the damage CSV (the command's bytes)."""
        if site is None:
            site = self._site
        site = _site(site)
        positions = [] if positions is None else _numbers("positions", positions, 1).tolist()
        powers = _numbers("powers", list(powers) if isinstance(powers, tuple) else powers, 1).tolist()
        return self._handle.damage(site._handle, positions, powers, _real("threshold", threshold),
                                   _integer("draws", draws, 2, _INT_MAX),
                                   _integer("trucks_per_draw", trucks_per_draw, 1, _INT_MAX), _seed(seed),
                                   bool(fixed_traffic), bool(new_road),
                                   None if vehicle_class is None else _text("vehicle_class", vehicle_class),
                                   "" if mix is None else _mix_text(mix), None if out is None else _text("out", out))

    def __repr__(self):
        labels = self.vehicle_classes
        info = self._handle.info(labels[0]) if len(labels) == 1 else None
        if info is None:
            return f"<ssrfleet.Posterior classes {labels}>"
        return (f"<ssrfleet.Posterior {info['method']}, model {info['model']}, {info['trucks_seen']} trucks, "
                f"{info['chains']} chain(s)>")


def _mix_text(mix):
    if isinstance(mix, dict):
        parts = []
        for label, share in mix.items():
            parts.append(f"{_text('mix label', label)}={_real(f'mix[{label!r}]', share)!r}")
        return ",".join(parts)
    return _text("mix", mix)


_FIT_INTS = {"particles": (2, 10_000_000), "runs": (1, 64), "chains": (1, _INT_MAX), "iterations": (1, _LONG_MAX),
             "burn_in": (0, _LONG_MAX), "thin": (1, _LONG_MAX), "threads": (0, _INT_MAX),
             "final_sweeps": (0, _INT_MAX), "max_sweeps": (1, _INT_MAX), "older_sweeps": (0, _INT_MAX)}


def fit(log=None, site=None, method="smc", model="base", seed=1, particles=None, runs=None, chains=None,
        iterations=None, burn_in=None, thin=None, threads=0, core=None, final_sweeps=None, cess=None,
        max_sweeps=None, older_sweeps=None, fhwa_classes=False, progress=False, checkpoint=None,
        checkpoint_every_s=None, checkpoint_every_trucks=None, sites=None):
    """Fit a WIM log, as `ssrfleet fit` (the same posterior, to the byte, for the same seed).

    log: a path to a log file, or arrays: a dict like simulate()'s output or a DataFrame with the log
    file's columns. An option left at None keeps the command's default (particles 1024; MCMC:
    chains 4, iterations 20000, burn_in 5000, thin 10). threads=0: all cores (the result does not
    depend on it). progress=True: the command's progress lines on standard error.
    checkpoint: a folder for the SMC's checkpoints (fit --checkpoint): a fit stopped (Ctrl-C, a crash)
    resumes there when called again with the same arguments, every checkpoint_every_s seconds
    (default 600) or checkpoint_every_trucks trucks.
    sites: a site manifest (fit --sites): one fleet posterior from all its sites' logs (log=None; the
    site argument gives only the vehicle constants, each site its own road and sensors).
    """
    site = _site(site)
    options = {"model": _text("model", model), "fhwa_classes": bool(fhwa_classes), "progress": bool(progress)}
    given = {"particles": particles, "runs": runs, "chains": chains, "iterations": iterations, "burn_in": burn_in,
             "thin": thin, "threads": threads, "final_sweeps": final_sweeps, "max_sweeps": max_sweeps,
             "older_sweeps": older_sweeps}
    for key, value in given.items():
        if value is not None:
            low, high = _FIT_INTS[key]
            options[key] = _integer(key, value, low, high)
    if cess is not None:
        options["cess"] = _real("cess", cess)
    if core is not None:
        options["core"] = _text("core", core)
    if checkpoint is not None:
        options["checkpoint"] = _text("checkpoint", checkpoint)
    if checkpoint_every_s is not None:
        options["checkpoint_every_s"] = _real("checkpoint_every_s", checkpoint_every_s)
    if checkpoint_every_trucks is not None:
        options["checkpoint_every_trucks"] = _integer("checkpoint_every_trucks", checkpoint_every_trucks, 0, _LONG_MAX)
    method = _text("method", method)
    seed = _seed(seed)
    if sites is not None:
        if log is not None:
            raise UsageError("give log or sites, not both (a manifest names each site's log)")
        import tempfile
        options["sites"] = _text("sites", sites)
        with tempfile.TemporaryDirectory(prefix="ssrfleet-sites-") as folder:
            options["sites_out"] = os.path.join(folder, "posterior.json")
            return Posterior(_core._fit(site._handle, None, None, method, seed, options), None)
    if log is None:
        raise UsageError("fit needs a log (a path or arrays), or sites=MANIFEST")
    if isinstance(log, (str, os.PathLike)):
        handle = _core._fit(site._handle, _text("log", log), None, method, seed, options)
    else:
        arrays = _log_arrays(log)
        try:
            handle = _core._fit(site._handle, None, arrays, method, seed, options)
        except DataError as e:
            e.row = e.line - 2 if e.line >= 2 else None  # the log's row (header: line 1)
            raise
    return Posterior(handle, site)


def read_posterior(path):
    """A posterior file that fit writes (or a stream's state directory)."""
    return Posterior(_core._read_posterior(_text("path", path)))


# --- diagnose ----------------------------------------------------------------------------------

class Diagnosis(dict):
    """diagnose()'s report: the JSON report `ssrfleet diagnose --json` writes, as a dict (checks_before,
    checks_after, candidates with their log_bayes_factor and heldout_gain, effect, model, parameters
    with their intervals, verdict, ...), with the posterior diagnose ends with as .posterior."""

    def __init__(self, report, posterior):
        super().__init__(report)
        self.posterior = posterior

    def __repr__(self):
        return f"<ssrfleet.Diagnosis model {self.get('model')!r}: {self.get('verdict')}>"


_DIAGNOSE_INTS = {"particles": (2, 10_000_000), "threads": (0, _INT_MAX), "max_effects": (0, _INT_MAX),
                  "draws": (1, _INT_MAX)}


def diagnose(log, site=None, seed=1, particles=None, threads=0, alpha=None, min_log_bf=None, holdout=None,
             candidates=None, max_effects=None, shortlist_only=False, refit_from_prior=False, draws=None,
             json=None, out=None, posterior_out=None, plots=False, progress=False):
    """Diagnose a WIM log, as `ssrfleet diagnose` (the same report for the same seed): run the posterior
    predictive checks, refit with each candidate effect, and keep the one the evidence and the held-out
    skill support. Returns a Diagnosis (a dict of the JSON report, with .posterior).

    log: a path or arrays, as fit takes it. An option left at None keeps the command's default
    (particles 512, alpha 0.01, min_log_bf 3, holdout 0.25, draws 200, max_effects 3, every candidate).
    candidates: effect names (a list or "a,b"). json / posterior_out: also write the command's JSON
    report / posterior file there; out: the command's report folder (plots=True runs gnuplot there).
    """
    site = _site(site)
    options = {"shortlist_only": bool(shortlist_only), "refit_from_prior": bool(refit_from_prior),
               "progress": bool(progress)}
    for key, value in (("particles", particles), ("threads", threads), ("max_effects", max_effects),
                       ("draws", draws)):
        if value is not None:
            low, high = _DIAGNOSE_INTS[key]
            options[key] = _integer(key, value, low, high)
    for key, value in (("alpha", alpha), ("min_log_bf", min_log_bf), ("holdout", holdout)):
        if value is not None:
            options[key] = _real(key, value)
    if candidates is not None:
        if isinstance(candidates, (str, os.PathLike)):
            candidates = [c for c in _text("candidates", candidates).split(",") if c]
        try:
            candidates = list(candidates)
        except TypeError:
            raise TypeError(f"candidates: expected effect names, not {type(candidates).__name__}") from None
        options["candidates"] = [_text(f"candidates[{i}]", c) for i, c in enumerate(candidates)]
    paths = [None if p is None else _text(name, p) for name, p in
             (("json", json), ("out", out), ("posterior_out", posterior_out))]
    seed = _seed(seed)
    if isinstance(log, (str, os.PathLike)):
        report, handle = _core._diagnose(site._handle, _text("log", log), None, seed, options, *paths, bool(plots))
    else:
        arrays = _log_arrays(log)
        try:
            report, handle = _core._diagnose(site._handle, None, arrays, seed, options, *paths, bool(plots))
        except DataError as e:
            e.row = e.line - 2 if e.line >= 2 else None
            raise
    return Diagnosis(_json.loads(report), Posterior(handle, site))


# --- streams -----------------------------------------------------------------------------------

_REJECT = re.compile(r"^# line (\d+): ([^:]*): (.*)$")
_pushes = 0  # arrays pushed by this process: each push's input is named apart (see Stream.push)


def _lock_holder(state_dir):
    """The process id the state's lock file names (its holder wrote it), or None."""
    try:
        with open(os.path.join(state_dir, "lock")) as f:
            return int(f.read().strip())
    except (OSError, ValueError):
        return None


def _new_rejects(path, offset):
    """The records rejects.csv gained after `offset` bytes: line, field, reason and the record's text."""
    try:
        with open(path, "rb") as f:
            f.seek(offset)
            text = f.read().decode("utf-8", "replace")
    except FileNotFoundError:
        return []
    out, lines = [], text.split("\n")
    for i, line in enumerate(lines):
        m = _REJECT.match(line)
        if m and i + 1 < len(lines):
            out.append({"line": int(m.group(1)), "field": m.group(2), "reason": m.group(3), "record": lines[i + 1]})
    return out


class Stream:
    """A stream over a state directory, as `ssrfleet stream --state DIR`: records pushed are absorbed
    into the fleet posterior one by one, the state saved after each; bad records are quarantined in
    DIR/rejects.csv. The state is the command's: either resumes the other, to the same posterior.

    One writer per state: a state another process (or another Stream) holds raises BusyError, with
    the attributes state_dir and pid. close() (or leaving a `with` block) releases it. The options
    are the command's (--model, --seed, --particles, --threads, --classes, --fhwa-classes,
    --tables-in-memory); a resume must give the seed and model the state was made with.
    """

    def __init__(self, state_dir, site=None, model="base", seed=1, particles=1024, threads=0, classes=None, fhwa_classes=False, tables_in_memory=False, progress=False):
        self._site = _site(site)
        self.state_dir = _text("state_dir", state_dir)
        options = {"model": _text("model", model), "particles": _integer("particles", particles, 2, 10_000_000),
                   "threads": _integer("threads", threads, 0, _INT_MAX),
                   "fhwa_classes": bool(fhwa_classes),
                   "tables_in_memory": bool(tables_in_memory), "progress": bool(progress)}
        if classes is not None:
            if isinstance(classes, str):
                classes = [c for c in classes.split(",")]
            options["classes"] = [_text(f"classes[{i}]", c) for i, c in enumerate(classes)]
            if not options["classes"]:
                raise UsageError("classes: no class labels")
        try:
            self._handle = _core._open_stream(self._site._handle, self.state_dir, _seed(seed), options)
        except BusyError as e:
            e.state_dir = self.state_dir
            e.pid = _lock_holder(self.state_dir)
            raise

    @property
    def resumed(self):
        """Whether the state held a checkpoint when the Stream opened it."""
        return self._handle.resumed

    @property
    def warning(self):
        """What to know about the posterior's quality ("" if nothing)."""
        return self._handle.warning

    @property
    def closed(self):
        return self._handle.closed

    def push(self, records):
        """Absorb records: a path to a WIM log, or arrays as fit takes them (simulate()'s dict, a
        DataFrame). Returns a dict: absorbed, rejected, skipped (already in the posterior: a truck id
        absorbed before), total_absorbed, and rejects, one dict per quarantined record (line, field,
        reason, record: its text; for arrays also row, counted from 0).

        A bad record (a NaN, a value out of range, a repeated truck id) is quarantined as the command
        quarantines it, not raised; arrays of a wrong shape or type raise ValueError / TypeError.
        Ctrl-C ends the push after the record in hand, its state saved, and raises KeyboardInterrupt;
        pushing the same records again goes on where it stopped."""
        rejects_path = os.path.join(self.state_dir, "rejects.csv")
        offset = os.path.getsize(rejects_path) if os.path.exists(rejects_path) else 0
        if isinstance(records, (str, os.PathLike)):
            counts = self._handle.push_file(_text("records", records))
            counts["rejects"] = _new_rejects(rejects_path, offset)
            return counts
        global _pushes
        arrays = _log_arrays(records, finite=False, name="records")
        _pushes += 1
        # The input's name goes into the checkpoint; a resume skips lines by number only on an input
        # of the same name, which arrays must never match: each push is named apart.
        source = f"<arrays pushed by process {os.getpid()}, push {_pushes}>"
        counts = self._handle.push_arrays(arrays, self._site._handle, source)
        rejects = _new_rejects(rejects_path, offset)
        for r in rejects:
            r["row"] = r["line"] - 2
        counts["rejects"] = rejects
        return counts

    def posterior(self):
        """The posterior now (the state's posterior.json), as fit returns it."""
        if not os.path.exists(os.path.join(self.state_dir, "posterior.json")):
            raise UsageError(f"the stream in '{self.state_dir}' has absorbed no truck yet: no posterior")
        return Posterior(_core._read_posterior(self.state_dir), self._site)

    def predict(self, positions=None, **options):
        """The SSR prediction from the posterior now: Posterior.predict's arguments."""
        return self.posterior().predict(positions, **options)

    def close(self):
        """Release the state (its lock): another process may stream into it then."""
        self._handle.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False

    def __repr__(self):
        return f"<ssrfleet.Stream on {self.state_dir!r}{' (closed)' if self.closed else ''}>"
