//! What the bench's CLI tests share.

// Each test binary uses a part of it.
#![allow(dead_code)]

use std::process::{Command, Output};

/// Runs the bench with `args`.
pub fn bench(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_treelight-bench"))
        .args(args)
        .output()
        .unwrap()
}

/// Runs the bench with `args`, which must succeed; its standard output.
pub fn bench_ok(args: &[&str]) -> String {
    let out = bench(args);
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

/// Runs the bench with `args`, which it must refuse; its standard error.
pub fn bench_refused(args: &[&str]) -> String {
    let out = bench(args);
    assert!(!out.status.success(), "{args:?} was not refused");
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// Runs the bench with `args` and no traced image, writing its rows as CSV into a fresh folder
/// named by `name` (unique per test); its standard output and the CSV's text.
pub fn bench_csv(name: &str, args: &[&str]) -> (String, String) {
    let dir = std::env::temp_dir().join(format!("treelight-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let csv = dir.join("rows.csv");
    let mut all = args.to_vec();
    all.extend([
        "--ao-rays",
        "0",
        "--resolution",
        "8x8",
        "--csv",
        csv.to_str().unwrap(),
    ]);
    let table = bench_ok(&all);
    let text = std::fs::read_to_string(&csv).unwrap();
    std::fs::remove_dir_all(&dir).unwrap();
    (table, text)
}

/// The CSV's data rows (the header skipped), each split into its fields: commas inside a quoted
/// field (the scene name, the settings label) do not split it, and the quotes are dropped.
pub fn csv_rows(text: &str) -> Vec<Vec<String>> {
    text.lines()
        .skip(1)
        .map(|line| {
            let mut fields = vec![String::new()];
            let mut quoted = false;
            for c in line.chars() {
                match c {
                    '"' => quoted = !quoted,
                    ',' if !quoted => fields.push(String::new()),
                    _ => fields.last_mut().unwrap().push(c),
                }
            }
            fields
        })
        .collect()
}
