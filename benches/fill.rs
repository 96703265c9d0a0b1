//! How long a large assembly takes to get into the scene's tree in the editor, on a quiet machine
//! and with one core taken by a busy loop, and where the process's CPU time went meanwhile: the
//! editor binary under Xvfb opens a generated assembly of bumpy tiles and its `--state` report is
//! read every 100 ms until every triangle is in the tree. Each run prints the seconds from the
//! start to the parse (the "opened" notice) and to the last triangle in, the frames drawn between,
//! and the CPU seconds each kind of thread used between the two: the scene worker and its build
//! pool (the fill), its background thread and refiner (bakes, updates, rebuilds), llvmpipe's named raster threads, and the rest (the main thread,
//! Bevy's task pools and the adapter's unnamed compute threads, which Linux cannot tell apart
//! by name). Medians follow each mode's runs. Unlike the `memory` bench it stops at the fill, so
//! a few runs take minutes, not tens of them.
//!
//! Run: `cargo bench --workspace --profile dev --bench fill [-- [quiet|busy] [runs N]
//! [PARTSxROWS]]` (default: both modes, 3 runs each, `400x100`: 8M triangles in 400 meshes).
//! Needs Xvfb and Mesa's software Vulkan, as the tests do.

#[path = "../plugins/document/tests/support/assembly.rs"]
mod assembly;
#[path = "support/editor_process.rs"]
mod editor_process;

use editor_process::{busy_core, editor_command, editor_pid, stop};
use std::collections::HashMap;
use std::path::Path;
use std::time::{Duration, Instant};
use treelight::report::EditorState;

/// The kinds of thread whose CPU time a run adds up, in the order they are printed.
const KINDS: [&str; 4] = [
    "worker: fill",
    "worker: background",
    "llvmpipe raster",
    "the rest",
];

/// Which of [`KINDS`] a thread of the editor is, by its name (Linux keeps 15 bytes of it).
fn kind(name: &str) -> usize {
    if name.starts_with("treelight-scene")
        || name
            .strip_prefix("treelight-bvh-")
            .is_some_and(|n| n.starts_with(|c: char| c.is_ascii_digit()))
    {
        0
    } else if name.starts_with("treelight-bvh-") {
        1
    } else if name.starts_with("llvmpipe") {
        2
    } else {
        3
    }
}

/// A thread of the editor: its id, its name and the CPU seconds it used so far.
type ThreadCpu = (u32, String, f64);

/// Each live thread of `pid`.
fn threads(pid: u32) -> Vec<ThreadCpu> {
    // SAFETY: sysconf only reads a configuration value.
    let tick = unsafe { libc::sysconf(libc::_SC_CLK_TCK) }.max(1) as f64;
    let Ok(dir) = std::fs::read_dir(format!("/proc/{pid}/task")) else {
        return Vec::new();
    };
    dir.flatten()
        .filter_map(|e| {
            let tid: u32 = e.file_name().to_string_lossy().parse().ok()?;
            let stat = std::fs::read_to_string(e.path().join("stat")).ok()?;
            let (open, close) = (stat.find('(')?, stat.rfind(')')?);
            let fields: Vec<&str> = stat[close + 2..].split_whitespace().collect();
            let ticks: f64 =
                fields.get(11)?.parse::<f64>().ok()? + fields.get(12)?.parse::<f64>().ok()?;
            Some((tid, stat[open + 1..close].to_string(), ticks / tick))
        })
        .collect()
}

/// CPU seconds per kind of thread from `before` to `after` (a thread born meanwhile counts
/// from zero; one that ended is lost).
fn cpu_between(before: &[ThreadCpu], after: &[ThreadCpu]) -> [f64; 4] {
    let then: HashMap<u32, f64> = before.iter().map(|(t, _, s)| (*t, *s)).collect();
    let mut sums = [0.0; 4];
    for (tid, name, s) in after {
        sums[kind(name)] += s - then.get(tid).copied().unwrap_or(0.0);
    }
    sums
}

/// One run's figures.
struct Fill {
    parsed: f64,
    all_in: f64,
    frames: u64,
    cpu: [f64; 4],
}

/// Runs the editor on `file` until `triangles` are in the tree (or 10 minutes pass: `None`).
fn run(file: &Path, triangles: u64, dir: &Path) -> Option<Fill> {
    let (state, mut cmd) = editor_command(Some(file), dir);
    let start = Instant::now();
    let mut child = cmd.spawn().expect("xvfb-run");
    let mut pid = None;
    // When the file was parsed: seconds, the frame, the threads' CPU.
    let mut at_parse: Option<(f64, u64, Vec<ThreadCpu>)> = None;
    let mut fill = None;
    while start.elapsed() < Duration::from_secs(600) {
        std::thread::sleep(Duration::from_millis(100));
        pid = pid.or_else(|| editor_pid(child.id()));
        let Some(s) = std::fs::read_to_string(&state)
            .ok()
            .and_then(|t| ron::from_str::<EditorState>(&t).ok())
        else {
            continue;
        };
        let t = start.elapsed().as_secs_f64();
        // The threads' CPU is read at the two moments only: the bench shares the cores it measures.
        let cpu_now = || pid.map(threads).unwrap_or_default();
        if at_parse.is_none() && s.notices.iter().any(|n| n.starts_with("opened ")) {
            at_parse = Some((t, s.frame, cpu_now()));
        }
        if let Some((parsed, frame, before)) = &at_parse
            && s.memory.triangles >= triangles
        {
            fill = Some(Fill {
                parsed: *parsed,
                all_in: t,
                frames: s.frame.saturating_sub(*frame),
                cpu: cpu_between(before, &cpu_now()),
            });
            break;
        }
    }
    stop(&mut child);
    fill
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let runs: usize = args
        .iter()
        .position(|a| a == "runs")
        .and_then(|i| args.get(i + 1)?.parse().ok())
        .unwrap_or(3);
    let (parts, rows) = args
        .iter()
        .find_map(|a| {
            let (p, r) = a.split_once('x')?;
            Some((p.parse().ok()?, r.parse().ok()?))
        })
        .unwrap_or((400, 100));
    let modes: Vec<bool> = match (
        args.iter().any(|a| a == "quiet"),
        args.iter().any(|a| a == "busy"),
    ) {
        (true, false) => vec![false],
        (false, true) => vec![true],
        _ => vec![false, true],
    };
    let dir = std::env::temp_dir().join(format!("treelight-fill-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (file, triangles) = assembly::generated_assembly(&dir, parts, rows);
    println!(
        "{parts} meshes, {triangles} triangles; CPU seconds from the parse until all in the tree: {}",
        KINDS.join(" / ")
    );
    println!(
        "\n| machine | run | parsed (s) | all in tree (s) | fill after the parse (s) | frames (per s) | CPU s: {} |",
        KINDS.join(" / ")
    );
    println!("|---|---|---|---|---|---|---|");
    for busy in modes {
        let label = if busy { "one core busy" } else { "quiet" };
        let mut fills = Vec::new();
        for i in 0..runs {
            let spinning = busy.then(busy_core);
            let fill = run(&file, triangles as u64, &dir);
            if let Some(flag) = spinning {
                flag.store(false, std::sync::atomic::Ordering::Relaxed);
            }
            let Some(f) = fill else {
                println!(
                    "| {label} | {} | the fill did not end within 10 minutes | | | | |",
                    i + 1
                );
                continue;
            };
            let cpu: Vec<String> = f.cpu.iter().map(|c| format!("{c:.1}")).collect();
            println!(
                "| {label} | {} | {:.2} | {:.2} | {:.2} | {} ({:.1}) | {} |",
                i + 1,
                f.parsed,
                f.all_in,
                f.all_in - f.parsed,
                f.frames,
                f.frames as f64 / (f.all_in - f.parsed),
                cpu.join(" / ")
            );
            fills.push(f);
        }
        if !fills.is_empty() {
            let cpu: Vec<String> = (0..KINDS.len())
                .map(|k| format!("{:.1}", median(fills.iter().map(|f| f.cpu[k]).collect())))
                .collect();
            println!(
                "| {label} | median of {} | {:.2} | {:.2} | {:.2} | {:.0} ({:.1}) | {} |",
                fills.len(),
                median(fills.iter().map(|f| f.parsed).collect()),
                median(fills.iter().map(|f| f.all_in).collect()),
                median(fills.iter().map(|f| f.all_in - f.parsed).collect()),
                median(fills.iter().map(|f| f.frames as f64).collect()),
                median(
                    fills
                        .iter()
                        .map(|f| f.frames as f64 / (f.all_in - f.parsed))
                        .collect()
                ),
                cpu.join(" / ")
            );
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}
