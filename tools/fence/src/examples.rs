//! Running a crate's example from its tests, so an example a user would copy cannot rot.

use std::path::PathBuf;
use std::process::Command;

/// Runs example `name` of package `package` with `args` (built by `cargo test`, or built now when
/// a test runs alone) and returns whether it succeeded, with its output and errors together.
pub fn run_example(package: &str, name: &str, args: &[&str]) -> (bool, String) {
    // A test binary lies in `target/PROFILE/deps`; the examples in `target/PROFILE/examples`.
    let exe: PathBuf = std::env::current_exe()
        .expect("the test's own path")
        .parent()
        .and_then(|deps| deps.parent())
        .expect("a target folder")
        .join("examples")
        .join(name);
    if !exe.exists() {
        let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
        let status = Command::new(cargo)
            .args(["build", "-p", package, "--example", name])
            .status()
            .expect("cargo runs");
        assert!(status.success(), "the example {name} does not build");
    }
    let out = Command::new(&exe)
        .args(args)
        .output()
        .unwrap_or_else(|e| panic!("{}: {e}", exe.display()));
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    (out.status.success(), text)
}
