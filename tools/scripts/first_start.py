#!/usr/bin/env python3
"""A first start's figures: the longest gap between frames and the time to the first traced sample.

Starts the editor with `--state` and reads the report every 20 ms from the process's start.
Run from the repository under a display (a headless machine: `xvfb-run -a`):

    xvfb-run -a python3 tools/scripts/first_start.py [--binary PATH] [--seconds 60] [-- EDITOR ARGS]

An empty Mesa shader cache: MESA_SHADER_CACHE_DIR=$(mktemp -d); no kernel record: a fresh
TREELIGHT_CONFIG_DIR=$(mktemp -d).
"""
import argparse
import os
import subprocess
import sys
import tempfile
import time

from state_report import read_state


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    target = os.environ.get("CARGO_TARGET_DIR", "target")
    ap.add_argument("--binary", default=os.path.join(target, "release", "treelight"))
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("editor_args", nargs="*")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        state = os.path.join(tmp, "state.ron")
        start = time.monotonic()
        editor = subprocess.Popen([args.binary, "--state", state, *args.editor_args])
        last_frame, last_change, longest, first_sample = None, start, 0.0, None
        try:
            while time.monotonic() - start < args.seconds and editor.poll() is None:
                now = time.monotonic()
                s = read_state(state)
                if s is not None:
                    frame, samples = s["frame"], s["samples"]
                    if frame != last_frame:
                        if last_frame is not None:
                            longest = max(longest, now - last_change)
                        last_frame, last_change = frame, now
                    if samples > 0 and first_sample is None:
                        first_sample = now - start
                        break
                time.sleep(0.02)
        finally:
            editor.terminate()
            editor.wait()
    print(f"longest gap between frames: {longest:.2f} s")
    if first_sample is None:
        print(f"no traced sample within {args.seconds:.0f} s")
        sys.exit(1)
    print(f"first traced sample: {first_sample:.2f} s")


if __name__ == "__main__":
    main()
