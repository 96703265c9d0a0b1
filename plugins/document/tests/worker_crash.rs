//! A crashed scene BVH worker in the editor's headless run (`--commands … --save`): the script is
//! not applied and says why, the save does not happen, and the run ends with an error instead of
//! waiting for a tree that will never settle.

use bevy::prelude::*;
use treelight_document::edit::command::EditCommand;
use treelight_document::edit::command::TransformValue;
use treelight_document::primitive::Primitive;
use treelight_document::project::script::ScriptedEdits;
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
