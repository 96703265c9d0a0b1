//! The one command path: every edit is a request; an exclusive system applies the frame's requests
//! through the history (the `undo` crate's record), which can take each back and redo it. A drag or
//! a scrub sends many requests marked as continuing: they merge into one step.

use super::command::{EditCommand, EditError, Undo};
use super::snapshot::ObjectSnapshot;
use crate::scene_id::{SceneId, SceneIndex};
use crate::selection::Selection;
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
        undo.revert(world);
    }

    fn redo(&mut self, world: &mut World) {
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
            | (EditCommand::Rename { id: a, .. }, EditCommand::Rename { id: b, .. }) => a == b,
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
}

impl Default for EditHistory {
    fn default() -> Self {
        Self {
            record: Record::builder().limit(1000).build(),
        }
    }
}

impl EditHistory {
    /// The steps' descriptions, oldest first.
    pub fn labels(&self) -> Vec<String> {
        self.record
            .entries()
            .map(|e| e.as_ref().label.clone())
            .collect()
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
                    continuing,
                };
                record.edit(world, step);
                select_what_was_made(world, record);
            }
            EditRequest::Undo => {
                record.undo(world);
            }
            EditRequest::Redo => {
                record.redo(world);
                select_what_was_made(world, record);
            }
            EditRequest::GoTo(i) => {
                record.go_to(world, i.min(record.len()));
            }
        }
        Ok(())
    })
}

/// After a duplicate or an added shape, the new objects are the selection.
fn select_what_was_made(world: &mut World, record: &Record<Step>) {
    let Some(step) = record
        .head()
        .checked_sub(1)
        .and_then(|i| record.get_entry(i))
    else {
        return;
    };
    let step = step.as_ref();
    let made = matches!(
        step.command,
        EditCommand::Duplicate { .. } | EditCommand::AddPrimitive { .. }
    );
    if let (true, Some(Undo::Despawn(ids))) = (made, &step.undo)
        && let Some(first) = ids.first()
    {
        let e = world.resource::<SceneIndex>().entity(*first);
        world.resource_mut::<Selection>().0 = e;
    }
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

/// The selected object's id.
pub fn selected_id(world: &World) -> Option<SceneId> {
    let e = world.resource::<Selection>().0?;
    world.get::<SceneId>(e).copied()
}
