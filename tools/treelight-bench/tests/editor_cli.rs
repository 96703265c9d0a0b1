//! The bench's `--editor`, end to end: the editor's tree (each mesh a group, then the `balanced`
//! preset's idle updates and full-sweep rebuilds of the meshes worth one) measured at 0, 0.1, 1 and
//! 10 s of idle time, for a real multi-mesh file and a generated assembly.

mod support;

use support::bench_ok;

/// The editor table's rows: scene, meshes, idle seconds, steps, SAH cost, meshes rebuilt.
fn editor_rows(table: &str) -> Vec<(String, usize, f64, u64, f32, u32)> {
    let start = table
        .find("The editor's tree over idle time")
        .expect("no editor table");
    table[start..]
        .lines()
        .filter(|l| l.starts_with("| ") && !l.starts_with("| scene"))
        .map(|l| {
            let c: Vec<&str> = l.split('|').map(str::trim).collect();
            let steps = c[5].split_whitespace().next().unwrap();
            (
                c[1].to_owned(),
                c[2].parse().unwrap(),
                c[4].parse().unwrap(),
                steps.parse().unwrap(),
                c[7].parse().unwrap(),
                c[6].parse().unwrap(),
            )
        })
        .collect()
}

#[test]
fn the_editor_s_tree_is_measured_over_idle_time_mesh_by_mesh() {
    let helmet = treelight_test_support::shared_scene("gltf/FlightHelmet/FlightHelmet.gltf");
    let helmet = helmet.to_str().unwrap();
    let table = bench_ok(&[
        "--scene",
        helmet,
        "--scene",
        "hairball:20000",
        "--method",
        "sah",
        "--editor",
        "--ao-rays",
        "0",
        "--resolution",
        "8x8",
    ]);
    let rows = editor_rows(&table);
    assert_eq!(rows.len(), 8, "{table}");
    let meshes = treelight_import::load_scene(std::path::Path::new(helmet))
        .unwrap()
        .meshes
        .len();
    for (scene_rows, groups) in [(&rows[..4], Some(meshes)), (&rows[4..], None)] {
        let idle: Vec<f64> = scene_rows.iter().map(|r| r.2).collect();
        assert_eq!(idle, [0.0, 0.1, 1.0, 10.0]);
        match groups {
            Some(n) => assert!(scene_rows.iter().all(|r| r.1 == n), "{scene_rows:?}"),
            // A hairball's tubes are its meshes.
            None => assert!(scene_rows[0].1 > 10, "{scene_rows:?}"),
        }
        // Nothing has run at 0 s; idle moves are kept only when they lower the cost.
        assert_eq!(scene_rows[0].3, 0);
        for w in scene_rows.windows(2) {
            assert!(w[1].3 >= w[0].3 && w[1].4 <= w[0].4, "{scene_rows:?}");
        }
        assert!(scene_rows[3].4 < scene_rows[0].4, "{scene_rows:?}");
        // Rebuilds come after the updates, never before anything ran.
        assert_eq!(scene_rows[0].5, 0);
        assert!(scene_rows.windows(2).all(|w| w[1].5 >= w[0].5));
    }
    // Every helmet mesh big enough is rebuilt by full sweep within the 10 s; the hairball's tubes
    // are too small for it.
    assert_eq!(rows[3].5 as usize, {
        let scene = treelight_import::load_scene(std::path::Path::new(helmet)).unwrap();
        scene
            .meshes
            .iter()
            .filter(|m| treelight_bvh::Refinement::is_worth(m.triangle_count()))
            .count()
    });
    assert_eq!(rows[7].5, 0);
}
