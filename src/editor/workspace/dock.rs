//! The editor's window: the menu bar on top, the status bar below and the dock between, each tab a
//! system of its own that draws into the `egui::Ui` it is given ([`draw_editor`] runs them in
//! turn); the panels' state and queries stay with each panel.

use crate::editor::assets::palette::assets_tab;
use crate::editor::core::layout::{EditorDock, EditorTab};
use crate::editor::core::widget_rects::WidgetRects;
use crate::editor::panels::history::history_tab;
use crate::editor::panels::inspector::inspector_tab;
use crate::editor::panels::menus::menu_bar_tab;
use crate::editor::panels::outliner::outliner_tab;
use crate::editor::panels::status_bar::status_bar;
use crate::editor::viewport::tab::viewport_tab;
use bevy::prelude::*;
use bevy_egui::{EguiContext, PrimaryEguiContext, egui};
use egui_dock::{DockArea, DockState, Style, TabViewer};

/// The dock's tabs, each drawn by running its system on the world.
struct EditorTabs<'w> {
    world: &'w mut World,
}

impl TabViewer for EditorTabs<'_> {
    type Tab = EditorTab;

    fn id(&mut self, tab: &mut EditorTab) -> egui::Id {
        egui::Id::new(("treelight-tab", *tab))
    }

    fn title(&mut self, tab: &mut EditorTab) -> egui::WidgetText {
        tab.title().into()
    }

    fn clear_background(&self, tab: &EditorTab) -> bool {
        // The 3D camera draws underneath the viewport panel.
        *tab != EditorTab::Viewport
    }

    fn closeable(&mut self, _tab: &mut EditorTab) -> bool {
        false
    }

    fn ui(&mut self, ui: &mut egui::Ui, tab: &mut EditorTab) {
        let w = &mut *self.world;
        let drawn = match tab {
            EditorTab::Viewport => w.run_system_cached_with(viewport_tab, ui).map_err(err),
            EditorTab::Outliner => w.run_system_cached_with(outliner_tab, ui).map_err(err),
            EditorTab::Inspector => w.run_system_cached_with(inspector_tab, ui).map_err(err),
            EditorTab::History => w.run_system_cached_with(history_tab, ui).map_err(err),
            EditorTab::Assets => w.run_system_cached_with(assets_tab, ui).map_err(err),
        };
        if let Err(e) = drawn {
            warn!("the {} panel was not drawn: {e}", tab.title());
        }
    }
}

fn err(e: impl std::fmt::Display) -> String {
    e.to_string()
}

/// Draws the menu bar, the status bar and the dock, running each panel's system on the world.
pub fn draw_editor(world: &mut World) {
    let mut contexts = world.query_filtered::<&mut EguiContext, With<PrimaryEguiContext>>();
    let Ok(mut context) = contexts.single_mut(world) else {
        return;
    };
    let ctx = context.get_mut().clone();
    world.resource_mut::<WidgetRects>().0.clear();
    let mut root = egui::Ui::new(
        ctx.clone(),
        "treelight-root".into(),
        egui::UiBuilder::new()
            .layer_id(egui::LayerId::background())
            .max_rect(ctx.viewport_rect()),
    );
    egui::Panel::top("menu-bar").show(&mut root, |ui| {
        if let Err(e) = world.run_system_cached_with(menu_bar_tab, ui) {
            warn!("the menu bar was not drawn: {e}");
        }
    });
    egui::Panel::bottom("status-bar").show(&mut root, |ui| {
        if let Err(e) = world.run_system_cached_with(status_bar, ui) {
            warn!("the status bar was not drawn: {e}");
        }
    });
    // The layout is taken out while the tabs run on the world.
    let mut dock = std::mem::replace(
        &mut world.resource_mut::<EditorDock>().0,
        DockState::new(Vec::new()),
    );
    egui::CentralPanel::default()
        .frame(egui::Frame::NONE)
        .show(&mut root, |ui| {
            DockArea::new(&mut dock)
                .style(Style::from_egui(ui.style().as_ref()))
                .show_close_buttons(false)
                .show_leaf_close_all_buttons(false)
                .show_leaf_collapse_buttons(false)
                .show_inside(ui, &mut EditorTabs { world });
        });
    world.resource_mut::<EditorDock>().0 = dock;
}
