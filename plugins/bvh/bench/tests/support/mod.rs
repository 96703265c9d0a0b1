//! What the bench's CLI tests share.

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
