//! A crashed scene BVH worker in the editor's headless run (`--commands … --save`): the script is
//! not applied and says why, the save does not happen, and the run ends with an error instead of
//! waiting for a tree that will never settle.

use bevy::prelude::*;
use treelight_document::edit::command::EditCommand;
use treelight_document::edit::command::TransformValue;
use treelight_document::project::script::ScriptedEdits;
use treelight_document::values::primitive::Primitive;
use treelight_scene::SceneBvh;

#[test]
fn a_crashed_worker_stops_the_script_and_the_save_with_an_error() {
    let dir = std::env::temp_dir().join(format!("treelight-worker-crash-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("out.treelight");
    let script = ScriptedEdits::new(
        dir.join("edits.ron"),
        vec![EditCommand::AddPrimitive {
            shape: Primitive::Cube,
            transform: TransformValue::from(Transform::IDENTITY),
            id: None,
        }],
    );
    let mut app = treelight_document::app::save_app(None, Some(out.clone()), Some(script));
    app.finish();
    app.cleanup();
    app.update();
    app.world().resource::<SceneBvh>().crash_worker_for_tests();
    let start = std::time::Instant::now();
    let exit = loop {
        app.update();
        if let Some(exit) = app.should_exit() {
            break exit;
        }
        assert!(start.elapsed().as_secs() < 30, "the run kept waiting");
        std::thread::sleep(std::time::Duration::from_millis(5));
    };
    assert!(exit.is_error(), "{exit:?}");
    assert!(!out.exists(), "a scene without its edits was saved");
    let failed = app.world().resource::<ScriptedEdits>().failed.clone();
    assert!(
        failed
            .as_deref()
            .is_some_and(|f| f.contains("not applied: the scene BVH worker crashed")),
        "{failed:?}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_worker_that_crashed_mid_write_publishes_no_tree_and_the_scene_still_saves_and_reopens() {
    let dir = std::env::temp_dir().join(format!("treelight-worker-mid-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mut app = treelight_document::app::headless_app(treelight_scene::SceneBvhConfig::default());
    treelight_document::default_scene::open_default_scene(app.world_mut());
    let start = std::time::Instant::now();
    while !app.world().resource::<SceneBvh>().is_idle()
        || app.world().resource::<SceneBvh>().stats().triangles == 0
    {
        assert!(start.elapsed().as_secs() < 30, "never settled");
        app.update();
    }
    // Readable before the crash (waiting out an idle-time update that holds the tree this instant).
    assert!(app.world().resource::<SceneBvh>().read_waiting().is_some());
    app.world().resource::<SceneBvh>().crash_worker_for_tests();
    let start = std::time::Instant::now();
    while app
        .world()
        .resource::<SceneBvh>()
        .worker_failure()
        .is_none()
    {
        assert!(start.elapsed().as_secs() < 30, "the crash was never seen");
        app.update();
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    let scene = app.world().resource::<SceneBvh>();
    assert!(
        scene.try_read().is_none(),
        "a half-written tree is still read"
    );
    assert!(scene.read_waiting().is_none());
    assert!(scene.try_take_changes(false, |_, _| ()).is_none());
    let ray = Ray3d::new(Vec3::new(0.0, 2.5, 9.0), Dir3::NEG_Z);
    assert!(
        scene.cast_ray(ray).is_none(),
        "picking reads the stopped worker's tree"
    );
    // The document does not need the tree: the scene saves and opens again as it was.
    let objects = |world: &mut World| {
        let mut ids: Vec<u64> = world
            .query::<&treelight_document::values::object::SceneId>()
            .iter(world)
            .map(|i| i.0)
            .collect();
        ids.sort_unstable();
        ids
    };
    let before = objects(app.world_mut());
    let path = dir.join("saved.treelight");
    treelight_document::project::capture::save_project(app.world_mut(), &path).unwrap();
    let mut fresh =
        treelight_document::app::headless_app(treelight_scene::SceneBvhConfig::default());
    treelight_document::project::restore::open_project(fresh.world_mut(), &path).unwrap();
    fresh.update();
    assert_eq!(objects(fresh.world_mut()), before);
    std::fs::remove_dir_all(&dir).ok();
}
