#!/usr/bin/env python3
"""A process's resident set over its life, for one or more commands, drawn as one plot.

Runs each `LABEL=COMMAND` in turn (a shell command line), reads its resident set from /proc
every `--every` seconds until it exits, and takes its peak from the kernel's account of the
finished process (`wait4`'s maximum resident set, which no sampling misses). Prints a line per
run (peak, time) and draws every run's curve, with its peak marked, in
an SVG. A headless render needs no display:

    python3 tools/scripts/resident_over_time.py --out rss.svg \\
        "before=/tmp/treelight-old render big.gltf --out /tmp/a.png --overwrite --spp 4" \\
        "after=$CARGO_TARGET_DIR/debug/treelight render big.gltf --out /tmp/b.png --overwrite --spp 4"

Only the command's own process is measured (not its children).
"""
import argparse
import os
import subprocess
import sys
import time

COLOURS = ["#d62728", "#1f77b4", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b"]
WIDTH, HEIGHT, LEFT, RIGHT, TOP, BOTTOM = 760, 420, 70, 20, 40, 50


def resident_mib(pid):
    """The resident set of `pid` now, MiB; None once it has gone."""
    try:
        with open(f"/proc/{pid}/status", encoding="utf-8") as f:
            for line in f:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1]) / 1024
    except OSError:
        return None
    return None


def measure(command, every):
    """Runs `command`; its samples [(seconds, MiB)], peak MiB, wall seconds and exit status."""
    start = time.monotonic()
    proc = subprocess.Popen(command, shell=True, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    samples = []
    while True:
        pid, status, usage = os.wait4(proc.pid, os.WNOHANG)
        if pid == proc.pid:
            break
        mib = resident_mib(proc.pid)
        if mib is not None:
            samples.append((time.monotonic() - start, mib))
        time.sleep(every)
    wall = time.monotonic() - start
    return samples, usage.ru_maxrss / 1024, wall, os.waitstatus_to_exitcode(status)


def svg(runs, title):
    """The runs' curves as an SVG document."""
    t_max = max(max((t for t, _ in r["samples"]), default=1.0) for r in runs) or 1.0
    m_max = max(r["peak"] for r in runs) * 1.08 or 1.0
    plot_w, plot_h = WIDTH - LEFT - RIGHT, HEIGHT - TOP - BOTTOM

    def x(t):
        return LEFT + plot_w * t / t_max

    def y(m):
        return TOP + plot_h * (1 - m / m_max)

    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{WIDTH}" height="{HEIGHT}" '
           f'font-family="sans-serif" font-size="12">',
           f'<rect width="{WIDTH}" height="{HEIGHT}" fill="white"/>',
           f'<text x="{WIDTH / 2}" y="22" text-anchor="middle" font-size="14">{title}</text>']
    step = 500 if m_max > 2000 else 100
    for m in range(0, int(m_max) + 1, step):
        out.append(f'<line x1="{LEFT}" x2="{WIDTH - RIGHT}" y1="{y(m):.1f}" y2="{y(m):.1f}" '
                   f'stroke="#ddd"/><text x="{LEFT - 6}" y="{y(m) + 4:.1f}" '
                   f'text-anchor="end">{m}</text>')
    t_step = max(1, round(t_max / 10))
    for t in range(0, int(t_max) + 1, t_step):
        out.append(f'<text x="{x(t):.1f}" y="{HEIGHT - BOTTOM + 16}" '
                   f'text-anchor="middle">{t}</text>')
    out.append(f'<text x="{LEFT + plot_w / 2}" y="{HEIGHT - 12}" text-anchor="middle">'
               f'seconds from the start</text>')
    out.append(f'<text x="16" y="{TOP + plot_h / 2}" text-anchor="middle" '
               f'transform="rotate(-90 16 {TOP + plot_h / 2})">resident set, MiB</text>')
    for k, r in enumerate(runs):
        colour = COLOURS[k % len(COLOURS)]
        points = " ".join(f"{x(t):.1f},{y(m):.1f}" for t, m in r["samples"])
        out.append(f'<polyline fill="none" stroke="{colour}" stroke-width="1.5" '
                   f'points="{points}"/>')
        out.append(f'<line x1="{LEFT}" x2="{WIDTH - RIGHT}" y1="{y(r["peak"]):.1f}" '
                   f'y2="{y(r["peak"]):.1f}" stroke="{colour}" stroke-dasharray="4 3"/>')
        # The legend in the lower right, where a curve that rises and holds leaves room.
        out.append(f'<text x="{WIDTH - RIGHT - 10}" y="{TOP + plot_h - 12 - 16 * (len(runs) - 1 - k)}" '
                   f'text-anchor="end" fill="{colour}">'
                   f'{r["label"]}: peak {r["peak"]:.0f} MiB (dashed)</text>')
    out.append("</svg>")
    return "\n".join(out)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("runs", nargs="+", metavar="LABEL=COMMAND")
    parser.add_argument("--out", required=True, help="the SVG to write (not replaced)")
    parser.add_argument("--every", type=float, default=0.1, help="seconds between reads")
    parser.add_argument("--title", default="Resident set over time")
    args = parser.parse_args()
    if os.path.lexists(args.out):
        sys.exit(f"{args.out}: the file exists")
    runs = []
    for run in args.runs:
        label, sep, command = run.partition("=")
        if not sep or not command.strip():
            sys.exit(f"{run!r}: expected LABEL=COMMAND")
        samples, peak, wall, status = measure(command, args.every)
        if status != 0:
            sys.exit(f"{label}: the command failed (status {status}): {command}")
        print(f"{label}: peak {peak:.0f} MiB, {wall:.1f} s")
        runs.append({"label": label, "samples": samples, "peak": peak})
    with open(args.out, "x", encoding="utf-8") as f:
        f.write(svg(runs, args.title))


if __name__ == "__main__":
    main()
