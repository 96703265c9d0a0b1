//! The document's readers of files a user can be handed (projects and `--commands` scripts),
//! fuzzed under a counting allocator: mutations of real ones (bytes flipped, lines repeated,
//! brackets nested, numbers blown up, the text cut short) never panic, answer within seconds,
//! and never allocate past the memory budget; a file too large for the budget is refused
//! before it is parsed.

use std::path::Path;
use std::time::{Duration, Instant};
use treelight_document::project::format::read_project;
use treelight_document::project::script::read_commands;
use treelight_test_support::Xorshift;
use treelight_test_support::counting;

#[global_allocator]
static ALLOCATOR: counting::Counting = counting::Counting;

/// The budget in MiB every read here gets (`TREELIGHT_IMPORT_MEMORY_MIB`), and the slack over
/// it allowed for small bookkeeping.
const BUDGET_MIB: u64 = 64;
const SLACK: u64 = 8 << 20;

/// One mutation of `text`.
fn mutate(text: &str, rng: &mut Xorshift) -> Vec<u8> {
    let mut bytes = text.as_bytes().to_vec();
    match rng.below(6) {
        0 => {
            for _ in 0..1 + rng.below(8) {
                let at = rng.below(bytes.len());
                bytes[at] = rng.next_u64() as u8;
            }
        }
        1 => {
            // A line repeated many times.
            let lines: Vec<&str> = text.lines().collect();
            let line = lines[rng.below(lines.len())];
            let at = rng.below(bytes.len());
            let repeated = format!("{line}\n").repeat(1 + rng.below(200_000));
            bytes.splice(at..at, repeated.into_bytes());
        }
        2 => {
            // Brackets nested deeper than any reader should follow.
            let depth = 1 + rng.below(100_000);
            let at = rng.below(bytes.len());
            let open = ["(", "[", "Some("][rng.below(3)];
            bytes.splice(at..at, open.repeat(depth).into_bytes());
        }
        3 => {
            // A number blown up.
            let at = rng.below(bytes.len());
            let n = [
                "1e39",
                "-1e39",
                "NaN",
                "inf",
                "18446744073709551616",
                "99999999999",
            ][rng.below(6)];
            bytes.splice(at..at, n.bytes());
        }
        4 => bytes.truncate(rng.below(bytes.len())),
        _ => {
            // A string grown long.
            let at = rng.below(bytes.len());
            let s = format!("\"{}\"", "x".repeat(rng.below(4 << 20)));
            bytes.splice(at..at, s.into_bytes());
        }
    }
    bytes
}

/// Reads `path` with `read`, checking the peak and the time.
fn check<T, E: std::fmt::Display>(
    what: &str,
    path: &Path,
    read: impl FnOnce(&Path) -> Result<T, E>,
) {
    let start = Instant::now();
    let (result, peak) = counting::peak_during(|| {
        std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| read(path)))
    });
    let Ok(result) = result else {
        panic!("{what}: the reader panicked");
    };
    assert!(
        peak <= (BUDGET_MIB << 20) + SLACK,
        "{what}: {peak} bytes at the peak"
    );
    assert!(
        start.elapsed() < Duration::from_secs(10),
        "{what}: {:?}",
        start.elapsed()
    );
    if let Err(e) = result {
        assert!(
            e.to_string().contains(&*path.to_string_lossy()),
            "{what}: {e}"
        );
    }
}

#[test]
fn mutated_projects_and_scripts_never_panic_hang_or_pass_the_budget() {
    // SAFETY: this binary's only test sets it before any thread reads the environment.
    unsafe { std::env::set_var(treelight_import::BUDGET_VARIABLE, BUDGET_MIB.to_string()) };
    let dir = std::env::temp_dir().join(format!("treelight-reader-budgets-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let project = treelight_document::default_scene::DEFAULT_PROJECT;
    let script = include_str!("../../../docs/edits-example.ron");
    let cases: usize = std::env::var("TREELIGHT_FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(400);
    let mut rng = Xorshift(0x9E37_79B9_7F4A_7C15);
    for k in 0..cases {
        let path = dir.join("case.treelight");
        std::fs::write(&path, mutate(project, &mut rng)).unwrap();
        check(&format!("project mutation {k}"), &path, read_project);
        let path = dir.join("case.ron");
        std::fs::write(&path, mutate(script, &mut rng)).unwrap();
        check(&format!("script mutation {k}"), &path, read_commands);
    }
    // Text whose parse would pass the budget is refused before it is read.
    let big = dir.join("big.treelight");
    let line = "(id: (1), name: \"g\", transform: (translation: (0.0, 0.0, 0.0)), kind: Empty),\n";
    std::fs::write(
        &big,
        format!("(version: 4, objects: [{}])", line.repeat(120_000)),
    )
    .unwrap();
    check("a project too large for the budget", &big, read_project);
    assert!(
        read_project(&big)
            .unwrap_err()
            .to_string()
            .contains("larger than")
    );
    std::fs::remove_dir_all(&dir).ok();
}
