//! The worker's threads run at the priorities its configuration gives them: what a user waits for
//! (meshes into the tree) `fill_nice` steps below the app, its background work `worker_nice`
//! below, and the refiner's rebuilds as many steps again. Linux only (nice values per thread,
//! read from /proc). A test binary of its own, so no other test's plugin adds threads of the
//! same names.

#![cfg(target_os = "linux")]

mod support;

use std::time::{Duration, Instant};
use support::headless_app;
use treelight_scene::SceneBvhConfig;

/// The nice value in a `/proc/.../stat` line.
fn nice_of(stat: &str) -> Option<i32> {
    let close = stat.rfind(')')?;
    stat[close + 2..].split_whitespace().nth(16)?.parse().ok()
}

/// Each thread of this process whose name starts with `prefix`: its nice value.
fn nices(prefix: &str) -> Vec<i32> {
    std::fs::read_dir("/proc/self/task")
        .unwrap()
        .flatten()
        .filter_map(|t| {
            let name = std::fs::read_to_string(t.path().join("comm")).ok()?;
            let stat = std::fs::read_to_string(t.path().join("stat")).ok()?;
            name.trim().starts_with(prefix).then_some(())?;
            nice_of(&stat)
        })
        .collect()
}

#[test]
fn the_fill_runs_above_the_background_work_and_the_rebuilds_below_it() {
    let base = nice_of(&std::fs::read_to_string("/proc/thread-self/stat").unwrap()).unwrap();
    let config = SceneBvhConfig::default();
    assert!(
        config.fill_nice < config.worker_nice,
        "the fill is the higher of the two"
    );
    let mut app = headless_app(config);
    app.update();
    // Linux keeps 15 bytes of a thread's name: `treelight-bvh-0`, `treelight-bvh-i`(dle-0),
    // `treelight-bvh-r`(efine).
    let (fill, background, refiner) = ("treelight-bvh-0", "treelight-bvh-i", "treelight-bvh-r");
    let start = Instant::now();
    while [fill, background, refiner]
        .iter()
        .any(|p| nices(p).is_empty())
    {
        assert!(
            start.elapsed() < Duration::from_secs(10),
            "the worker's threads did not all start"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    let at = |steps: i32| (base + steps).min(19);
    assert_eq!(nices(fill), vec![at(config.fill_nice)], "the fill's pool");
    assert_eq!(
        nices("treelight-scene"),
        vec![at(config.fill_nice)],
        "the worker's own thread"
    );
    assert_eq!(
        nices(background),
        vec![at(config.worker_nice)],
        "the background thread"
    );
    assert_eq!(
        nices(refiner),
        vec![at(2 * config.worker_nice)],
        "the refiner, below the background"
    );
    drop(app);
}
