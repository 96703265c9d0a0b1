//! The one command path: every edit is a request; an exclusive system applies the frame's requests
//! through the history (the `undo` crate's record), which can take each back and redo it. A drag or
//! a scrub sends many requests marked as continuing: they merge into one step.

use super::command::{EditCommand, EditError, Undo};
use super::snapshot::ObjectSnapshot;
use crate::scene::outbox::DocumentEvent;
use crate::values::object::{SceneId, SceneIndex};
use bevy::prelude::*;
use undo::{Edit, Merged, Record};

/// One step of the history: the command and what undoes it.
pub struct Step {
    /// The command, with the ids it made filled in.
    pub command: EditCommand,
    /// Its description when it was first applied.
    pub label: String,
    undo: Option<Undo>,
    /// What an undone step that made objects held: redo brings back these very objects (the
    /// same ids, meshes and materials) instead of making new ones.
    remade: Option<Vec<ObjectSnapshot>>,
    /// What an undone "make unique" made: redo gives the object this same material again.
    reassigned: Option<(SceneId, Handle<StandardMaterial>)>,
    /// Whether this step continues the previous one (the same drag or scrub).
    continuing: bool,
}

impl std::fmt::Display for Step {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.label)
    }
}

impl Edit for Step {
    type Target = World;
    type Output = ();

    fn edit(&mut self, world: &mut World) {
        match self.command.apply(world) {
            Ok(undo) => self.undo = Some(undo),
            Err(e) => {
                // Checked before it entered the history; a redo after outside changes can still fail.
                warn!("cannot apply '{}': {e}", self.label);
                self.undo = None;
            }
        }
    }

    fn undo(&mut self, world: &mut World) {
        let Some(undo) = self.undo.take() else {
            return;
        };
        if let Undo::Despawn(ids) = &undo {
            let index = world.resource::<SceneIndex>();
            let entities: Vec<Entity> = ids.iter().filter_map(|id| index.entity(*id)).collect();
            self.remade = Some(
                entities
                    .into_iter()
                    .filter_map(|e| ObjectSnapshot::capture(world, e))
                    .collect(),
            );
        }
        if let Undo::MaterialHandle(id, _) = &undo
            && let Some(e) = world.resource::<SceneIndex>().entity(*id)
            && let Some(m) = world.get::<MeshMaterial3d<StandardMaterial>>(e)
        {
            self.reassigned = Some((*id, m.0.clone()));
        }
        undo.revert(world);
    }

    fn redo(&mut self, world: &mut World) {
        if let Some((id, unique)) = self.reassigned.take()
            && let Some(e) = world.resource::<SceneIndex>().entity(id)
            && let Some(before) = world.get::<MeshMaterial3d<StandardMaterial>>(e).cloned()
        {
            world.entity_mut(e).insert(MeshMaterial3d(unique));
            self.undo = Some(Undo::MaterialHandle(id, before.0));
            return;
        }
        let Some(snapshots) = self.remade.take() else {
            return self.edit(world);
        };
        for s in &snapshots {
            s.respawn(world, &mut std::iter::empty());
        }
        self.undo = Some(Undo::Despawn(snapshots.iter().map(|s| s.id).collect()));
    }

    fn merge(&mut self, other: Self) -> Merged<Self> {
        let same_target = match (&self.command, &other.command) {
            (EditCommand::SetTransform { id: a, .. }, EditCommand::SetTransform { id: b, .. })
            | (EditCommand::Rename { id: a, .. }, EditCommand::Rename { id: b, .. })
            | (EditCommand::SetMaterial { id: a, .. }, EditCommand::SetMaterial { id: b, .. })
            | (EditCommand::SetLight { id: a, .. }, EditCommand::SetLight { id: b, .. }) => a == b,
            (
                EditCommand::SetTransforms { transforms: a },
                EditCommand::SetTransforms { transforms: b },
            ) => a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.0 == y.0),
            // One scrub of the exposure; a new curve is a step of its own.
            (EditCommand::SetLook { look: a }, EditCommand::SetLook { look: b }) => {
                a.tone == b.tone
            }
            // One scrub of the panorama's rotation or intensity; another file is a step of its own.
            (
                EditCommand::SetEnvironment { environment: a },
                EditCommand::SetEnvironment { environment: b },
            ) => a.image == b.image && a.shown == b.shown,
            _ => false,
        };
        if other.continuing && same_target {
            // The step keeps what undoes the first change and takes the latest value.
            self.command = other.command;
            self.label = other.label;
            Merged::Yes
        } else {
            Merged::No(other)
        }
    }
}

/// The edit history.
#[derive(Resource)]
pub struct EditHistory {
    record: Record<Step>,
    /// While a drag is shown live but not yet a step: each moved object's transform before it.
    previewed: Vec<(SceneId, Transform)>,
    /// Objects a preview made (a palette item dragged over the viewport), removed when it ends.
    preview_made: Vec<SceneId>,
    /// The steps after the head were taken back by a cancel (an import stopped before it was
    /// complete), not by Undo: they are not offered for redo, and the next step drops them.
    redo_dropped: bool,
}

impl Default for EditHistory {
    fn default() -> Self {
        Self {
            record: Record::builder().limit(1000).build(),
            previewed: Vec::new(),
            preview_made: Vec::new(),
            redo_dropped: false,
        }
    }
}

impl EditHistory {
    /// Whether a live preview (a drag not yet committed) has moved objects.
    pub fn previewing(&self) -> bool {
        !self.previewed.is_empty() || !self.preview_made.is_empty()
    }

    /// Marks the scene as it is now as saved.
    pub fn mark_saved(&mut self) {
        self.record.set_saved();
    }

    /// Marks the scene as having changes no file holds (a recovered copy).
    pub fn mark_unsaved(&mut self) {
        self.record.clear_saved();
    }

    /// Whether the scene has changes since it was last saved or opened.
    pub fn is_dirty(&self) -> bool {
        !self.record.is_saved()
    }

    /// The object a preview made, if any (the ghost of a palette item being dragged).
    pub fn preview_made(&self) -> Option<SceneId> {
        self.preview_made.first().copied()
    }

    /// Puts back what a preview moved and removes what it made.
    fn end_preview(&mut self, world: &mut World) {
        if !self.preview_made.is_empty() {
            Undo::Despawn(std::mem::take(&mut self.preview_made)).revert(world);
        }
        if !self.previewed.is_empty() {
            Undo::Transforms(std::mem::take(&mut self.previewed)).revert(world);
        }
    }

    /// The steps' descriptions, oldest first (those that can be redone included).
    pub fn labels(&self) -> Vec<String> {
        self.record
            .entries()
            .take(self.steps())
            .map(|e| e.as_ref().label.clone())
            .collect()
    }

    /// Steps that exist: applied ones and those Redo would apply again.
    fn steps(&self) -> usize {
        if self.redo_dropped {
            self.record.head()
        } else {
            self.record.len()
        }
    }

    /// Takes back the last step as if it had never been made (a cancelled import): Undo, with
    /// nothing left to redo.
    pub fn cancel_last(&mut self, world: &mut World) {
        self.end_preview(world);
        if self.record.undo(world).is_some() {
            self.redo_dropped = true;
        }
    }

    /// Steps applied: the history's position (0 before the first step).
    pub fn head(&self) -> usize {
        self.record.head()
    }

    /// What Undo would take back.
    pub fn undo_label(&self) -> Option<String> {
        self.record
            .head()
            .checked_sub(1)
            .and_then(|i| self.label(i))
    }

    /// What Redo would apply again.
    pub fn redo_label(&self) -> Option<String> {
        if self.redo_dropped {
            return None;
        }
        self.label(self.record.head())
    }

    fn label(&self, i: usize) -> Option<String> {
        self.record.get_entry(i).map(|e| e.as_ref().label.clone())
    }

    /// The applied commands, oldest first, as a script would replay them.
    pub fn commands(&self) -> Vec<EditCommand> {
        self.record
            .entries()
            .take(self.record.head())
            .map(|e| e.as_ref().command.clone())
            .collect()
    }
}

/// What the UI, the shortcuts and scripts ask of the history this frame.
#[derive(Clone, Debug, PartialEq)]
pub enum EditRequest {
    /// Apply a command; `continuing` merges it into the previous step when both change the same
    /// object in the same way (one drag, one scrub, one text field's typing).
    Apply {
        /// The command.
        command: EditCommand,
        /// Whether it continues the previous step.
        continuing: bool,
    },
    /// Take the last step back.
    Undo,
    /// Apply the next step again.
    Redo,
    /// Undo or redo until this many steps are applied.
    GoTo(usize),
    /// Shows a transform command live without making it a step (a gizmo drag in progress), or
    /// adds a shape that is not yet a step (a palette item dragged over the viewport, moved by
    /// later transform previews). The next request of any other kind first puts the objects back
    /// and removes what previews added, so an `Apply` of the drag's final command is one step whose
    /// undo returns to where the drag began.
    Preview(EditCommand),
    /// Puts back what previews moved: a cancelled drag, and no step.
    CancelPreview,
}

/// The frame's requests, applied in order by [`apply_edit_requests`].
#[derive(Resource, Default, Debug)]
pub struct EditRequests(pub Vec<EditRequest>);

impl EditRequests {
    /// Asks for a command as a step of its own.
    pub fn apply(&mut self, command: EditCommand) {
        self.0.push(EditRequest::Apply {
            command,
            continuing: false,
        });
    }
}

/// Applies one request to the world; a command that cannot apply leaves the world and the history
/// as they were.
pub fn apply_request(world: &mut World, request: EditRequest) -> Result<(), EditError> {
    world.resource_scope(|world, mut history: Mut<EditHistory>| {
        if let EditRequest::Preview(mut command) = request {
            if let EditCommand::AddPrimitive { .. } | EditCommand::Import { .. } = command {
                history.end_preview(world);
                if let Undo::Despawn(made) = command.apply(world)? {
                    history.preview_made = made;
                }
                return Ok(());
            }
            let ids: Vec<SceneId> = match &command {
                EditCommand::SetTransform { id, .. } => vec![*id],
                EditCommand::SetTransforms { transforms } => {
                    transforms.iter().map(|(id, _)| *id).collect()
                }
                _ => return Err(EditError::NotPreviewable),
            };
            command.check(world)?;
            for id in ids {
                if !history.previewed.iter().any(|(x, _)| *x == id)
                    && let Some(e) = world.resource::<SceneIndex>().entity(id)
                    && let Some(t) = world.get::<Transform>(e)
                {
                    history.previewed.push((id, *t));
                }
            }
            command.apply(world)?;
            return Ok(());
        }
        history.end_preview(world);
        let (dropped, steps) = (history.redo_dropped, history.steps());
        let record = &mut history.record;
        match request {
            EditRequest::Apply {
                command,
                continuing,
            } => {
                command.check(world)?;
                let label = command.label(world);
                let step = Step {
                    command,
                    label,
                    undo: None,
                    remade: None,
                    reassigned: None,
                    continuing,
                };
                record.edit(world, step);
                select_what_was_made(world, record);
                history.redo_dropped = false;
            }
            EditRequest::Undo => {
                record.undo(world);
            }
            EditRequest::Redo if dropped => {}
            EditRequest::Redo => {
                record.redo(world);
                select_what_was_made(world, record);
            }
            EditRequest::GoTo(i) => {
                record.go_to(world, i.min(steps));
            }
            EditRequest::Preview(_) | EditRequest::CancelPreview => {}
        }
        Ok(())
    })
}

/// After a duplicate, an added shape or light, or a group, the new objects are announced for an
/// editor to select (not after an import: the opened scene is framed whole, without a gizmo).
fn select_what_was_made(world: &mut World, record: &Record<Step>) {
    let Some(step) = record
        .head()
        .checked_sub(1)
        .and_then(|i| record.get_entry(i))
    else {
        return;
    };
    let step = step.as_ref();
    let made: Vec<SceneId> = match (&step.command, &step.undo) {
        (
            EditCommand::Duplicate { .. }
            | EditCommand::AddPrimitive { .. }
            | EditCommand::AddLight { .. },
            Some(Undo::Despawn(ids)),
        ) => ids.clone(),
        (EditCommand::Group { group: Some(g), .. }, _) => vec![*g],
        _ => return,
    };
    world.write_message(DocumentEvent::Made(made));
}

/// Applies the frame's requests in order.
pub fn apply_edit_requests(world: &mut World) {
    let requests = std::mem::take(&mut world.resource_mut::<EditRequests>().0);
    for request in requests {
        if let Err(e) = apply_request(world, request.clone()) {
            warn!("edit refused: {e} ({request:?})");
        }
    }
}
