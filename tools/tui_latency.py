#!/usr/bin/env python3
"""Key press -> changed picture of `hdrvis tui`, measured from outside through a real tmux pane.

Starts `HDRVIS tui FILE --protocol halfblocks` in a COLS x ROWS tmux window of its own server,
waits for the first picture, then presses KEY RUNS + 1 times (the first is a warm-up). After each
press it polls `capture-pane -e` for 1.5 s and takes the time of the last change of the screen:
the panel changes at once, the picture when the view worker is done and the frame is drawn.
Prints the median and every run in milliseconds. `hdrvis bench tui` times the same path inside
the process; this adds the terminal (tmux parsing the frame) and the event loop.

    python3 tools/tui_latency.py target/release/hdrvis image.exr 160 50 + 8
"""
import hashlib
import os
import statistics
import subprocess
import sys
import time

HDRVIS, FILE, COLS, ROWS, KEY, RUNS = sys.argv[1:7]
SOCKET = f"hdrvis-latency-{os.getpid()}"


def tmux(*args):
    return subprocess.run(["tmux", "-L", SOCKET, *args], capture_output=True, text=True).stdout


def screen():
    return hashlib.sha1(tmux("capture-pane", "-e", "-p").encode()).hexdigest()


def settle(previous, quiet_s=0.3):
    """Waits until the screen has not changed for quiet_s; returns its hash."""
    since = time.time()
    while time.time() - since < quiet_s:
        now = screen()
        if now != previous:
            previous, since = now, time.time()
        time.sleep(0.01)
    return previous


tmux("new-session", "-d", "-x", COLS, "-y", ROWS, f"{HDRVIS} tui {FILE} --protocol halfblocks")
try:
    time.sleep(3)
    shown = settle(screen(), 1.0)
    times = []
    for run in range(int(RUNS) + 1):
        shown = settle(shown)
        t0 = time.time()
        tmux("send-keys", KEY)
        last = t0
        while time.time() - t0 < 1.5:
            now = screen()
            if now != shown:
                shown, last = now, time.time()
            time.sleep(0.002)
        if run > 0:
            times.append((last - t0) * 1e3)
finally:
    tmux("kill-server")
print(f"key {KEY!r} at {COLS}x{ROWS}: median {statistics.median(times):.0f} ms, "
      f"runs {[round(t) for t in times]}")
