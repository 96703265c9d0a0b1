//! Parsed files become import commands: one undoable step each, standing where they were dropped
//! by the placement rule, or framed when opened otherwise.

use crate::edit::command::EditCommand;
use crate::edit::history::EditRequests;
use crate::import::jobs::TracingImports;
use crate::import::parse::{ParsedImports, PendingImport, PendingImports};
use crate::notice::Notices;
use crate::object::SceneIndex;
use crate::outbox::DocumentEvent;
use crate::placement::{Surface, place_on, surface_under};
use bevy::prelude::*;
use bevy::tasks::{block_on, poll_once};

/// Where a dropped scene's root goes: its bounds' bottom centre on `surface` by the placement rule
/// (the file's own coordinates otherwise kept: the root only moves).
pub fn drop_transform(bounds: (Vec3, Vec3), surface: Surface) -> Transform {
    Transform::from_translation(place_on(surface, bounds.0, bounds.1, Vec3::ONE))
}

/// Hands each parsed file to the history as an import command (one undoable step); a file not
/// dropped asks to be framed.
#[allow(clippy::too_many_arguments)]
pub fn finish_imports(
    mut pending: ResMut<PendingImports>,
    mut parsed_imports: ResMut<ParsedImports>,
    mut index: ResMut<SceneIndex>,
    mut requests: ResMut<EditRequests>,
    mut notices: ResMut<Notices>,
    mut events: MessageWriter<DocumentEvent>,
    bvh: Res<treelight_scene::SceneBvh>,
    mut jobs: ResMut<TracingImports>,
) {
    let mut i = 0;
    while i < pending.0.len() {
        let Some(result) = block_on(poll_once(&mut pending.0[i].task)) else {
            i += 1;
            continue;
        };
        let PendingImport {
            path, dropped_at, ..
        } = pending.0.remove(i);
        match result {
            Err(e) => notices.error(e.to_string()),
            Ok(parsed) => {
                let scene = &parsed.scene;
                for w in &scene.warnings {
                    notices.warn(format!("{}: {w}", path.display()));
                }
                // A dropped file stands where it was dropped, by the placement rule; a file opened
                // otherwise keeps its coordinates and the camera frames it.
                let transform = match (dropped_at, parsed.bounds) {
                    (Some(ray), Some(b)) => {
                        Some(drop_transform(b, surface_under(&bvh, ray, 5.0)).into())
                    }
                    (_, Some((min, max))) => {
                        events.write(DocumentEvent::Frame { min, max });
                        None
                    }
                    (_, None) => None,
                };
                notices.info(format!(
                    "opened {} ({} meshes, {} triangles)",
                    path.display(),
                    scene.meshes.len(),
                    scene.triangle_count()
                ));
                // The root's id, given now, names this import from the command to its tracking.
                let root = index.allocate();
                parsed_imports.0.insert(root, parsed);
                jobs.awaiting
                    .push((root, path.clone(), std::time::Instant::now()));
                requests.apply(EditCommand::Import {
                    file: path,
                    root: Some(root),
                    transform,
                });
            }
        }
    }
}

#[cfg(test)]
mod drop_tests {
    use super::*;

    #[test]
    fn a_dropped_scene_stands_on_the_surface_where_it_was_dropped() {
        // A scene floating two units up, dropped on the floor at (3, 0, 0).
        let bounds = (Vec3::new(-1.0, 2.0, -1.0), Vec3::new(1.0, 4.0, 1.0));
        let surface = Surface {
            point: Vec3::new(3.0, 0.0, 0.0),
            normal: Vec3::Y,
        };
        let t = drop_transform(bounds, surface);
        let bottom_centre = t.transform_point(Vec3::new(0.0, 2.0, 0.0));
        assert!(
            bottom_centre.distance(surface.point) < 1e-6,
            "{bottom_centre}"
        );
        assert_eq!(t.rotation, Quat::IDENTITY);
    }
}
