#!/usr/bin/env python3
"""ssrfleet serve in a real browser: a stream follows a WIM log that grows in steps, serve follows the
stream, and headless Chromium renders the page. From the rendered DOM: the truck count rises in one
page load without a reload, every new checkpoint is shown within 2 s of its report, the SSR chart
has one point per sensor, and the page says plainly that the stream stopped once it has. A
screenshot is kept beside the test's other output.

usage: serve_browser_test.py SSRFLEET_BINARY OUTPUT_DIR
Without Chromium the test fails, naming the package to install."""

import base64
import json
import os
import re
import select
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import urllib.request

SENSORS = 16  # AS1's default array: 76 m, every 1.5 m


def fail(message):
    print("FAIL: " + message, file=sys.stderr)
    sys.exit(1)


def chromium_binary():
    for name in ("chromium", "chromium-browser", "google-chrome"):
        path = shutil.which(name)
        if path:
            return path
    fail("no chromium on PATH: this test renders the page in a real browser; install Debian's package "
         "with `apt-get install chromium` (scripts/setup-debian.sh does)")


class Browser:
    """Headless Chromium driven over the DevTools protocol on a pipe (--remote-debugging-pipe:
    NUL-terminated JSON on the browser's fds 3 and 4), so one page can be watched as it runs."""

    def __init__(self, chromium, out_dir):
        self.profile = tempfile.mkdtemp(prefix="chromium-profile-", dir=out_dir)
        to_browser_r, self.to_browser = os.pipe()
        self.from_browser, from_browser_w = os.pipe()

        def fds():
            # Moved out of the way first: either may itself be fd 3 or 4.
            reads, writes = os.dup(to_browser_r), os.dup(from_browser_w)
            os.dup2(reads, 3)
            os.dup2(writes, 4)

        self.log = open(os.path.join(out_dir, "chromium.log"), "w")
        self.proc = subprocess.Popen([chromium, "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
                                      "--disable-extensions", "--remote-debugging-pipe",
                                      "--user-data-dir=" + self.profile, "about:blank"],
                                     stdout=self.log, stderr=self.log, close_fds=False, preexec_fn=fds)
        os.close(to_browser_r)
        os.close(from_browser_w)
        self.next_id = 0
        self.buffer = b""
        target = self.call("Target.createTarget", {"url": "about:blank"})["targetId"]
        self.session = self.call("Target.attachToTarget", {"targetId": target, "flatten": True})["sessionId"]

    def call(self, method, params=None, session=True, timeout=30):
        self.next_id += 1
        message = {"id": self.next_id, "method": method, "params": params or {}}
        if session and hasattr(self, "session"):
            message["sessionId"] = self.session
        os.write(self.to_browser, json.dumps(message).encode() + b"\0")
        deadline = time.time() + timeout
        while True:
            while b"\0" in self.buffer:
                raw, self.buffer = self.buffer.split(b"\0", 1)
                reply = json.loads(raw)
                if reply.get("id") == self.next_id:
                    if "error" in reply:
                        fail("chromium refused %s: %s" % (method, reply["error"]))
                    return reply["result"]
            left = deadline - time.time()
            if left <= 0 or not select.select([self.from_browser], [], [], left)[0]:
                fail("chromium did not answer %s in %d s (see chromium.log)" % (method, timeout))
            chunk = os.read(self.from_browser, 1 << 20)
            if not chunk:
                fail("chromium exited (see chromium.log)")
            self.buffer += chunk

    def value(self, expression):
        return self.call("Runtime.evaluate", {"expression": expression, "returnByValue": True})["result"].get("value")

    def close(self):
        try:
            self.call("Browser.close", session=False, timeout=10)
        except SystemExit:
            pass
        try:
            self.proc.wait(timeout=20)
        except subprocess.TimeoutExpired:
            self.proc.kill()
        shutil.rmtree(self.profile, ignore_errors=True)


# What the page exposes for this test, read from its live DOM.
PAGE_STATE = """JSON.stringify({
  trucks: Number(document.getElementById("trucks").dataset.trucks),
  first: Number(document.body.dataset.firstTrucks),
  updates: Number(document.body.dataset.updates || 0),
  lag: Number(document.body.dataset.maxLagMs || -1),
  points: Number(document.getElementById("ssr-chart").dataset.points),
  hyper: document.querySelectorAll("#hyper-grid canvas").length,
  status: document.body.dataset.status,
  banner: document.getElementById("status").textContent,
  navigations: performance.getEntriesByType("navigation").length,
  loaded_at: performance.timeOrigin})"""


def page_state(browser):
    text = browser.value(PAGE_STATE)  # none while the page is still loading (no #trucks yet)
    return json.loads(text) if text else None


def wait_page(browser, what, test, seconds):
    deadline = time.time() + seconds
    state = None
    while time.time() < deadline:
        state = page_state(browser)
        if state is not None and test(state):
            return state
        time.sleep(0.25)
    fail("the page did not show %s in %d s: %s" % (what, seconds, state))


def summary(port):
    with urllib.request.urlopen("http://127.0.0.1:%d/api/summary" % port, timeout=5) as r:
        return json.load(r)


def wait_for_trucks(port, at_least, seconds):
    deadline = time.time() + seconds
    while time.time() < deadline:
        s = summary(port)
        if s["checkpoint"] and s["checkpoint"]["trucks"] >= at_least:
            return s["checkpoint"]["trucks"]
        time.sleep(0.2)
    fail("the stream did not reach %d trucks in %d s" % (at_least, seconds))


def main():
    if len(sys.argv) != 3:
        fail("usage: serve_browser_test.py SSRFLEET_BINARY OUTPUT_DIR")
    ssrfleet, out_dir = sys.argv[1], os.path.abspath(sys.argv[2])
    os.makedirs(out_dir, exist_ok=True)
    chromium = chromium_binary()
    work = tempfile.mkdtemp(prefix="ssrfleet-serve-browser-")
    stream = serve = None
    try:
        log = os.path.join(work, "all.csv")
        subprocess.run([ssrfleet, "simulate", "--road", "AS1", "--trucks", "60", "--seed", "11", "--out", log],
                       check=True, capture_output=True)
        lines = [l for l in open(log).read().splitlines() if l and not l.startswith("#")]
        header, records = lines[0], lines[1:]
        feed = os.path.join(work, "feed.csv")
        with open(feed, "w") as f:
            f.write(header + "\n" + "\n".join(records[:8]) + "\n")
        state = os.path.join(work, "state")
        stream = subprocess.Popen([ssrfleet, "stream", "--state", state, "--input", feed, "--follow",
                                   "--particles", "128", "--threads", "1", "--quiet"],
                                  stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        serve_err = open(os.path.join(out_dir, "serve.log"), "w+")
        serve = subprocess.Popen([ssrfleet, "serve", "--state", state, "--port", "0"],
                                 stdout=subprocess.DEVNULL, stderr=serve_err)
        port = None
        for _ in range(100):
            serve_err.seek(0)
            m = re.search(r"http://127\.0\.0\.1:(\d+)/", serve_err.read())
            if m:
                port = int(m.group(1))
                break
            time.sleep(0.1)
        if port is None:
            fail("serve did not print its address (see serve.log)")
        url = "http://127.0.0.1:%d/" % port
        first = wait_for_trucks(port, 8, 90)

        browser = Browser(chromium, out_dir)
        try:
            browser.call("Emulation.setDeviceMetricsOverride",
                         {"width": 1280, "height": 1500, "deviceScaleFactor": 1, "mobile": False})
            browser.call("Page.navigate", {"url": url})
            s1 = wait_page(browser, "the first checkpoint", lambda s: s["trucks"] >= first and s["points"] > 0 and s["hyper"] > 0,
                           30)
            print("first look: %d trucks, %d SSR points, %d hyperparameter charts, status %s" %
                  (s1["trucks"], s1["points"], s1["hyper"], s1["status"]))
            if s1["points"] != SENSORS:
                fail("the SSR chart has %d points, not one per sensor (%d)" % (s1["points"], SENSORS))
            if s1["hyper"] != 7:
                fail("%d hyperparameter charts, not 7" % s1["hyper"])
            if s1["status"] != "running":
                fail("the page says '%s' while the stream runs" % s1["status"])
            # The log grows by 4 records every 1.5 s; the same page load must follow it.
            for k in range(8, 32, 4):
                with open(feed, "a") as f:
                    f.write("\n".join(records[k:k + 4]) + "\n")
                time.sleep(1.5)
            s2 = wait_page(browser, "32 trucks", lambda s: s["trucks"] >= 32, 90)
            print("same page later: %d trucks after %d updates without reload (%d navigation); longest delay from "
                  "a checkpoint to the page %d ms; %d SSR points" %
                  (s2["trucks"], s2["updates"], s2["navigations"], s2["lag"], s2["points"]))
            if not s2["trucks"] > s1["trucks"] or s2["updates"] < 2:
                fail("the truck count did not rise in one page load (%d -> %d)" % (s1["trucks"], s2["trucks"]))
            if s2["navigations"] != 1 or s2["loaded_at"] != s1["loaded_at"]:
                fail("the page was reloaded")
            if not 0 <= s2["lag"] <= 2000:
                fail("a checkpoint took %d ms to reach the page (at most 2000)" % s2["lag"])
            if s2["points"] != SENSORS:
                fail("the SSR chart has %d points after the updates, not %d" % (s2["points"], SENSORS))
            time.sleep(1.5)  # the damage table's first computation
            shot = browser.call("Page.captureScreenshot", {"format": "png"})["data"]
            with open(os.path.join(out_dir, "serve-page.png"), "wb") as f:
                f.write(base64.b64decode(shot))

            # The stream stops: the page says so, plainly.
            stream.send_signal(signal.SIGTERM)
            stream.wait(timeout=60)
            s3 = wait_page(browser, "that the stream stopped", lambda s: s["status"] == "stopped", 10)
            print("after SIGTERM: '%s'" % s3["banner"])
            if "STOPPED" not in s3["banner"]:
                fail("the banner does not say that the stream stopped: " + s3["banner"])
        finally:
            browser.close()

        # A second browser, the plain command line way: a fresh load shows the latest count.
        dom = subprocess.run([chromium, "--headless", "--no-sandbox", "--disable-gpu", "--virtual-time-budget=5000",
                              "--dump-dom", url], capture_output=True, text=True, timeout=120).stdout
        m = re.search(r'id="trucks"[^>]*data-trucks="(\d+)"|data-trucks="(\d+)"[^>]*id="trucks"', dom)
        fresh = int(m.group(1) or m.group(2)) if m else -1
        print("a second browser's load: %d trucks" % fresh)
        if fresh != summary(port)["checkpoint"]["trucks"]:
            fail("a fresh load shows %d trucks, not the last checkpoint's %d" % (fresh, summary(port)["checkpoint"]["trucks"]))
        print("PASS; screenshot: " + os.path.join(out_dir, "serve-page.png"))
    finally:
        for p in (stream, serve):
            if p is not None and p.poll() is None:
                p.terminate()
                try:
                    p.wait(timeout=20)
                except subprocess.TimeoutExpired:
                    p.kill()
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
