//! Where the editor's memory goes with a large assembly in its path-traced viewport, on the
//! machine's adapter (llvmpipe here, whose GPU buffers live in the process's memory): the editor
//! binary under Xvfb opens a generated assembly of bumpy tiles (the sizes below), and its `--state`
//! report is read until the whole assembly is in the tree and the scene has settled. Prints, per
//! assembly, each owner's bytes by its own count (Bevy's mesh assets, the parked meshes' compressed
//! vertices, the BVH's arrays, the BVH groups' shading, the path tracer's scene buffers) and per
//! triangle, the device allocator's
//! memory blocks (every buffer and texture and the uploads' staging: it overlaps the scene
//! buffers, so it is not in the sum), the whole process's resident set once idle and its peak
//! (the default scene's varies by hundreds of megabytes with the kernel cache and the heap's
//! trims, so nothing is taken off); when the file was parsed (from the start of the process),
//! how long after that the tree held its first triangles, the viewport traced a frame of them (a
//! coarse preview while the tree fills) and showed a whole path-traced picture with them (every
//! pixel sampled), when the tree held all of them (from the start); when the view kept its samples
//! (the worker's background bakes over), when its idle-time rebuilds were over (every mesh rebuilt, the
//! scene settled: idle); and the frame rate then (the median of 8 s of reports, 20 s after the
//! resident set has held within 1% for 8 s) next to the default scene's, with how much the
//! resident set grew per frame over those 8 s (nothing should). The owners' bytes and the resident
//! set are read once idle; the editor's log is `editor.log` in the run's temporary folder, with its
//! mappings once idle (`smaps-NAME`, NAME the file's stem).
//!
//! After each assembly's editor, `treelight render` draws the same file headless (320×200, 4
//! samples a pixel) and its peak resident set is printed under the table, from the kernel's
//! account of the finished process (`wait4`'s maximum resident set).
//!
//! Run: `cargo bench --workspace --profile dev --bench memory [-- [busy] [render] PARTSxROWS ...]`
//! (`render`: the headless renders alone, no editor; default
//! `100x100 400x100 400x123`: 2M, 8M and 12.1M triangles). `busy`: a thread of this process spins
//! on one core while each assembly's editor runs (the fill on a busy machine). Needs Xvfb and
//! Mesa's software Vulkan, as the tests do. The largest takes minutes and more than 10 GB.

#[path = "../plugins/document/tests/support/assembly.rs"]
mod assembly;
#[path = "support/editor_process.rs"]
mod editor_process;

use editor_process::{busy_core, editor_command, editor_pid, stop};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};
use treelight::report::{EditorState, MemoryReport};
use treelight_render::BufferKind;

/// What one run of the editor showed.
struct Run {
    memory: MemoryReport,
    /// Frames per second once settled.
    fps: f64,
    /// Resident set of the editor's process once idle (the idle-time rebuilds over, 8 s after),
    /// and its peak resident set until then, bytes.
    rss: u64,
    hwm: u64,
    /// Seconds from the start until the tree held triangles, and all of them.
    first: Option<f64>,
    all: Option<f64>,
    /// Seconds from the start until the file was parsed (its "opened" notice), until the viewport
    /// traced a frame of some of its triangles, and until it showed a whole path-traced picture of
    /// them.
    parsed: Option<f64>,
    traced: Option<f64>,
    pictured: Option<f64>,
    /// Frames from the parse's until the tree held triangles, until the first traced frame of
    /// them, and until the whole picture.
    frames_to_first: Option<u64>,
    frames_to_traced: Option<u64>,
    frames_to_picture: Option<u64>,
    /// Seconds from the start until the view kept 4 samples (the background bakes done).
    quiet: Option<f64>,
    /// Seconds from the start until the worker's idle-time rebuilds were over (5 s without one).
    idle: f64,
    /// Bytes the resident set grew by per frame over the 8 s once idle.
    growth_per_frame: Option<f64>,
    /// The view's trace in its last frame once idle: pixel samples, and nanoseconds a sample as
    /// its budget estimates it (a slow frame rate with many samples is the budget's doing).
    trace: Option<(u64, Option<f64>)>,
    /// The largest resident set seen in the polls, with the owners' counts and the phase then.
    peak: Option<(u64, MemoryReport, &'static str)>,
}

/// The largest resident set seen in the reports' polls, with the owners' counts then and the
/// phase of the run (where a peak comes from).
struct PeakProbe {
    group: u32,
    pid: Option<u32>,
    peak: Option<(u64, MemoryReport, &'static str)>,
}

impl PeakProbe {
    fn see(&mut self, s: &EditorState, phase: &'static str) {
        self.pid = self.pid.or_else(|| editor_pid(self.group));
        if let Some(rss) = self.pid.map(|p| rss_and_peak(p).0)
            && self.peak.as_ref().is_none_or(|(peak, ..)| rss > *peak)
        {
            self.peak = Some((rss, s.memory.clone(), phase));
        }
    }
}

/// VmRSS and VmHWM of `pid`, bytes.
fn rss_and_peak(pid: u32) -> (u64, u64) {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).unwrap_or_default();
    let field = |name: &str| {
        status
            .lines()
            .find(|l| l.starts_with(name))
            .and_then(|l| l.split_whitespace().nth(1))
            .and_then(|v| v.parse::<u64>().ok())
            .unwrap_or(0)
            * 1024
    };
    (field("VmRSS:"), field("VmHWM:"))
}

/// Runs the editor on `file` (or its default scene) until `triangles` are in the tree, `meshes`
/// meshes have been rebuilt (every mesh of an assembly is large enough to be) and the resident
/// set holds still.
fn run(file: Option<&Path>, triangles: u64, meshes: u64, dir: &Path) -> Run {
    let (state, mut cmd) = editor_command(file, dir);
    let start = Instant::now();
    let mut child = cmd.spawn().expect("xvfb-run");
    let mut probe = PeakProbe {
        group: child.id(),
        pid: None,
        peak: None,
    };
    let fill = follow_fill(&state, start, triangles, &mut probe);
    let mut last = fill.last.clone();
    // Once every triangle is in, the worker still bakes and rebuilds the meshes in the background
    // (each one restarting the traced view's samples) for up to minutes: the frame rate is taken
    // once the view keeps its samples, the median of its reports over 8 s.
    let state_now = || {
        std::fs::read_to_string(&state)
            .ok()
            .and_then(|t| ron::from_str::<EditorState>(&t).ok())
    };
    let quiet_from = Instant::now();
    let mut quiet = None;
    while last.is_some() && quiet_from.elapsed() < Duration::from_secs(300) {
        std::thread::sleep(Duration::from_millis(250));
        let now = state_now();
        if let Some(s) = &now {
            probe.see(s, "bakes");
        }
        if now.is_some_and(|s| s.samples >= 4) {
            quiet = Some(start.elapsed().as_secs_f64());
            break;
        }
    }
    // Then the worker rebuilds each still mesh with a better builder, for minutes: idle once
    // every mesh is rebuilt and the count has held for 5 s, the scene settled. (The count alone
    // can hold for 5 s between two rebuilds while updates run.)
    let mut rebuilt = (0, Instant::now());
    while last.is_some() && quiet_from.elapsed() < Duration::from_secs(600) {
        std::thread::sleep(Duration::from_millis(500));
        if let Some(s) = state_now() {
            probe.see(&s, "rebuilds");
            if s.memory.meshes_rebuilt != rebuilt.0 || !s.settled {
                rebuilt = (s.memory.meshes_rebuilt, Instant::now());
            } else if rebuilt.0 >= meshes && rebuilt.1.elapsed() >= Duration::from_secs(5) {
                break;
            }
        }
    }
    let idle = start.elapsed().as_secs_f64();
    // The editor's process, as the polls found it.
    let pid = probe.pid.or_else(|| editor_pid(child.id()));
    // The updates that follow the last rebuild rewrite most node records, and their uploads'
    // staging comes and goes for seconds: the resident set is read once it has held within 1%
    // for 8 s (at most a minute).
    let mut recent: Vec<u64> = Vec::new();
    let settling = Instant::now();
    while let Some(pid) =
        pid.filter(|_| last.is_some() && settling.elapsed() < Duration::from_secs(60))
    {
        std::thread::sleep(Duration::from_millis(500));
        recent.push(rss_and_peak(pid).0);
        if recent.len() >= 16 {
            let window = &recent[recent.len() - 16..];
            let (lo, hi) = (window.iter().min().unwrap(), window.iter().max().unwrap());
            if (hi - lo) * 100 <= *hi {
                break;
            }
        }
    }
    // The frame rate is low for a while after the last rebuild (the updates that follow it, their
    // uploads, the view's first denoised frames) and then holds: it is read 20 s on, over 8 s.
    if last.is_some() {
        std::thread::sleep(Duration::from_secs(20));
    }
    // The resident set's growth over those 8 s, per frame drawn: a view that leaks with every
    // frame (as lavapipe did with uniform-driven branches) shows here, not in the owners' counts.
    let idle_start = pid
        .map(rss_and_peak)
        .zip(state_now())
        .map(|((rss, _), s)| (rss, s.frame));
    let mut rates = Vec::new();
    let until = Instant::now() + Duration::from_secs(8);
    while last.is_some() && Instant::now() < until {
        std::thread::sleep(Duration::from_millis(250));
        if let Some(s) = state_now() {
            rates.push(s.fps);
        }
    }
    // Idle: the rebuilds over and the frame rate taken.
    let (rss, hwm) = pid.map_or((0, 0), rss_and_peak);
    let growth_per_frame = idle_start
        .zip(state_now())
        .filter(|((_, f0), s)| s.frame > *f0)
        .map(|((r0, f0), s)| (rss as f64 - r0 as f64) / (s.frame - f0) as f64);
    // The editor's mappings once idle, for a look at what the owners do not count.
    if let Some(pid) = pid {
        let name = file
            .and_then(|f| f.file_stem())
            .map_or("default".into(), |n| n.to_string_lossy().into_owned());
        std::fs::copy(
            format!("/proc/{pid}/smaps"),
            dir.join(format!("smaps-{name}")),
        )
        .ok();
    }
    if let Some(s) = state_now().filter(|_| last.is_some()) {
        last = Some(s);
    }
    stop(&mut child);
    rates.sort_by(f64::total_cmp);
    let fps = rates.get(rates.len() / 2).copied().unwrap_or(0.0);
    if let Some(s) = &last {
        eprintln!("view: {}", s.view);
        for n in &s.notices {
            eprintln!(
                "{}: {n}",
                file.map_or("default scene".into(), |f| f.display().to_string())
            );
        }
    }
    let trace = last.as_ref().and_then(|s| s.trace);
    let memory = last.map(|s| s.memory).unwrap_or_else(|| {
        panic!(
            "{}: the tree never held {triangles} triangles",
            file.map_or("default scene".into(), |f| f.display().to_string())
        )
    });
    Run {
        memory,
        fps,
        rss,
        hwm,
        first: fill.first,
        all: fill.all,
        parsed: fill.parsed,
        traced: fill.traced,
        pictured: fill.pictured,
        frames_to_first: fill.frames_to_first,
        frames_to_traced: fill.frames_to_traced,
        frames_to_picture: fill.frames_to_picture,
        quiet,
        idle,
        growth_per_frame,
        trace,
        peak: probe.peak,
    }
}

/// `treelight render` of `file` into `dir`, headless: its peak resident set (bytes, the kernel's
/// maximum for the finished process) and its wall time, or why it failed.
fn render_peak(file: &Path, dir: &Path) -> Result<(u64, f64), String> {
    let start = Instant::now();
    // Under heaptrack too with TREELIGHT_MEMORY_HEAPTRACK=1 (its profile `heaptrack-render`).
    let mut cmd = if std::env::var_os("TREELIGHT_MEMORY_HEAPTRACK").is_some() {
        let mut c = Command::new("heaptrack");
        c.arg("-o")
            .arg(dir.join("heaptrack-render"))
            .arg(env!("CARGO_BIN_EXE_treelight"));
        c
    } else {
        Command::new(env!("CARGO_BIN_EXE_treelight"))
    };
    let child = cmd
        .arg("render")
        .arg(file)
        .arg("--out")
        .arg(dir.join("render.png"))
        .arg("--overwrite")
        .args(["--width", "320", "--height", "200", "--spp", "4"])
        .env("TREELIGHT_CONFIG_DIR", dir.join("config"))
        .env("TREELIGHT_CACHE_DIR", dir.join("config").join("cache"))
        .stdout(std::process::Stdio::null())
        .stderr(
            std::fs::File::create(dir.join("render.log"))
                .map_or(std::process::Stdio::null(), Into::into),
        )
        .spawn()
        .map_err(|e| format!("cannot start treelight render: {e}"))?;
    let mut status = 0;
    // SAFETY: a zeroed rusage is valid; wait4 fills it for our own child, which is reaped here
    // (the Child handle is not waited on again).
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    let waited = unsafe { libc::wait4(child.id() as i32, &mut status, 0, &mut usage) };
    if waited < 0 {
        return Err(format!("wait4: {}", std::io::Error::last_os_error()));
    }
    if !(libc::WIFEXITED(status) && libc::WEXITSTATUS(status) == 0) {
        return Err(format!(
            "treelight render failed (status {status}); see {}",
            dir.join("render.log").display()
        ));
    }
    // ru_maxrss is in kilobytes on Linux.
    Ok((usage.ru_maxrss as u64 * 1024, start.elapsed().as_secs_f64()))
}

/// A line on `treelight render` of the assembly `file`: its peak per triangle and its time.
fn render_line(parts: usize, rows: usize, triangles: usize, file: &Path, dir: &Path) -> String {
    match render_peak(file, dir) {
        Ok((peak, seconds)) => format!(
            "{parts} × {rows}: `treelight render` peaked at {:.0} MiB, {:.0} B a triangle, in {seconds:.1} s",
            peak as f64 / 1048576.0,
            peak as f64 / triangles as f64
        ),
        Err(why) => format!("{parts} × {rows}: {why}"),
    }
}

/// The fill's moments, from the reports of a run until every triangle is in and settled.
#[derive(Default)]
struct Fill {
    first: Option<f64>,
    all: Option<f64>,
    parsed: Option<f64>,
    traced: Option<f64>,
    pictured: Option<f64>,
    frames_to_first: Option<u64>,
    frames_to_traced: Option<u64>,
    frames_to_picture: Option<u64>,
    /// The report once settled with every triangle in; `None` if that never came (15 minutes).
    last: Option<EditorState>,
}

/// Follows the reports at `state` until `triangles` are in the tree, the path tracer's buffers
/// hold them, and the scene has settled.
fn follow_fill(state: &Path, start: Instant, triangles: u64, probe: &mut PeakProbe) -> Fill {
    let mut f = Fill::default();
    // (since when, the buffers' size then, the frame then)
    let mut settled_since = None::<(Instant, u64, u64)>;
    let mut parse_frame = None;
    while start.elapsed() < Duration::from_secs(900) {
        // Finely until the first triangles and traced frame; then coarser, as each look parses a
        // report of hundreds of kilobytes on a machine whose two cores the editor needs.
        let fine = f.first.is_none() || f.traced.is_none();
        std::thread::sleep(Duration::from_millis(if fine { 50 } else { 250 }));
        let Some(s) = std::fs::read_to_string(state)
            .ok()
            .and_then(|t| ron::from_str::<EditorState>(&t).ok())
        else {
            continue;
        };
        let t = start.elapsed().as_secs_f64();
        probe.see(&s, "fill");
        if f.parsed.is_none() && s.notices.iter().any(|n| n.starts_with("opened ")) {
            f.parsed = Some(t);
            parse_frame = Some(s.frame);
        }
        let since_parse = parse_frame.map(|p| s.frame.saturating_sub(p));
        if s.memory.triangles > 0 && f.first.is_none() {
            f.first = Some(t);
            f.frames_to_first = since_parse;
        }
        if f.traced.is_none() && s.memory.triangles > 0 && s.traced_geometry {
            f.traced = Some(t);
            f.frames_to_traced = since_parse;
        }
        // The traced view's samples restart with each change: a whole picture showing some of
        // the file's triangles (after a frame traced them: a sweep of the sky alone, before the
        // path tracer has the first triangles, does not count).
        if f.pictured.is_none() && f.traced.is_some() && s.samples >= 1 {
            f.pictured = Some(t);
            f.frames_to_picture = since_parse;
        }
        let complete = s.memory.triangles >= triangles;
        if complete && f.all.is_none() {
            f.all = Some(t);
        }
        // Settled, the path tracer's buffers holding every triangle's records (node, triangle and
        // shading; its uploads follow the tree, at times many seconds behind), and no longer
        // growing over 3 s and 10 frames.
        // (Node records: a third of the inner nodes at the least, as a record holds at most two
        // expanded children.)
        let buffers = s.memory.scene_buffers;
        let per_triangle: u64 = [BufferKind::Triangles, BufferKind::Attributes]
            .map(BufferKind::record_bytes)
            .iter()
            .sum();
        let nodes = s.memory.triangles.saturating_sub(1) / 3 * BufferKind::Nodes.record_bytes();
        let complete = complete && buffers >= s.memory.triangles * per_triangle + nodes;
        match settled_since {
            Some((since, b, frame)) if complete && s.settled && b == buffers => {
                // Ten more frames, or none needed: an editor at rest draws none.
                if since.elapsed() >= Duration::from_secs(3)
                    && (s.frame >= frame + 10 || s.at_rest)
                    && s.memory.tree > 0
                {
                    f.last = Some(s);
                    break;
                }
            }
            _ if complete && s.settled => {
                settled_since = Some((Instant::now(), buffers, s.frame));
            }
            _ => settled_since = None,
        }
    }
    f
}

/// The trace's last frame, for the lines under the table.
fn trace_line(trace: Option<(u64, Option<f64>)>) -> String {
    match trace {
        Some((samples, Some(ns))) => format!(
            "{samples} pixel samples a frame at {:.1} µs each ({:.0} ms)",
            ns / 1e3,
            samples as f64 * ns / 1e6
        ),
        Some((samples, None)) => format!("{samples} pixel samples a frame, cost not yet known"),
        None => "not traced".into(),
    }
}

/// Bytes a frame as KiB, or `?` where no frame was drawn.
fn kib(bytes: Option<f64>) -> String {
    bytes.map_or("?".into(), |b| format!("{:.1}", b / 1024.0))
}

fn main() {
    let busy = std::env::args().any(|a| a == "busy");
    let sizes: Vec<(usize, usize)> = {
        let args: Vec<(usize, usize)> = std::env::args()
            .skip(1)
            .filter_map(|a| {
                let (p, r) = a.split_once('x')?;
                Some((p.parse().ok()?, r.parse().ok()?))
            })
            .collect();
        if args.is_empty() {
            vec![(100, 100), (400, 100), (400, 123)]
        } else {
            args
        }
    };
    let dir: PathBuf =
        std::env::temp_dir().join(format!("treelight-memory-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    if std::env::args().any(|a| a == "render") {
        for (parts, rows) in sizes {
            let (file, triangles) = assembly::generated_assembly(&dir, parts, rows);
            println!("- {}", render_line(parts, rows, triangles, &file, &dir));
            std::fs::remove_file(&file).ok();
            std::fs::remove_file(dir.join("assembly.bin")).ok();
        }
        return;
    }
    let base = run(None, 1, 0, &dir);
    println!(
        "\nThe default scene: {:.0} MiB resident, {:.0} MiB at peak, {:.1} frames/s, resident set \
         growing by {} KiB a frame once idle.\n",
        base.rss as f64 / 1048576.0,
        base.hwm as f64 / 1048576.0,
        base.fps,
        kib(base.growth_per_frame),
    );
    println!(
        "| assembly | triangles | mesh assets | parked meshes | BVH arrays | BVH shading | scene buffers and their record map | counted | device allocator's blocks | resident once idle (the whole process) | peak, VmHWM (the whole process) | parsed (s) | then first in tree / first traced frame of them / first whole traced picture, s (frames) | all in tree (s) | view keeps its samples (s) | rebuilds over (s) | frames/s then | growth once idle, KiB a frame |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    let mut peaks = Vec::new();
    let mut traces = vec![format!("default scene: {}", trace_line(base.trace))];
    let mut renders = Vec::new();
    for (parts, rows) in sizes {
        let (file, triangles) = assembly::generated_assembly(&dir, parts, rows);
        let spinning = busy.then(busy_core);
        let r = run(Some(&file), triangles as u64, parts as u64, &dir);
        if let Some(flag) = spinning {
            flag.store(false, std::sync::atomic::Ordering::Relaxed);
        }
        renders.push(render_line(parts, rows, triangles, &file, &dir));
        let m = &r.memory;
        let n = triangles as f64;
        let cell = |b: u64| format!("{:.0} MiB, {:.0} B", b as f64 / 1048576.0, b as f64 / n);
        let counted =
            m.mesh_assets + m.parked_bytes + m.tree + m.shading + m.scene_buffers + m.record_layout;
        println!(
            "| {parts} × {}k | {triangles} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {:.2} | {:.2} ({}) / {:.2} ({}) / {:.2} ({}) | {:.1} | {:.1} | {:.0} | {:.1} | {} |",
            rows * rows * 2 / 1000,
            cell(m.mesh_assets),
            cell(m.parked_bytes),
            cell(m.tree),
            cell(m.shading),
            cell(m.scene_buffers + m.record_layout),
            cell(counted),
            cell(m.gpu_reserved),
            cell(r.rss),
            cell(r.hwm),
            r.parsed.unwrap_or(f64::NAN),
            r.first.unwrap_or(f64::NAN) - r.parsed.unwrap_or(f64::NAN),
            r.frames_to_first.map_or("?".into(), |f| f.to_string()),
            r.traced.unwrap_or(f64::NAN) - r.parsed.unwrap_or(f64::NAN),
            r.frames_to_traced.map_or("?".into(), |f| f.to_string()),
            r.pictured.unwrap_or(f64::NAN) - r.parsed.unwrap_or(f64::NAN),
            r.frames_to_picture.map_or("?".into(), |f| f.to_string()),
            r.all.unwrap_or(f64::NAN),
            r.quiet.unwrap_or(f64::NAN),
            r.idle,
            r.fps,
            kib(r.growth_per_frame),
        );
        traces.push(format!("{parts} × {rows}: {}", trace_line(r.trace)));
        if let Some((rss, m, phase)) = &r.peak {
            peaks.push(format!(
                "{parts} × {rows}: the process's peak (VmHWM) {}; the largest resident set polled \
                 {}, during the {phase}; mesh \
                 assets {}, parked meshes {}, BVH arrays {}, BVH shading {}, scene buffers and their record map {}, device allocator's \
                 blocks {}; {} triangles in the tree then; the largest frame's writes so far {}, \
                 by the run's end {}",
                cell(r.hwm),
                cell(*rss),
                cell(m.mesh_assets),
                cell(m.parked_bytes),
                cell(m.tree),
                cell(m.shading),
                cell(m.scene_buffers + m.record_layout),
                cell(m.gpu_reserved),
                m.triangles,
                cell(m.largest_upload),
                cell(r.memory.largest_upload),
            ));
        }
        std::fs::remove_file(&file).ok();
        std::fs::remove_file(dir.join("assembly.bin")).ok();
    }
    println!("\nThe view's trace in its last frame once idle:");
    for t in traces {
        println!("- {t}");
    }
    println!("\n`treelight render` of each file, 320×200, 4 samples a pixel, headless:");
    for r in renders {
        println!("- {r}");
    }
    println!(
        "\nThe largest resident set seen in the polls (fill: every 50 to 250 ms; bakes and rebuilds: \
         every 250 to 500 ms), with the owners' counts in the report read then (per triangle of \
         the whole assembly):"
    );
    for p in peaks {
        println!("- {p}");
    }
    // The generated files are gone; the editors' logs and mappings stay for a look.
    println!("\nThe editors' logs and mappings: {}", dir.display());
}
