//! The editor as a benchmark runs it: under Xvfb with a configuration of its own, found among
//! xvfb-run's processes, stopped with them, and a busy core beside it.

use std::path::{Path, PathBuf};
use std::process::{Child, Command};

/// The editor's process among `child`'s group (xvfb-run starts Xvfb and the editor in it).
pub fn editor_pid(group: u32) -> Option<u32> {
    for entry in std::fs::read_dir("/proc").ok()?.flatten() {
        let Ok(pid) = entry.file_name().to_string_lossy().parse::<u32>() else {
            continue;
        };
        let Ok(stat) = std::fs::read_to_string(format!("/proc/{pid}/stat")) else {
            continue;
        };
        // pid (comm) state ppid pgrp ...
        let Some(close) = stat.rfind(')') else {
            continue;
        };
        let comm = &stat[stat.find('(').map_or(0, |i| i + 1)..close];
        let pgrp = stat[close + 2..].split_whitespace().nth(2);
        if comm == "treelight" && pgrp == Some(&group.to_string()) {
            return Some(pid);
        }
    }
    None
}

/// The editor under Xvfb on `file` (or its default scene), writing its report to the returned
/// path, with its own config folder in `dir`.
pub fn editor_command(file: Option<&Path>, dir: &Path) -> (PathBuf, Command) {
    use std::os::unix::process::CommandExt;
    let state = dir.join("state.ron");
    std::fs::remove_file(&state).ok();
    let config = dir.join("config");
    let mut cmd = Command::new("xvfb-run");
    cmd.args(["-a", "-s", "-screen 0 1600x1000x24"]);
    // TREELIGHT_MEMORY_HEAPTRACK=1 runs the assembly's editor under heaptrack, its profile in the
    // run's folder (far slower: for finding owners, not for the figures).
    if file.is_some() && std::env::var_os("TREELIGHT_MEMORY_HEAPTRACK").is_some() {
        cmd.args(["heaptrack", "-o"]).arg(dir.join("heaptrack"));
    }
    cmd.arg(env!("CARGO_BIN_EXE_treelight"))
        .args(file.map(|f| f.as_os_str()))
        .arg("--state")
        .arg(&state)
        .env("TREELIGHT_CONFIG_DIR", &config)
        .env("TREELIGHT_CACHE_DIR", config.join("cache"))
        .stdout(std::process::Stdio::null())
        .stderr(
            std::fs::File::create(dir.join("editor.log"))
                .map_or(std::process::Stdio::null(), Into::into),
        )
        .process_group(0);
    (state, cmd)
}

/// Stops xvfb-run's whole group: xvfb-run, Xvfb and the editor.
pub fn stop(child: &mut Child) {
    let _ = Command::new("kill")
        .args(["-9", "--", &format!("-{}", child.id())])
        .status();
    let _ = child.wait();
}

/// A thread spinning on a core until the returned flag is cleared: a busy process beside the
/// editor.
pub fn busy_core() -> std::sync::Arc<std::sync::atomic::AtomicBool> {
    use std::sync::atomic::{AtomicBool, Ordering};
    let on = std::sync::Arc::new(AtomicBool::new(true));
    let flag = on.clone();
    std::thread::spawn(move || {
        let mut x = 0u64;
        while flag.load(Ordering::Relaxed) {
            x = std::hint::black_box(x.wrapping_mul(6364136223846793005).wrapping_add(1));
        }
    });
    on
}
