//! What Copy took, for Paste: shared by the shortcuts and the Edit menu.

use bevy::prelude::*;
use treelight_document::edit::command::EditCommand;
use treelight_document::edit::history::EditRequest;
use treelight_document::values::object::SceneId;

/// The objects Ctrl+C copied, by id.
#[derive(Resource, Debug, Default, Clone, PartialEq)]
pub struct EditClipboard(pub Vec<SceneId>);

impl EditClipboard {
    /// What pasting asks for: copies of the copied objects that still exist (in place, selected).
    pub fn paste(
        &self,
        index: &treelight_document::values::object::SceneIndex,
    ) -> Option<EditRequest> {
        let ids: Vec<SceneId> = self
            .0
            .iter()
            .copied()
            .filter(|id| index.entity(*id).is_some())
            .collect();
        (!ids.is_empty()).then_some(EditRequest::Apply {
            command: EditCommand::Duplicate {
                ids,
                copies: Vec::new(),
            },
            continuing: false,
        })
    }
}
