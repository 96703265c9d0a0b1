//! The dock's layout: which panels there are and where they stand, kept between frames (and, by
//! the settings, between runs) so the user's rearrangements persist.

use bevy::prelude::*;
use egui_dock::{DockState, NodeIndex};

/// The panels that can be docked.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub enum EditorTab {
    /// The 3D view.
    Viewport,
    /// The list of scene entities.
    Outliner,
    /// The selected entity's properties.
    Inspector,
    /// The edit history: every step, and a click goes back or forward to it.
    History,
    /// The built-in shapes, to drag onto the viewport.
    Assets,
}

impl EditorTab {
    /// Every panel.
    pub const ALL: [EditorTab; 5] = [
        EditorTab::Viewport,
        EditorTab::Outliner,
        EditorTab::Inspector,
        EditorTab::History,
        EditorTab::Assets,
    ];

    /// The panel's title on its tab.
    pub fn title(self) -> &'static str {
        match self {
            EditorTab::Viewport => "Viewport",
            EditorTab::Outliner => "Outliner",
            EditorTab::Inspector => "Inspector",
            EditorTab::History => "History",
            EditorTab::Assets => "Assets",
        }
    }
}

/// The dock layout.
#[derive(Resource)]
pub struct EditorDock(pub DockState<EditorTab>);

impl Default for EditorDock {
    fn default() -> Self {
        let mut state = DockState::new(vec![EditorTab::Viewport]);
        let tree = state.main_surface_mut();
        let [viewport, outliner] =
            tree.split_left(NodeIndex::root(), 0.2, vec![EditorTab::Outliner]);
        let [_, inspector] = tree.split_right(viewport, 0.75, vec![EditorTab::Inspector]);
        tree.split_below(inspector, 0.6, vec![EditorTab::History]);
        tree.split_below(outliner, 0.7, vec![EditorTab::Assets]);
        Self(state)
    }
}
