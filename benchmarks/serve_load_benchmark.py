#!/usr/bin/env python3
"""ssrfleet serve under load beside the stream it shows (docs/serve.md, "Load").

One run, two streams of the same simulated log into fresh states, side by side and taking turns:
  alone   a stream by itself;
  served  the same stream with `ssrfleet serve` following it and CLIENTS clients, each polling
          as the page does (the summary every second; on a new checkpoint the SSR, the
          history and the rejects; the damage every 3 s), each from its own loopback address
          (127.0.0.2, 127.0.0.3, ...), so each has its own rate-limit bucket as a browser would.
They take turns of PHASE seconds (the other one stopped with SIGSTOP; in the alone turns the server
is stopped too and the clients wait), so a change in the machine's other load hits both alike
instead of whichever ran second. The clients poll for at least MINUTES minutes of served turns.
Criteria (--check: exit 1 if one fails):
  - no failed request (anything but 200 or 202, or no answer);
  - the server's resident memory grows by at most 5 MB after its first minute (the median of the last
    minute's samples, taken every 5 s, against the second minute's);
  - the served stream's trucks/s is at least 90 % of the stream alone's, each its trucks absorbed
    in its own turns over the length of those turns (the first SKIP trucks of each left out: the
    tables' rebuilds at the start).

usage: serve_load_benchmark.py --ssrfleet BIN [--trucks 10000] [--clients 50] [--minutes 10]
                               [--phase 20] [--particles 1024] [--seed 1] [--out DIR] [--check]"""

import argparse
import http.client
import json
import os
import re
import shutil
import signal
import sqlite3
import subprocess
import sys
import tempfile
import threading
import time


def trucks_in(state):
    """The trucks of the state's last checkpoint (0 before the first)."""
    path = os.path.join(state, "history.sqlite")
    if not os.path.exists(path):
        return 0
    db = sqlite3.connect("file:%s?mode=ro" % path, uri=True, timeout=10)
    try:
        row = db.execute("SELECT max(trucks) FROM reports").fetchone()
    except sqlite3.OperationalError:  # the stream has not made its tables yet
        row = None
    db.close()
    return row[0] if row and row[0] is not None else 0


def rss_kb(pid):
    with open("/proc/%d/status" % pid) as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    return 0


class Client(threading.Thread):
    """One page: the requests app.js makes, from its own source address."""

    def __init__(self, port, address, stop, go, offset_s, damage_every_s=3.0):
        super().__init__(daemon=True)
        self.port, self.address, self.stop, self.go, self.damage_every_s = port, address, stop, go, damage_every_s
        self.offset_s = offset_s  # where in each second this page polls: pages opened at different times
        self.idle = threading.Event()  # set while waiting for its turn (no request in flight)
        self.requests = 0
        self.failures = []
        self.latencies = []

    def get(self, target, parse=False):
        """The answer's JSON when parse is set; otherwise only its status counts: what a browser does
        with the body is the browser's cost, on another machine, not the server's."""
        start = time.time()
        try:
            c = http.client.HTTPConnection("127.0.0.1", self.port, timeout=10, source_address=(self.address, 0))
            c.request("GET", target)
            r = c.getresponse()
            body = r.read()
            c.close()
            self.requests += 1
            self.latencies.append(time.time() - start)
            if r.status not in (200, 202):
                self.failures.append("%s %d %s" % (target, r.status, body[:200]))
                return None
            return json.loads(body) if parse else True
        except Exception as e:  # noqa: BLE001 -- every failure counts, whatever its kind
            self.requests += 1
            self.failures.append("%s %s" % (target, e))
            return None

    def run(self):
        seq, damage_at = None, 0.0
        next_tick = time.time()
        while not self.stop.is_set():
            if not self.go.is_set():
                self.idle.set()
                self.go.wait()
                self.idle.clear()
                next_tick = time.time() + self.offset_s
                continue
            s = self.get("/api/summary", parse=True)
            if s and s.get("checkpoint") and s["checkpoint"]["seq"] != seq:
                seq = s["checkpoint"]["seq"]
                self.get("/api/ssr")
                self.get("/api/history?points=300")
                self.get("/api/rejects?limit=10")
            if seq is not None and time.time() - damage_at >= self.damage_every_s:
                damage_at = time.time()
                self.get("/api/damage")
            next_tick += 1.0
            self.stop.wait(max(0.0, next_tick - time.time()))


def run_stream(ssrfleet, log, state, particles, seed):
    return subprocess.Popen([ssrfleet, "stream", "--state", state, "--input", log, "--particles", str(particles),
                             "--seed", str(seed), "--quiet"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--ssrfleet", required=True)
    ap.add_argument("--trucks", type=int, default=10000)
    ap.add_argument("--clients", type=int, default=50)
    ap.add_argument("--minutes", type=float, default=10.0, help="minutes of served turns the clients poll, at least")
    ap.add_argument("--phase", type=float, default=20.0, help="seconds of each turn")
    ap.add_argument("--particles", type=int, default=1024)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--skip", type=int, default=100, help="trucks left out at the start of each rate")
    ap.add_argument("--out", default=None, help="folder for the JSON and Markdown report")
    ap.add_argument("--check", action="store_true")
    a = ap.parse_args()
    work = tempfile.mkdtemp(prefix="ssrfleet-serve-load-")
    serve = None
    procs = []  # every process started, stopped ones too, ended in any case
    try:
        log = os.path.join(work, "log.csv")
        subprocess.run([a.ssrfleet, "simulate", "--road", "AS1", "--trucks", str(a.trucks), "--seed", str(a.seed),
                        "--out", log], check=True, capture_output=True)
        load_before = os.getloadavg()[0]

        # Both streams and the server start; then they take turns.
        alone_state, state = os.path.join(work, "alone"), os.path.join(work, "served")
        serve_log = open(os.path.join(work, "serve.log"), "w+")
        serve = subprocess.Popen([a.ssrfleet, "serve", "--state", state, "--port", "0"], stdout=subprocess.DEVNULL,
                                 stderr=serve_log)
        procs.append(serve)
        port = None
        for _ in range(100):
            serve_log.seek(0)
            m = re.search(r"http://127\.0\.0\.1:(\d+)/", serve_log.read())
            if m:
                port = int(m.group(1))
                break
            time.sleep(0.1)
        if port is None:
            sys.exit("serve did not start: " + open(os.path.join(work, "serve.log")).read())
        stop, go = threading.Event(), threading.Event()
        clients = [Client(port, "127.0.0.%d" % (2 + i), stop, go, i / a.clients) for i in range(a.clients)]
        for c in clients:
            c.start()
        alone = run_stream(a.ssrfleet, log, alone_state, a.particles, a.seed)
        served = run_stream(a.ssrfleet, log, state, a.particles, a.seed)
        procs += [alone, served]
        served.send_signal(signal.SIGSTOP)
        serve.send_signal(signal.SIGSTOP)
        turns = {"alone": [0, 0.0], "served": [0, 0.0]}  # trucks counted, seconds
        rss = []  # (seconds of served turns, kB)
        served_time = 0.0
        turn = "alone"
        while True:
            running = alone if turn == "alone" else served
            if running.poll() is None:
                state_dir = alone_state if turn == "alone" else state
                before, start = trucks_in(state_dir), time.time()
                running.send_signal(signal.SIGCONT)
                if turn == "served":
                    serve.send_signal(signal.SIGCONT)
                    go.set()
                deadline = start + a.phase
                while time.time() < deadline and running.poll() is None:
                    if turn == "served":
                        rss.append((served_time + time.time() - start, rss_kb(serve.pid)))
                    time.sleep(min(5.0, max(0.0, deadline - time.time())))
                if running.poll() is None:
                    running.send_signal(signal.SIGSTOP)
                elapsed = time.time() - start
                if turn == "served":
                    go.clear()
                    for c in clients:
                        c.idle.wait(timeout=30)
                    serve.send_signal(signal.SIGSTOP)
                    served_time += elapsed
                after = trucks_in(state_dir)
                # Only turns past the first SKIP trucks count (the start's table rebuilds).
                if before >= a.skip:
                    turns[turn][0] += after - before
                    turns[turn][1] += elapsed
            if alone.poll() is not None and served.poll() is not None:
                if served_time >= a.minutes * 60:
                    break
                # The streams are done but the clients have not polled long enough: serve alone.
                serve.send_signal(signal.SIGCONT)
                go.set()
                start = time.time()
                while time.time() - start < min(a.phase, a.minutes * 60 - served_time + 1):
                    rss.append((served_time + time.time() - start, rss_kb(serve.pid)))
                    time.sleep(5)
                served_time += time.time() - start
                go.clear()
                continue
            turn = "served" if turn == "alone" else "alone"
        serve.send_signal(signal.SIGCONT)
        stop.set()
        go.set()
        for c in clients:
            c.join(timeout=30)
        alone_rate = turns["alone"][0] / turns["alone"][1] if turns["alone"][1] > 0 else 0.0
        served_rate = turns["served"][0] / turns["served"][1] if turns["served"][1] > 0 else 0.0
        alone_trucks, alone_s = turns["alone"]
        served_trucks, served_s = turns["served"]
        alone_wall = alone_s
        load_after = os.getloadavg()[0]
        requests = sum(c.requests for c in clients)
        failures = [f for c in clients for f in c.failures]
        latencies = sorted(l for c in clients for l in c.latencies)
        # Growth after the first minute: the median of the last minute's samples against the median
        # of the second minute's. A computation's buffers (a few MB, freed at once after it) make
        # single samples jump; the medians follow what stays. The largest sample is reported too.
        def median(values):
            values = sorted(values)
            return values[len(values) // 2] if values else 0
        after_first_minute = [kb for t, kb in rss if t >= 60]
        second_minute = [kb for t, kb in rss if 60 <= t < 120]
        end = rss[-1][0] if rss else 0
        last_minute = [kb for t, kb in rss if t >= max(60, end - 60)]
        base_kb = median(second_minute)
        growth_mb = (median(last_minute) - base_kb) / 1024.0 if second_minute else 0.0
        ratio = served_rate / alone_rate if alone_rate > 0 else 0.0
        result = {
            "trucks": a.trucks, "clients": a.clients, "minutes_polled": (rss[-1][0]) / 60.0, "particles": a.particles,
            "seed": a.seed, "skip": a.skip,
            "phase_s": a.phase,
            "alone": {"trucks_per_s": alone_rate, "trucks": alone_trucks, "seconds": alone_s},
            "served": {"trucks_per_s": served_rate, "trucks": served_trucks, "seconds": served_s},
            "ratio": ratio, "requests": requests, "failed": len(failures), "failures_first": failures[:10],
            "latency_s": {"median": latencies[len(latencies) // 2] if latencies else None,
                          "p99": latencies[int(len(latencies) * 0.99)] if latencies else None,
                          "max": latencies[-1] if latencies else None},
            "rss_kb": {"first": rss[0][1], "median_second_minute": base_kb, "median_last_minute": median(last_minute),
                       "max_after_1_min": max(after_first_minute or [0]), "last": rss[-1][1]},
            "rss_growth_after_first_minute_mb": growth_mb,
            "load_1min": {"before": load_before, "after": load_after},
            "rss_series_kb": rss,
        }
        ok = {"no failed request": len(failures) == 0, "RSS growth <= 5 MB": growth_mb <= 5.0,
              "trucks/s >= 90 %": ratio >= 0.9}
        result["criteria"] = ok
        lines = [
            "| quantity | value |", "|---|---|",
            "| trucks, clients, minutes polled | %d, %d, %.1f |" % (a.trucks, a.clients, result["minutes_polled"]),
            "| turns | %.0f s each; alone %.0f s, served %.0f s counted |" % (a.phase, alone_s, served_s),
            "| stream alone | %.2f trucks/s |" % alone_rate,
            "| stream served and polled | %.2f trucks/s (%.1f %% of alone) |" % (served_rate, 100 * ratio),
            "| requests, failed | %d, %d |" % (requests, len(failures)),
            "| latency median / p99 / max | %.1f / %.1f / %.1f ms |" % tuple(1000 * (v or 0) for v in
                                                                         result["latency_s"].values()),
            "| server RSS, medians of the second and the last minute; growth; largest sample after 1 min | "
            "%.1f MB, %.1f MB; %.2f MB; %.1f MB |" % (base_kb / 1024, median(last_minute) / 1024, growth_mb,
                                                     result["rss_kb"]["max_after_1_min"] / 1024),
            "| load (1 min) before / after | %.2f / %.2f |" % (load_before, load_after),
        ] + ["| criterion: %s | %s |" % (k, "pass" if v else "FAIL") for k, v in ok.items()]
        print("\n".join(lines))
        if a.out:
            os.makedirs(a.out, exist_ok=True)
            with open(os.path.join(a.out, "serve-load.json"), "w") as f:
                json.dump(result, f, indent=1)
            with open(os.path.join(a.out, "serve-load.md"), "w") as f:
                f.write("\n".join(lines) + "\n")
        if a.check and not all(ok.values()):
            sys.exit(1)
    finally:
        for p in procs:
            if p.poll() is None:
                p.send_signal(signal.SIGCONT)
                p.terminate()
                p.wait(timeout=30)
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
