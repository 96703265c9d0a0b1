//! What a day's work relies on, in the document: `info` counts what an open holds, a save
//! records the view the file was framed with and is read back before it is called saved, the
//! children of a mesh that cannot be saved keep their place, framing stays within what a reopen
//! accepts, and no hierarchy a user or a file makes is deeper than the editor walks safely.

#[path = "support/assembly.rs"]
mod assembly;
#[path = "support/world.rs"]
mod world;

use bevy::prelude::*;
use std::path::{Path, PathBuf};
use treelight_document::edit::command::{EditCommand, EditError};
use treelight_document::edit::history::{EditRequest, apply_request};
use treelight_document::project::capture::save_project;
use treelight_document::project::format::read_project;
use treelight_document::project::restore::open_project;
use treelight_document::scene::hierarchy::MAX_HIERARCHY_DEPTH;
use treelight_document::scene::outbox::{CameraValue, DocumentView};
use treelight_document::values::object::{SceneId, SceneIndex, SceneObject};
use world::{editor_world, fresh_dir, settle_tree};

fn helmet() -> PathBuf {
    treelight_test_support::shared_scene("gltf/FlightHelmet/FlightHelmet.gltf")
}

fn apply(app: &mut App, command: EditCommand) -> Result<(), String> {
    apply_request(
        app.world_mut(),
        EditRequest::Apply {
            command,
            continuing: false,
        },
    )
    .map_err(|e| e.to_string())?;
    app.update();
    Ok(())
}

fn import(app: &mut App, file: &Path) {
    apply(
        app,
        EditCommand::Import {
            file: file.to_owned(),
            root: None,
            transform: None,
        },
    )
    .unwrap();
}

/// Triangles of every mesh object in the world.
fn world_triangles(world: &mut World) -> u64 {
    let handles: Vec<Handle<Mesh>> = world
        .query_filtered::<&Mesh3d, With<SceneObject>>()
        .iter(world)
        .map(|m| m.0.clone())
        .collect();
    let meshes = world.resource::<Assets<Mesh>>();
    handles
        .iter()
        .map(|h| {
            let m = meshes.get(h).unwrap();
            (m.indices().map_or(m.count_vertices(), |i| i.len()) / 3) as u64
        })
        .sum()
}

fn ids_named(world: &mut World, name: &str) -> Vec<SceneId> {
    world
        .query::<(&SceneId, &Name)>()
        .iter(world)
        .filter(|(_, n)| n.as_str() == name)
        .map(|(i, _)| *i)
        .collect()
}

fn info_triangles(path: &Path) -> u64 {
    let text = treelight_document::project::info::describe(path).unwrap();
    text.lines()
        .find_map(|l| l.strip_prefix("triangles: "))
        .unwrap_or_else(|| panic!("{text}"))
        .parse()
        .unwrap()
}

#[test]
fn info_counts_the_triangles_an_open_of_a_compact_project_holds() {
    let dir = fresh_dir("trust", "info");
    // An unedited assembly: every node a run of ids, none listed.
    let (file, triangles) = assembly::generated_assembly(&dir, 40, 6);
    let mut app = editor_world();
    import(&mut app, &file);
    let path = dir.join("unedited.treelight");
    save_project(app.world_mut(), &path).unwrap();
    assert_eq!(info_triangles(&path), triangles as u64);
    // Edits: a part deleted, one copied, a group of two with one of them deleted after.
    let part = |app: &mut App, k: usize| ids_named(app.world_mut(), &format!("part {k}"))[0];
    let (a, b, c) = (part(&mut app, 3), part(&mut app, 4), part(&mut app, 5));
    apply(&mut app, EditCommand::Delete { ids: vec![a] }).unwrap();
    apply(
        &mut app,
        EditCommand::Duplicate {
            ids: vec![b],
            copies: Vec::new(),
        },
    )
    .unwrap();
    apply(
        &mut app,
        EditCommand::Group {
            ids: vec![b, c],
            name: "pair".into(),
            group: None,
        },
    )
    .unwrap();
    apply(&mut app, EditCommand::Delete { ids: vec![c] }).unwrap();
    import(&mut app, &helmet());
    let path = dir.join("edited.treelight");
    save_project(app.world_mut(), &path).unwrap();
    let expected = world_triangles(app.world_mut());
    assert_eq!(info_triangles(&path), expected);
    let mut fresh = editor_world();
    open_project(fresh.world_mut(), &path).unwrap();
    fresh.update();
    assert_eq!(world_triangles(fresh.world_mut()), expected);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_project_saved_from_a_scene_file_keeps_the_view_it_was_framed_with() {
    let dir = fresh_dir("trust", "framed");
    let mut app = treelight_document::app::save_app(
        Some(&helmet()),
        Some(dir.join("helmet.treelight")),
        None,
    );
    let start = std::time::Instant::now();
    while !dir.join("helmet.treelight").exists() {
        assert!(start.elapsed().as_secs() < 60, "never saved");
        app.update();
    }
    let saved = read_project(&dir.join("helmet.treelight")).unwrap();
    let camera = saved.camera.expect("the framed view is saved");
    // The helmet is about half a unit tall, centred near y = 0.3: framed close, not the
    // default room's view.
    assert!(camera.radius < 2.0, "{camera:?}");
    assert!((camera.pitch - CameraValue::THREE_QUARTER_PITCH).abs() < 1e-6);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn framing_any_extent_gives_a_view_a_reopen_accepts() {
    let dir = fresh_dir("trust", "far");
    for (k, span) in [1.0e9f32, 3.0e38].into_iter().enumerate() {
        let obj = dir.join(format!("far{k}.obj"));
        std::fs::write(
            &obj,
            format!("v 0 0 0\nv 1 0 0\nv 0 1 0\nv {span} 0 0\nv {span} 1 0\nv {span} 0 1\nf 1 2 3\nf 4 5 6\n"),
        )
        .unwrap();
        let mut app = editor_world();
        app.world_mut().resource_mut::<DocumentView>().0 = None;
        // Through the document's own opening, which frames it.
        treelight_document::app::open_at_start(app.world_mut(), &obj);
        let start = std::time::Instant::now();
        while app.world().resource::<DocumentView>().0.is_none() {
            assert!(start.elapsed().as_secs() < 30, "never framed");
            app.update();
        }
        let view = app.world().resource::<DocumentView>().0.unwrap();
        assert_eq!(view, view.clamped(), "{view:?}");
        let path = dir.join(format!("far{k}.treelight"));
        save_project(app.world_mut(), &path).unwrap();
        read_project(&path).unwrap_or_else(|e| panic!("span {span}: {e}"));
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn children_of_a_mesh_that_cannot_be_saved_are_saved_where_they_are() {
    let dir = fresh_dir("trust", "unsaved-parent");
    let mut app = editor_world();
    // A mesh made by code (no file, no shape) with a light under it.
    let mesh = app
        .world_mut()
        .resource_mut::<Assets<Mesh>>()
        .add(Cuboid::default());
    let made = app
        .world_mut()
        .spawn((
            SceneObject,
            Name::new("made by code"),
            Mesh3d(mesh),
            Transform::from_xyz(5.0, 0.0, 0.0),
        ))
        .id();
    app.update();
    let made_id = *app.world().get::<SceneId>(made).unwrap();
    apply(
        &mut app,
        EditCommand::AddLight {
            kind: treelight_document::edit::command::LightKind::Point,
            transform: Transform::from_xyz(6.0, 1.0, 0.0).into(),
            id: None,
        },
    )
    .unwrap();
    let lamp = *app
        .world_mut()
        .query_filtered::<&SceneId, With<PointLight>>()
        .iter(app.world())
        .next()
        .unwrap();
    apply(
        &mut app,
        EditCommand::Reparent {
            ids: vec![lamp],
            parent: Some(made_id),
        },
    )
    .unwrap();
    let path = dir.join("made.treelight");
    let unsaved = save_project(app.world_mut(), &path).unwrap();
    assert_eq!(unsaved, vec!["made by code".to_owned()]);
    let saved = read_project(&path).expect("the save opens again");
    let light = saved.objects.iter().find(|o| o.id == lamp).unwrap();
    assert_eq!(light.parent, None);
    assert_eq!(
        Transform::from(light.transform).translation,
        Vec3::new(6.0, 1.0, 0.0)
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// A chain of `n` groups over `top`: each new group made over the last.
fn group_chain(app: &mut App, top: SceneId, n: usize) -> Result<SceneId, String> {
    let mut at = top;
    for k in 0..n {
        let before: Vec<SceneId> = ids_named(app.world_mut(), &format!("g{k}"));
        apply(
            app,
            EditCommand::Group {
                ids: vec![at],
                name: format!("g{k}"),
                group: None,
            },
        )?;
        let after = ids_named(app.world_mut(), &format!("g{k}"));
        at = *after.iter().find(|i| !before.contains(i)).unwrap();
    }
    Ok(at)
}

#[test]
fn hierarchies_deeper_than_the_editor_holds_are_refused_naming_the_object() {
    let mut app = editor_world();
    apply(
        &mut app,
        EditCommand::AddPrimitive {
            shape: treelight_document::values::primitive::Primitive::Cube,
            transform: Transform::default().into(),
            id: None,
        },
    )
    .unwrap();
    let cube = *app
        .world_mut()
        .query_filtered::<&SceneId, With<SceneObject>>()
        .iter(app.world())
        .next()
        .unwrap();
    // Grouping up to the limit is fine; one more level is refused, the scene unchanged.
    let top = group_chain(&mut app, cube, MAX_HIERARCHY_DEPTH - 1).unwrap();
    let objects = app.world().resource::<SceneIndex>().len();
    let refused = apply_request(
        app.world_mut(),
        EditRequest::Apply {
            command: EditCommand::Group {
                ids: vec![top],
                name: "one too many".into(),
                group: None,
            },
            continuing: false,
        },
    );
    match refused {
        Err(e) => {
            let text = e.to_string();
            assert!(
                text.contains(&top.to_string()) && text.contains("levels"),
                "{text}"
            );
        }
        Ok(()) => panic!("a group past the limit was made"),
    }
    assert_eq!(app.world().resource::<SceneIndex>().len(), objects);
    let _ = EditError::TooDeep(top, 0);
    // The whole chain deletes and undoes without recursion.
    apply(&mut app, EditCommand::Delete { ids: vec![top] }).unwrap();
    assert_eq!(app.world().resource::<SceneIndex>().len(), 0);
    apply_request(app.world_mut(), EditRequest::Undo).unwrap();
    app.update();
    assert_eq!(app.world().resource::<SceneIndex>().len(), objects);
    settle_tree(&mut app);
}

#[test]
fn a_project_of_a_chain_deeper_than_the_limit_is_refused_at_once() {
    let dir = fresh_dir("trust", "deep");
    let n = 200_000u64;
    let mut text = String::from("(version: 4, objects: [\n");
    for id in 1..=n {
        let parent = if id == 1 {
            "None".to_owned()
        } else {
            format!("Some(({}))", id - 1)
        };
        text.push_str(&format!(
            "(id: ({id}), name: \"g\", parent: {parent}, transform: (translation: (0.0, 0.0, \
             0.0)), kind: Empty),\n"
        ));
    }
    text.push_str("])\n");
    let path = dir.join("deep.treelight");
    std::fs::write(&path, text).unwrap();
    let start = std::time::Instant::now();
    let e = read_project(&path).unwrap_err().to_string();
    assert!(e.contains("levels deep"), "{e}");
    assert!(start.elapsed().as_secs() < 20);
    std::fs::remove_dir_all(&dir).ok();
}
