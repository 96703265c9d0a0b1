#!/usr/bin/env python3
"""An editor at rest: CPU time and frames over a while once the view has converged.

Starts the editor on its default scene with `--samples 16 --state` (1280x800), waits until the
view has its samples, the scene has settled and the editor says it rests, then counts the
process's CPU time (all threads: user + system, from /proc) and the frames drawn over
`--seconds`, first with the window focused (the pointer in it), then unfocused (the keyboard's
focus taken away). Run from the repository under a display (a headless machine: `xvfb-run -a`):

    xvfb-run -a -s "-screen 0 1600x1000x24" python3 tools/scripts/idle_cpu.py \
        [--binary PATH] [--seconds 20] [-- EDITOR ARGS]

The binary defaults to the release build in $CARGO_TARGET_DIR (or target/).
"""
import argparse
import ctypes
import os
import subprocess
import sys
import time

from state_report import read_state, start_editor


def cpu_seconds(pid):
    """User + system time of every thread of `pid`, seconds."""
    with open(f"/proc/{pid}/stat", encoding="utf-8") as f:
        parts = f.read().rsplit(")", 1)[1].split()
    ticks = os.sysconf("SC_CLK_TCK")
    return (int(parts[11]) + int(parts[12])) / ticks


def set_focus(focused):
    """Gives the keyboard's focus to the window under the pointer (the editor's, at the screen's
    centre) or to no window, through libX11."""
    x11 = ctypes.cdll.LoadLibrary("libX11.so.6")
    x11.XOpenDisplay.restype = ctypes.c_void_p
    dpy = x11.XOpenDisplay(None)
    if not dpy:
        return False
    dpy = ctypes.c_void_p(dpy)
    x11.XDefaultRootWindow.restype = ctypes.c_ulong
    root = x11.XDefaultRootWindow(dpy)
    if focused:
        x11.XWarpPointer(dpy, 0, ctypes.c_ulong(root), 0, 0, 0, 0, 400, 300)
    # PointerRoot (1) follows the pointer; None (0) gives no window the keyboard.
    x11.XSetInputFocus(dpy, ctypes.c_ulong(1 if focused else 0), 1, 0)
    x11.XSync(dpy, 0)
    x11.XCloseDisplay(dpy)
    return True


def measure(pid, state, seconds):
    before, start = cpu_seconds(pid), time.monotonic()
    frames_before = (read_state(state) or {}).get("frame", 0)
    time.sleep(seconds)
    used, wall = cpu_seconds(pid) - before, time.monotonic() - start
    st = read_state(state) or {}
    return used / wall, st.get("frame", 0) - frames_before, st


def main():
    parser = argparse.ArgumentParser()
    target = os.environ.get("CARGO_TARGET_DIR", "target")
    parser.add_argument("--binary", default=os.path.join(target, "release", "treelight"))
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument("--timeout", type=float, default=600.0)
    parser.add_argument("editor_args", nargs="*")
    a = parser.parse_args()
    editor, state, tmp = start_editor(a.binary, "treelight-idle-",
                                      ["--samples", "16"] + a.editor_args,
                                      stdout=subprocess.DEVNULL)
    try:
        start = time.monotonic()
        while True:
            st = read_state(state)
            if st and st["samples"] >= 16 and st["settled"] and st["at_rest"]:
                break
            if editor.poll() is not None or time.monotonic() - start > a.timeout:
                sys.exit(f"the editor never came to rest: {st} (log in {tmp})")
            time.sleep(0.2)
        print(f"converged and at rest after {time.monotonic() - start:.1f} s "
              f"(frame {st['frame']})")
        for focused in (True, False):
            if not set_focus(focused):
                print("no X display to set the focus on")
                break
            # The focus change is input: its frames settle first.
            time.sleep(1.0)
            while not (read_state(state) or {}).get("at_rest"):
                time.sleep(0.1)
            time.sleep(3.0)
            share, frames, st = measure(editor.pid, state, a.seconds)
            name = "focused" if focused else "unfocused"
            print(f"{name}: {100 * share:.2f}% of one core over {a.seconds:.0f} s, "
                  f"{frames} frames (last busy: {st.get('last_busy', '')})")
    finally:
        editor.kill()
        editor.wait()


if __name__ == "__main__":
    main()
