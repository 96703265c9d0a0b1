//! The bench's post-pass flags, end to end: `--post-finish` and `--post-finish-moves` change the
//! short pass's treelet sweeps and finishing moves, a `--post-fraction` list makes a row per
//! fraction, and all label their rows and refuse what they cannot run.

mod support;

use support::{bench_csv, bench_refused, csv_rows};

/// The short post-pass's row on the synthetic `scene` with the flags `extra` (none: the short pass
/// as it is): its settings label and SAH cost, read back from the CSV.
fn short_pass(scene: &str, extra: &[&str]) -> (String, f32) {
    let name = format!("post-{scene}-{}", extra.join("_")).replace(['@', ',', '-', ':'], "_");
    let mut args = vec!["--scene", scene, "--method", "incru-post", "--post-short"];
    args.extend(extra);
    let (_, text) = bench_csv(&name, &args);
    let row = &csv_rows(&text)[0];
    (row[4].clone(), row[7].parse().unwrap())
}

#[test]
fn the_short_pass_s_sweeps_lower_its_cost_and_can_be_turned_off_or_changed() {
    let (short, with) = short_pass("hairball:3000", &[]);
    let (off, without) = short_pass("hairball:3000", &["--post-finish", "off"]);
    let (changed, other) = short_pass("hairball:3000", &["--post-finish", "4@0,8@0.01"]);
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
fn the_short_pass_s_finishing_moves_lower_its_cost_and_can_be_turned_off() {
    // A scene large enough for the moves to find better places at the CSV's four decimals.
    let scene = "hairball:20000";
    let (short, with) = short_pass(scene, &[]);
    let (off, without) = short_pass(scene, &["--post-finish-moves", "0"]);
    let (wider, more) = short_pass(scene, &["--post-finish-moves", "0.0003"]);
    assert_eq!(off, "short finish moves=0");
    assert_eq!(wider, "short finish moves=0.0003");
    assert!(with < without, "{with} against {without} without the moves");
    assert!(
        more < with,
        "{more} over more nodes against {with} ({short})"
    );
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

#[test]
fn bad_finishing_moves_are_refused_with_their_reason() {
    for (area, reason) in [
        ("-0.01", "not a finite number >= 0"),
        ("nan", "not a finite number >= 0"),
        ("inf", "not a finite number >= 0"),
        ("most", "area fraction `most`"),
    ] {
        let err = bench_refused(&[
            "--scene",
            "hairball:100",
            "--method",
            "incru-post",
            &format!("--post-finish-moves={area}"),
        ]);
        assert!(err.contains(reason), "{area}: {err}");
    }
}

#[test]
fn a_list_of_post_fractions_builds_one_post_pass_row_each_and_summarises_each() {
    let (table, text) = bench_csv(
        "post-fractions",
        &[
            "--scene",
            "hairball:20000",
            "--method",
            "incru,incru-post",
            "--post-short",
            "--post-fraction",
            "0.05,0.4",
            "--update-fraction-sweep",
            "0.05:0.1:0.05",
        ],
    );
    // Rows: IncrU once per k_u, the post-pass once per k_u and fraction.
    let rows: Vec<(String, String, f32)> = csv_rows(&text)
        .into_iter()
        .map(|r| (r[3].clone(), r[4].clone(), r[7].parse().unwrap()))
        .collect();
    let labels: Vec<(&str, &str)> = rows.iter().map(|r| (&r.0[..], &r.1[..])).collect();
    assert_eq!(
        labels,
        [
            ("incru", "k_u=0.05"),
            ("incru", "k_u=0.1"),
            ("incru-post", "k_u=0.05 fraction=0.05 short"),
            ("incru-post", "k_u=0.05 fraction=0.4 short"),
            ("incru-post", "k_u=0.1 fraction=0.05 short"),
            ("incru-post", "k_u=0.1 fraction=0.4 short"),
        ]
    );
    // The wider rounds end lower from the same build at each k_u.
    assert!(rows[3].2 < rows[2].2, "{rows:?}");
    assert!(rows[5].2 < rows[4].2, "{rows:?}");
    // The summary has a line per fraction, over its own draws.
    for fraction in ["0.05", "0.4"] {
        let needle = format!("| incru-post (fraction={fraction} short) |");
        assert!(table.contains(&needle), "no {needle} in:\n{table}");
    }
}

#[test]
fn several_post_fractions_will_not_export_one_of_their_trees() {
    let err = bench_refused(&[
        "--scene",
        "hairball:100",
        "--method",
        "incru-post",
        "--post-fraction",
        "0.1,0.2",
        "--export-bvh",
        "never.tlbvh",
    ]);
    assert!(err.contains("at most one --post-fraction"), "{err}");
}
