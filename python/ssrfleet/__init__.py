"""ssrfleet from Python: roads, sites, simulate, fit, posteriors and SSR prediction.

The compiled part (ssrfleet._core) runs the library and the commands' own code, so a seed gives the
numbers `ssrfleet simulate`, `ssrfleet fit` and `ssrfleet predict` give. This file checks the
arguments (a wrong shape, dtype or a NaN is a ValueError or TypeError naming the argument, the row
and the column) and converts to and from numpy arrays and pandas DataFrames. docs/python.md is the
guide.
"""

import math
import operator
import os

import numpy as _np

from . import _core
from ._core import (BusyError, DataError, Error, IoError, MissingInputError, NumericalError, Road,
                    UsageError, __version__)

__all__ = ["road", "Site", "simulate", "fit", "read_posterior", "Posterior", "Road", "Error", "UsageError",
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


def _numbers(name, value, ndim):
    """A float64 array of `ndim` dimensions holding finite numbers only."""
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
    if bad.any():
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


def _log_arrays(log):
    """A log given as arrays: a dict like simulate()'s, or a DataFrame with the log file's columns."""
    if hasattr(log, "columns") and hasattr(log, "to_numpy"):  # a pandas DataFrame
        columns = [str(c) for c in log.columns]
        sensors = sorted((int(c[3:]) for c in columns if c.startswith("if_") and c[3:].isdigit()))
        if not sensors or sensors != list(range(1, len(sensors) + 1)):
            raise ValueError("log: a DataFrame needs the columns if_1..if_M (M the site's sensors)")
        get = {c: log[c].to_numpy() for c in ("truck_id", "speed_mps", "sprung_mass_kg", "time_s", "class")
               if c in columns}
        get["impact_factor"] = log[[f"if_{j}" for j in sensors]].to_numpy()
    elif isinstance(log, dict):
        get = log
    else:
        raise TypeError(f"log: expected a path, a dict of arrays or a DataFrame, not {type(log).__name__}")
    for key in ("truck_id", "speed_mps", "sprung_mass_kg", "impact_factor"):
        if key not in get:
            raise ValueError(f"log: missing {key!r}")
    impact = _numbers("log['impact_factor']", get["impact_factor"], 2)
    n = impact.shape[0]
    if n == 0:
        raise ValueError("log: no trucks")
    truck_id = _labels("log['truck_id']", get["truck_id"], n)
    arrays = {}
    for key in ("speed_mps", "sprung_mass_kg", "time_s"):
        if key in get and get[key] is not None:
            arrays[key] = _numbers(f"log[{key!r}]", get[key], 1)
            if arrays[key].shape[0] != n:
                raise ValueError(f"log[{key!r}]: {arrays[key].shape[0]} rows for {n} trucks (impact_factor's rows)")
    classes = None
    if "class" in get and get["class"] is not None:
        classes = _labels("log['class']", get["class"], n)
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
             "final_sweeps": (0, _INT_MAX), "max_sweeps": (1, _INT_MAX), "older_sweeps": (0, _INT_MAX),
             "window": (0, _LONG_MAX)}


def fit(log, site=None, method="smc", model="base", seed=1, particles=None, runs=None, chains=None,
        iterations=None, burn_in=None, thin=None, threads=0, core=None, final_sweeps=None, cess=None,
        max_sweeps=None, older_sweeps=None, window=None, fhwa_classes=False, progress=False):
    """Fit a WIM log, as `ssrfleet fit` (the same posterior, to the byte, for the same seed).

    log: a path to a log file, or arrays: a dict like simulate()'s output or a DataFrame with the log
    file's columns. An option left at None keeps the command's default (particles 1024; MCMC:
    chains 4, iterations 20000, burn_in 5000, thin 10). threads=0: all cores (the result does not
    depend on it). progress=True: the command's progress lines on standard error.
    """
    site = _site(site)
    options = {"model": _text("model", model), "fhwa_classes": bool(fhwa_classes), "progress": bool(progress)}
    given = {"particles": particles, "runs": runs, "chains": chains, "iterations": iterations, "burn_in": burn_in,
             "thin": thin, "threads": threads, "final_sweeps": final_sweeps, "max_sweeps": max_sweeps,
             "older_sweeps": older_sweeps, "window": window}
    for key, value in given.items():
        if value is not None:
            low, high = _FIT_INTS[key]
            options[key] = _integer(key, value, low, high)
    if cess is not None:
        options["cess"] = _real("cess", cess)
    if core is not None:
        options["core"] = _text("core", core)
    method = _text("method", method)
    seed = _seed(seed)
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
