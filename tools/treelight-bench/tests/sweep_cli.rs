//! The bench's k_u sweep, end to end: one row per draw for the incremental methods, one for the
//! others, and a summary whose means are those of the rows.

mod support;

use support::{bench_csv, bench_refused, csv_rows};

#[test]
fn a_k_u_sweep_builds_each_draw_and_summarises_them() {
    let (table, text) = bench_csv(
        "sweep",
        &[
            "--scene",
            "hairball:3000",
            "--method",
            "median,incru",
            "--update-fraction-sweep",
            "0.05:0.15:0.05",
            // A cache this small fills many times over 3,000 triangles.
            "--update-cache",
            "500",
        ],
    );

    // Rows: median once, IncrU once per k_u.
    let rows = csv_rows(&text);
    let methods: Vec<(&str, &str)> = rows.iter().map(|r| (&r[3][..], &r[4][..])).collect();
    assert_eq!(
        methods,
        [
            ("median", ""),
            ("incru", "k_u=0.05 N_u=500"),
            ("incru", "k_u=0.1 N_u=500"),
            ("incru", "k_u=0.15 N_u=500"),
        ]
    );
    // Different k_u, different update work: the draws are really different builds.
    let updates: Vec<f64> = rows[1..].iter().map(|r| r[11].parse().unwrap()).collect();
    assert!(
        updates[0] < updates[1] && updates[1] < updates[2],
        "{updates:?}"
    );

    // The summary line's mean is the mean of the three rows' costs.
    let costs: Vec<f64> = rows[1..].iter().map(|r| r[7].parse().unwrap()).collect();
    let mean = costs.iter().sum::<f64>() / 3.0;
    let (_, summary) = table
        .split_once("### k_u sweep 0.05:0.15:0.05")
        .unwrap_or_else(|| panic!("no summary:\n{table}"));
    let line = summary
        .lines()
        .find(|l| l.contains("| incru (N_u=500) |"))
        .unwrap_or_else(|| panic!("no summary line:\n{table}"));
    let cells: Vec<&str> = line.split('|').map(str::trim).collect();
    assert_eq!(cells[5], "3", "{line}");
    let summary_mean: f64 = cells[6].parse().unwrap();
    // The CSV keeps four decimals, the summary means the unrounded costs.
    assert!(
        (summary_mean - mean).abs() < 1e-3,
        "{summary_mean} against {mean}"
    );
    assert!(
        !summary.contains("| median |"),
        "median does not read k_u:\n{summary}"
    );
}

#[test]
fn a_bad_sweep_is_refused_with_its_reason() {
    let err = bench_refused(&[
        "--scene",
        "hairball:100",
        "--method",
        "incru",
        "--update-fraction-sweep",
        "0.1:0.2:0",
    ]);
    assert!(
        err.contains("0.1:0.2:0") && err.contains("step must be positive"),
        "{err}"
    );
}

#[test]
fn a_sweep_will_not_export_one_of_its_trees() {
    let err = bench_refused(&[
        "--scene",
        "hairball:100",
        "--method",
        "incru",
        "--update-fraction-sweep",
        "0.1:0.2:0.1",
        "--export-bvh",
        "never-written.tlbvh",
    ]);
    assert!(err.contains("--export-bvh"), "{err}");
    assert!(!std::path::Path::new("never-written.tlbvh").exists());
}
