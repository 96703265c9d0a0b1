//! The document without a window or a renderer: opens a scene file, moves its first top-level
//! object up through the edit history, undoes and redoes the move, and saves the scene as a
//! project (`.treelight`) that stores the move over the file.
//!
//! `cargo run -p treelight_document --example headless_edit -- SCENE OUT.treelight`

use bevy::ecs::system::SystemState;
use bevy::prelude::*;
use std::path::Path;
use std::time::{Duration, Instant};
use treelight_document::app::{SceneLoading, headless_app};
use treelight_document::edit::command::{EditCommand, TransformValue};
use treelight_document::edit::history::{EditRequest, apply_request};
use treelight_document::scene::notice::Notices;
use treelight_document::values::object::SceneId;
use treelight_scene::SceneBvhConfig;

fn main() -> Result<(), String> {
    let mut args = std::env::args().skip(1);
    let (Some(scene), Some(out)) = (args.next(), args.next()) else {
        return Err("usage: headless_edit SCENE OUT.treelight".into());
    };
    let mut app = headless_app(SceneBvhConfig::default());
    treelight_document::app::open_at_start(app.world_mut(), Path::new(&scene));
    settle(&mut app)?;

    // The top-level object with the lowest id, and where it stands.
    let world = app.world_mut();
    let mut roots = world.query_filtered::<(&SceneId, &Transform), Without<ChildOf>>();
    let (id, before) = roots
        .iter(world)
        .min_by_key(|(id, _)| id.0)
        .map(|(id, t)| (*id, *t))
        .ok_or_else(|| format!("{scene}: no objects"))?;
    let up = before.with_translation(before.translation + Vec3::Y);
    let command = EditCommand::SetTransform {
        id,
        transform: TransformValue::from(up),
    };
    let step =
        |world: &mut World, request| apply_request(world, request).map_err(|e| e.to_string());
    step(
        world,
        EditRequest::Apply {
            command,
            continuing: false,
        },
    )?;
    println!("moved object {} up by 1", id.0);
    step(world, EditRequest::Undo)?;
    println!("undone: at {}", translation_of(world, id));
    step(world, EditRequest::Redo)?;
    println!("redone: at {}", translation_of(world, id));
    settle(&mut app)?;

    treelight_document::project::capture::save_project(app.world_mut(), Path::new(&out))
        .map_err(|e| e.to_string())?;
    println!("saved {out}");
    Ok(())
}

/// Runs frames until nothing loads and the scene's tree holds everything (a minute at most), or
/// returns the first error a notice reports (a file that would not open).
fn settle(app: &mut App) -> Result<(), String> {
    let start = Instant::now();
    let mut loading = SystemState::<SceneLoading>::new(app.world_mut());
    let mut settled = 0;
    while settled < 3 {
        app.update();
        if let Some(error) = app
            .world()
            .resource::<Notices>()
            .0
            .iter()
            .find(|n| n.level == treelight_document::scene::notice::Level::Error)
        {
            return Err(error.text.clone());
        }
        let now = loading.get(app.world()).is_ok_and(|l| l.settled());
        settled = if now { settled + 1 } else { 0 };
        if start.elapsed() > Duration::from_secs(60) {
            return Err("the scene did not settle within a minute".into());
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    Ok(())
}

/// Where object `id` stands now.
fn translation_of(world: &mut World, id: SceneId) -> Vec3 {
    let mut q = world.query::<(&SceneId, &Transform)>();
    q.iter(world)
        .find(|(i, _)| **i == id)
        .map_or(Vec3::NAN, |(_, t)| t.translation)
}
