//! The bench's `--preset`, end to end: each preset is a row of its own, labelled as one, built by
//! the engine's whole policy (so `--update-fraction` leaves it alone), costed like every other row;
//! an unknown preset is refused with the names it takes. And the help fits on one screen.

mod support;

use support::{bench, bench_csv, bench_ok, bench_refused, csv_rows};

/// Each row's method, settings label and SAH cost, from the CSV of a run with `extra`.
fn rows(name: &str, extra: &[&str]) -> Vec<(String, String, f32)> {
    let mut args = vec![
        "--scene",
        "hairball:4000",
        "--method",
        "sah,incrupb",
        "--preset",
        "fast,balanced,best",
    ];
    args.extend_from_slice(extra);
    let (_, text) = bench_csv(name, &args);
    csv_rows(&text)
        .into_iter()
        .map(|r| (r[3].clone(), r[4].clone(), r[7].parse().unwrap()))
        .collect()
}

#[test]
fn presets_are_rows_built_by_their_whole_policy() {
    let plain = rows("presets", &[]);
    let labels: Vec<(&str, &str)> = plain.iter().map(|r| (&r.0[..], &r.1[..])).collect();
    assert_eq!(
        labels,
        [
            ("sah", ""),
            ("incrupb", ""),
            ("fast", "preset"),
            ("balanced", "preset"),
            ("best", "preset"),
        ]
    );
    let cost = |m: &str| plain.iter().find(|r| r.0 == m).unwrap().2;
    // `fast` is the paper's IncrUPB at the engine's defaults: the same tree.
    assert_eq!(cost("fast"), cost("incrupb"));
    // `balanced` only keeps idle moves that lower the cost; `best` runs the full post-pass.
    assert!(cost("balanced") <= cost("fast"), "{plain:?}");
    assert!(cost("best") < cost("balanced"), "{plain:?}");
    assert!(cost("best") < cost("sah") * 1.05, "{plain:?}");
    // The paper's parameters tune the paper's methods, not a preset's own policy.
    let tuned = rows(
        "presets-tuned",
        &["--update-fraction", "0.5", "--update-cache", "50"],
    );
    assert_ne!(tuned[1].2, plain[1].2, "{tuned:?}");
    assert_eq!(&tuned[2..], &plain[2..]);
}

#[test]
fn an_unknown_preset_is_refused_with_the_names_it_takes() {
    let err = bench_refused(&["--scene", "hairball:100", "--preset", "quick"]);
    assert!(
        err.contains("quick") && err.contains("fast, balanced, best"),
        "{err}"
    );
}

#[test]
fn the_help_fits_on_one_screen() {
    let out = bench(&["--help"]);
    assert!(out.status.success());
    let help = String::from_utf8(out.stdout).unwrap();
    let lines = help.lines().count();
    assert!(lines <= 60, "{lines} lines:\n{help}");
    for flag in ["--preset", "--method", "--update-fraction", "--csv"] {
        assert!(help.contains(flag), "{flag} missing:\n{help}");
    }
}

#[test]
fn a_preset_alone_exports_its_tree() {
    // `--preset` without `--method` builds that preset's row only, so its tree can be written.
    let dir = std::env::temp_dir().join(format!("treelight-preset-export-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("best.tlbvh");
    let table = bench_ok(&[
        "--scene",
        "hairball:2000",
        "--preset",
        "best",
        "--export-bvh",
        file.to_str().unwrap(),
        "--ao-rays",
        "0",
        "--resolution",
        "8x8",
    ]);
    assert!(
        !table.contains("incrupb"),
        "the default methods ran too:\n{table}"
    );
    let tree = treelight_bvh::read_tlbvh(&mut std::fs::File::open(&file).unwrap()).unwrap();
    assert!(tree.triangle_count > 0 && !tree.nodes.is_empty());
    std::fs::remove_dir_all(&dir).ok();
}
