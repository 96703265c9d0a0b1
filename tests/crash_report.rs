//! The editor's own crash leaves its message and backtrace in the cache folder for the next start;
//! a panic that a job contains leaves none. Run in a child process, which really dies.

use std::path::PathBuf;
use std::process::Command;

const CHILD: &str = "TREELIGHT_TEST_CRASH_DIR";

#[test]
fn a_crash_leaves_its_report_and_a_contained_panic_does_not() {
    if let Ok(dir) = std::env::var(CHILD) {
        treelight::editor::files::crash_report::install_hook_in(PathBuf::from(&dir));
        let contained = treelight_document::files::contain::contain(
            || "a thumbnail".into(),
            || -> u32 { panic!("contained, not a crash") },
        );
        assert!(contained.is_err());
        let written = std::fs::read_dir(&dir).unwrap().count();
        assert_eq!(written, 0, "a contained panic wrote a report");
        panic!("the editor's own bug");
    }
    let dir = std::env::temp_dir().join(format!("treelight-crash-test-{}", std::process::id()));
    std::fs::remove_dir_all(&dir).ok();
    std::fs::create_dir_all(&dir).unwrap();
    let out = Command::new(std::env::current_exe().unwrap())
        .args([
            "--exact",
            "a_crash_leaves_its_report_and_a_contained_panic_does_not",
            "--nocapture",
            "--test-threads",
            "1",
        ])
        .env(CHILD, &dir)
        .output()
        .unwrap();
    assert!(!out.status.success(), "the child did not crash");
    let reports = treelight::editor::files::crash_report::reports_to_show(&dir);
    assert_eq!(reports.len(), 1, "{reports:?}");
    let text = std::fs::read_to_string(&reports[0]).unwrap();
    assert!(text.contains("the editor's own bug"), "{text}");
    assert!(text.contains("Backtrace:"), "{text}");
    assert!(!text.contains("contained, not a crash"), "{text}");
    std::fs::remove_dir_all(&dir).ok();
}
