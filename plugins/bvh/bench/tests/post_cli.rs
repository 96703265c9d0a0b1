//! The bench's post-pass flags, end to end: `--post-finish` changes the short pass's treelet
//! sweeps, labels its rows, and refuses what it cannot run.

mod support;

use support::{bench_ok, bench_refused};

/// The short post-pass's row on a synthetic scene with `--post-finish finish` (none: the short
/// pass's own sweeps): its settings label and SAH cost, read back from the CSV.
fn short_pass(finish: Option<&str>) -> (String, f32) {
    let dir = std::env::temp_dir().join(format!(
        "treelight-post-{}-{}",
        std::process::id(),
        finish.unwrap_or("default").replace(['@', ','], "_")
    ));
    std::fs::create_dir_all(&dir).unwrap();
    let csv = dir.join("rows.csv");
    let mut args = vec![
        "--scene",
        "hairball:3000",
        "--method",
        "incru-post",
        "--post-short",
        "--ao-rays",
        "0",
        "--resolution",
        "8x8",
        "--csv",
        csv.to_str().unwrap(),
    ];
    if let Some(f) = finish {
        args.extend(["--post-finish", f]);
    }
    bench_ok(&args);
    let text = std::fs::read_to_string(&csv).unwrap();
    std::fs::remove_dir_all(&dir).unwrap();
    let row = text.lines().nth(1).unwrap();
    // The label is quoted and may hold commas; the seven numbers after it do not.
    let (head, numbers) = row.rsplit_once('"').unwrap();
    let label = head.rsplit_once('"').unwrap().1.to_owned();
    let cost = numbers.split(',').nth(3).unwrap().parse().unwrap();
    (label, cost)
}

#[test]
fn the_short_pass_s_sweeps_lower_its_cost_and_can_be_turned_off_or_changed() {
    let (short, with) = short_pass(None);
    let (off, without) = short_pass(Some("off"));
    let (changed, other) = short_pass(Some("4@0,8@0.01"));
    assert_eq!(short, "short");
    assert_eq!(off, "short finish=off");
    assert_eq!(changed, "short finish=4@0,8@0.01");
    assert!(
        with < without,
        "{with} against {without} without the sweeps"
    );
    assert!(
        other < without,
        "{other} against {without} without the sweeps"
    );
    assert_ne!(with, other);
}

#[test]
fn a_bad_finish_is_refused_with_its_reason() {
    for (finish, reason) in [
        ("9@0.01", "not in 3-8"),
        ("6", "is not SIZE@AREA"),
        ("6@-1", "not a finite number >= 0"),
        ("6@nan", "not a finite number >= 0"),
        ("4@0,6@0,8@0", "at most 2 sweeps"),
    ] {
        let err = bench_refused(&[
            "--scene",
            "hairball:100",
            "--method",
            "incru-post",
            "--post-finish",
            finish,
        ]);
        assert!(
            err.contains(finish) && err.contains(reason),
            "{finish}: {err}"
        );
    }
}
