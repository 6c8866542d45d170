#!/usr/bin/env python3
"""Drives headless Chromium over its DevTools pipe (no extra package: `--remote-debugging-pipe`
speaks NUL-separated JSON on file descriptors 3 and 4) to check the viewer as a person sees it.

  page_check.py layout URL [--shot PNG]
      At 1024x768 the page has no horizontal scroll (document.scrollWidth <= innerWidth); at
      1400x900 the reorg text is above the fold. --shot keeps the 1024 px screenshot.
  page_check.py live SWARMFL [--shot PNG] [--set key=value ...]
      1. Starts `SWARMFL run --live --port 0` on a long run, opens the page, and reads the
         page's frame counter (its <pre id="status">) until two reads at least 2 s apart, both
         while the run goes, show more frames and a later time in the later one (--shot keeps
         the screenshot then). Ctrl-C (SIGINT) to the run then stops run and server: the page
         says the server is gone and the port is closed.
      2. Starts a short run with the page open: the page says the run ended, holds as many
         frames as `swarmfl view` writes for the finished log, and the server stops by itself.
Exits 1 naming what failed."""

import base64
import json
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time


def fail(message):
    sys.exit(f"page_check: {message}")


class Chrome:
    """One headless Chromium and one page (target) in it."""

    def __init__(self, profile):
        chrome = shutil.which("chromium") or shutil.which("chromium-browser") or shutil.which("google-chrome")
        if not chrome:
            fail("no chromium found (apt-get install -y chromium)")
        to_chrome_r, self.to_chrome = os.pipe()
        self.from_chrome, from_chrome_w = os.pipe()

        def child():
            # Its own process group, so that close() stops the renderers and helpers too:
            # killing only the browser left them writing into the profile while it was removed.
            os.setpgrp()
            os.dup2(to_chrome_r, 3)
            os.dup2(from_chrome_w, 4)

        self.proc = subprocess.Popen(
            [chrome, "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
             "--disable-background-networking", "--disable-component-update", "--disable-sync",
             "--hide-scrollbars", "--remote-debugging-pipe", f"--user-data-dir={profile}",
             "about:blank"],
            pass_fds=(3, 4), preexec_fn=child,
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        os.close(to_chrome_r)
        os.close(from_chrome_w)
        self.buf = b""
        self.next_id = 0
        self.session = None

    def call(self, method, params=None, timeout_s=30):
        self.next_id += 1
        message = {"id": self.next_id, "method": method, "params": params or {}}
        if self.session and not method.startswith("Target."):
            message["sessionId"] = self.session
        os.write(self.to_chrome, json.dumps(message).encode() + b"\0")
        deadline = time.monotonic() + timeout_s
        while True:
            while b"\0" in self.buf:
                raw, self.buf = self.buf.split(b"\0", 1)
                reply = json.loads(raw)
                if reply.get("id") == self.next_id:
                    if "error" in reply:
                        fail(f"chromium refused {method}: {reply['error']}")
                    return reply.get("result", {})
            if time.monotonic() > deadline:
                fail(f"chromium did not answer {method} in {timeout_s} s")
            chunk = os.read(self.from_chrome, 1 << 20)
            if not chunk:
                fail("chromium closed its pipe")
            self.buf += chunk

    def open(self, url, width, height):
        target = self.call("Target.createTarget", {"url": "about:blank"})["targetId"]
        self.session = self.call("Target.attachToTarget", {"targetId": target, "flatten": True})["sessionId"]
        self.call("Emulation.setDeviceMetricsOverride",
                  {"width": width, "height": height, "deviceScaleFactor": 1, "mobile": False})
        self.call("Page.navigate", {"url": url})

    def resize(self, width, height):
        self.call("Emulation.setDeviceMetricsOverride",
                  {"width": width, "height": height, "deviceScaleFactor": 1, "mobile": False})

    def eval(self, expression):
        result = self.call("Runtime.evaluate", {"expression": expression, "returnByValue": True})
        if "exceptionDetails" in result:
            return None
        return result["result"].get("value")

    def status(self):
        text = self.eval("(document.getElementById('status') || {}).textContent || ''")
        try:
            return json.loads(text) if text else None
        except ValueError:
            return None

    def wait_status(self, ready, timeout_s, what):
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            s = self.status()
            if s and not s.get("loading") and ready(s):
                return s
            time.sleep(0.2)
        fail(f"{what} within {timeout_s} s (last status: {json.dumps(self.status())[:300]})")

    def shot(self, path):
        data = self.call("Page.captureScreenshot", {"format": "png"})["data"]
        with open(path, "wb") as f:
            f.write(base64.b64decode(data))

    def close(self):
        """Stops the browser and every process it started, and waits for the browser."""
        try:
            os.killpg(self.proc.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        self.proc.wait()
        # The group's other members are not our children; give them a moment to be reaped.
        time.sleep(0.2)


def layout(url, shot):
    work = tempfile.mkdtemp()
    try:
        c = Chrome(os.path.join(work, "profile"))
        try:
            c.open(url, 1024, 768)
            s = c.wait_status(lambda s: True, 20, "the page did not render")
            if not s["ok"]:
                fail(f"script errors: {s['errors']}")
            axes = s["loss_axes"]
            if len(axes["x"]) < 3 or len(axes["y"]) < 3 or len(axes["titles"]) != 2:
                fail(f"the loss chart needs ticks along both axes and two axis titles: {axes}")
            time.sleep(0.3)
            wide = c.eval("[document.documentElement.scrollWidth, window.innerWidth]")
            if wide[0] > wide[1]:
                fail(f"at 1024x768 the page scrolls sideways: scrollWidth {wide[0]} > innerWidth {wide[1]}")
            if shot:
                c.shot(shot)
            c.resize(1400, 900)
            time.sleep(0.5)
            bottom = c.eval("[document.getElementById('reorgs').getBoundingClientRect().bottom, window.innerHeight, document.getElementById('reorgs').textContent]")
            if not bottom[2]:
                fail("the reorg text is empty")
            if bottom[0] > bottom[1]:
                fail(f"at 1400x900 the reorg text ends at y = {bottom[0]:.0f}, below the fold ({bottom[1]})")
            print(f"page_check: layout: loss chart ticks x {axes['x']}, y {axes['y']}, titles {axes['titles']}")
            print(f"page_check: layout: no horizontal scroll at 1024x768 (scrollWidth {wide[0]}); "
                  f"reorg text above the fold at 1400x900 (ends at y = {bottom[0]:.0f})")
        finally:
            c.close()
    finally:
        shutil.rmtree(work, ignore_errors=True)


def start_run(swarmfl, out, sets):
    """Starts a live run; returns the process and its page's URL."""
    args = [swarmfl, "run", "--preset", "smoke", "--seed", "3", "--out", out, "--quiet", "--live", "--port", "0"]
    for kv in sets:
        args += ["--set", kv]
    err = open(out + ".stderr", "w+")
    # SIGINT at its default even if this script was started with it ignored (a background job).
    proc = subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=err,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline:
        err.seek(0)
        m = re.search(r"live view: (http://127\.0\.0\.1:(\d+)/)", err.read())
        if m:
            return proc, m.group(1), int(m.group(2))
        if proc.poll() is not None:
            err.seek(0)
            fail(f"`{' '.join(args)}` exited {proc.returncode} before serving: {err.read()}")
        time.sleep(0.05)
    fail("the live run printed no URL in 30 s")


def port_open(port):
    with socket.socket() as s:
        s.settimeout(0.5)
        return s.connect_ex(("127.0.0.1", port)) == 0


def live(swarmfl, shot, sets):
    work = tempfile.mkdtemp()
    try:
        c = Chrome(os.path.join(work, "profile"))
        try:
            watch_then_interrupt(c, swarmfl, os.path.join(work, "long"), shot, sets)
            watch_to_the_end(c, swarmfl, os.path.join(work, "short"))
        finally:
            c.close()
    finally:
        shutil.rmtree(work, ignore_errors=True)


def watch_then_interrupt(c, swarmfl, out, shot, sets):
    proc, url, port = start_run(swarmfl, out, sets or ["run.duration_s=5000"])
    try:
        c.open(url, 1240, 900)
        first = c.wait_status(lambda s: s.get("live") and s["frames"] > 1, 30, "the live page showed no frame")
        first_at = time.monotonic()
        while True:
            time.sleep(0.5)
            s = c.status()
            if s is None or s.get("loading"):
                continue
            if s["live"]["ended"]:
                fail("the run ended before its page could be read twice 2 s apart: make it longer")
            if time.monotonic() - first_at >= 2 and s["frames"] > first["frames"] \
                    and s["live"]["upto_s"] > first["live"]["upto_s"]:
                break
            if time.monotonic() - first_at > 40:
                fail(f"the page's frames did not advance in 40 s: {first['frames']} -> {s['frames']}")
        if not s["ok"]:
            fail(f"script errors: {s['errors']}")
        if abs(s["time_s"] - s["live"]["upto_s"]) > 1e-6:
            fail(f"following the run, the page shows t = {s['time_s']} s, its newest frame is at {s['live']['upto_s']} s")
        print(f"page_check: live: frames advance while the run goes: {first['frames']} frames "
              f"(t = {first['live']['upto_s']} s), {time.monotonic() - first_at:.1f} s later "
              f"{s['frames']} (t = {s['live']['upto_s']} s); the page follows the newest frame")
        if shot:
            c.shot(shot)
        proc.send_signal(signal.SIGINT)
        try:
            proc.wait(10)
        except subprocess.TimeoutExpired:
            fail("the run went on 10 s after Ctrl-C (SIGINT)")
        if port_open(port):
            fail(f"port {port} still open after Ctrl-C")
        gone = c.wait_status(lambda s: s["live"]["server_gone"], 10, "after Ctrl-C the page did not say the server is gone")
        if "server is gone" not in gone["live"]["text"]:
            fail(f"the page's words after Ctrl-C: {gone['live']['text']}")
        print(f"page_check: live: Ctrl-C stopped run and server (exit {proc.returncode}, port {port} closed); "
              f"the page says: {gone['live']['text'][:60]}...")
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


def watch_to_the_end(c, swarmfl, out):
    proc, url, port = start_run(swarmfl, out, [])
    try:
        c.open(url, 1240, 900)
        end = c.wait_status(lambda s: s.get("live") and s["live"]["ended"], 60, "the page did not say the run ended")
        if "The run ended" not in end["live"]["text"]:
            fail(f"the ended page's words: {end['live']['text']}")
        try:
            proc.wait(15)
        except subprocess.TimeoutExpired:
            fail("the server did not stop within 15 s of the run's end")
        if proc.returncode != 0:
            fail(f"the live run exited {proc.returncode}")
        if port_open(port):
            fail(f"port {port} still open after the run ended")
        view = subprocess.run([swarmfl, "view", os.path.join(out, "run.swlog"), "--out", out + ".html"],
                              capture_output=True, text=True, check=True).stdout
        frames = int(re.search(r"(\d+) frames", view).group(1))
        if frames != end["frames"]:
            fail(f"the ended live page holds {end['frames']} frames, `swarmfl view` writes {frames}")
        print(f"page_check: live: the page says the run ended and holds its {frames} frames (as "
              f"`swarmfl view`); the server stopped by itself (exit 0, port closed)")
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


def main(argv):
    if len(argv) < 3 or argv[1] not in ("layout", "live"):
        sys.exit(__doc__)
    shot = None
    sets = []
    rest = argv[3:]
    while rest:
        if rest[0] == "--shot" and len(rest) > 1:
            shot, rest = rest[1], rest[2:]
        elif rest[0] == "--set" and len(rest) > 1:
            sets.append(rest[1])
            rest = rest[2:]
        else:
            sys.exit(f"page_check: unknown argument {rest[0]}\n{__doc__}")
    if argv[1] == "layout":
        layout(argv[2], shot)
    else:
        live(argv[2], shot, sets)


if __name__ == "__main__":
    main(sys.argv)
