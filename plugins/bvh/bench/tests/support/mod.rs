//! What the bench's CLI tests share.

use std::process::{Command, Output};

/// Runs the bench with `args`.
pub fn bench(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_treelight-bench"))
        .args(args)
        .output()
        .unwrap()
}
