//! Parsed files become import commands: one undoable step each, standing where they were dropped
//! by the placement rule, or framed when opened otherwise; one too large for the free memory waits
//! for the user's answer where the app asks ([`crate::import::ask`]).

use crate::edit::command::{EditCommand, TransformValue};
use crate::edit::history::EditRequests;
use crate::import::ask::{HeldImport, ImportQuestions};
use crate::import::jobs::TracingImports;
use crate::import::parse::{ParsedImports, ParsedScene, PendingImport, PendingImports};
use crate::scene::notice::Notices;
use crate::scene::outbox::DocumentEvent;
use crate::scene::placement::{Surface, place_on, surface_under};
use crate::values::object::SceneIndex;
use bevy::ecs::system::SystemParam;
use bevy::prelude::*;
use std::path::PathBuf;
use treelight_import::ImportError;

/// Where a dropped scene's root goes: its bounds' bottom centre on `surface` by the placement rule
/// (the file's own coordinates otherwise kept: the root only moves).
pub fn drop_transform(bounds: (Vec3, Vec3), surface: Surface) -> Transform {
    Transform::from_translation(place_on(surface, bounds.0, bounds.1, Vec3::ONE))
}

/// What starting an import changes: the ids, the history's requests, the imports followed, the
/// notices and the messages for the shell.
#[derive(SystemParam)]
pub struct ImportStart<'w> {
    view: ResMut<'w, crate::scene::outbox::DocumentView>,
    parsed_imports: ResMut<'w, ParsedImports>,
    index: ResMut<'w, SceneIndex>,
    requests: ResMut<'w, EditRequests>,
    notices: ResMut<'w, Notices>,
    events: MessageWriter<'w, DocumentEvent>,
    jobs: ResMut<'w, TracingImports>,
}

impl ImportStart<'_> {
    /// Hands a parsed file to the history as an import command (one undoable step); one not dropped
    /// asks to be framed.
    fn start(&mut self, path: PathBuf, parsed: ParsedScene, transform: Option<TransformValue>) {
        if transform.is_none()
            && let Some((min, max)) = parsed.bounds
        {
            self.events.write(DocumentEvent::Frame { min, max });
            // The view the file is framed with is the one a save records, with or without an
            // editor's camera to follow it.
            self.view.0 = Some(crate::scene::outbox::CameraValue::framing(min, max));
        }
        let scene = &parsed.scene;
        self.notices.info(format!(
            "opened {} ({} meshes, {} triangles)",
            path.display(),
            scene.meshes.len(),
            scene.triangle_count()
        ));
        // The root's id, given now, names this import from the command to its tracking.
        let root = self.index.allocate();
        self.parsed_imports.0.insert(root, parsed);
        self.jobs
            .awaiting
            .push((root, path.clone(), std::time::Instant::now()));
        self.requests.apply(EditCommand::Import {
            file: path,
            root: Some(root),
            transform,
        });
    }
}

/// Hands each parsed file to the history as an import command, standing where it was dropped by
/// the placement rule (a file opened otherwise keeps its coordinates and the camera frames it);
/// one that would not fit in the free memory waits for an answer where the app asks.
pub fn finish_imports(
    mut pending: ResMut<PendingImports>,
    mut questions: ResMut<ImportQuestions>,
    bvh: Res<treelight_scene::SceneBvh>,
    mut start: ImportStart,
) {
    let mut i = 0;
    while i < pending.0.len() {
        let Some(result) = pending.0[i].job.poll() else {
            i += 1;
            continue;
        };
        let PendingImport {
            path, dropped_at, ..
        } = pending.0.remove(i);
        // A crash in the importer ends this import with an error, not the editor.
        let result = result.unwrap_or_else(|problem| {
            Err(ImportError {
                file: path.clone(),
                problem,
            })
        });
        let parsed = match result {
            Err(e) => {
                start.notices.error(e.to_string());
                continue;
            }
            Ok(parsed) => parsed,
        };
        for w in &parsed.scene.warnings {
            start.notices.warn(format!("{}: {w}", path.display()));
        }
        let transform = match (dropped_at, parsed.bounds) {
            (Some(ray), Some(b)) => Some(drop_transform(b, surface_under(&bvh, ray, 5.0)).into()),
            _ => None,
        };
        let triangles = parsed.scene.triangle_count() as u64;
        match questions.must_ask(triangles) {
            Some((needed, free)) => questions.waiting.push(HeldImport {
                path,
                needed,
                free,
                triangles,
                parsed,
                transform,
            }),
            None => start.start(path, parsed, transform),
        }
    }
}

/// Applies the answers about held imports: go ahead, or drop the parsed file.
pub fn answer_import_questions(mut questions: ResMut<ImportQuestions>, mut start: ImportStart) {
    let answers = std::mem::take(&mut questions.answers);
    for (path, go) in answers {
        let Some(k) = questions.waiting.iter().position(|h| h.path == path) else {
            continue;
        };
        let held = questions.waiting.remove(k);
        if go {
            start.start(held.path, held.parsed, held.transform);
        } else {
            start
                .notices
                .info(format!("import of {} cancelled", held.path.display()));
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
