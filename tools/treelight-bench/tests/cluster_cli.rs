//! The bench's `--cluster-levels`, end to end: it reaches the incremental builders that cluster
//! (IncrU, IncrUP), labels their rows, leaves IncrUPB's batches alone, and refuses what is not a
//! count.

mod support;

use support::{bench_csv, bench_refused, csv_rows};

/// Each row's method, settings label and SAH cost, from the CSV of a run with `levels`.
fn rows(levels: &str) -> Vec<(String, String, f32)> {
    let (_, text) = bench_csv(
        &format!("cluster-levels-{levels}"),
        &[
            "--scene",
            "hairball:3000",
            "--method",
            "incr,incrup,incrupb",
            "--cluster-levels",
            levels,
        ],
    );
    csv_rows(&text)
        .into_iter()
        .map(|r| (r[3].clone(), r[4].clone(), r[7].parse().unwrap()))
        .collect()
}

#[test]
fn cluster_levels_reach_the_clustering_builders_only() {
    let (pairs, quads) = (rows("1"), rows("2"));
    let labels: Vec<(&str, &str)> = quads.iter().map(|r| (&r.0[..], &r.1[..])).collect();
    assert_eq!(
        labels,
        [
            ("incr", "cluster levels=2"),
            ("incrup", "cluster levels=2"),
            ("incrupb", ""),
        ]
    );
    // Other clusters, other trees; IncrUPB builds its batches the same way either way.
    assert_ne!(pairs[0].2, quads[0].2, "{pairs:?} {quads:?}");
    assert_ne!(pairs[1].2, quads[1].2, "{pairs:?} {quads:?}");
    assert_eq!(pairs[2].2, quads[2].2, "{pairs:?} {quads:?}");
}

#[test]
fn a_cluster_level_that_is_not_a_count_is_refused() {
    let err = bench_refused(&[
        "--scene",
        "hairball:100",
        "--method",
        "incr",
        "--cluster-levels",
        "two",
    ]);
    assert!(
        err.contains("--cluster-levels") && err.contains("two"),
        "{err}"
    );
}
