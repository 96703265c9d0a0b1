//! The Assets panel: the built-in shapes, each a tile. A click adds the shape where the view's
//! centre meets the scene; a drag carries it over the viewport, where it is shown (and path traced)
//! at the point under the pointer by the placement rule until it is dropped (one step) or the drag
//! is cancelled with Escape or ends outside the viewport.

use crate::edit::Primitive;
use bevy_egui::egui;

/// What a palette drag carries.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PaletteItem(pub Primitive);

/// Lays out the panel; returns a shape clicked (not dragged). Each tile's rectangle goes to
/// `tiles`, named after its shape.
pub fn palette_ui(ui: &mut egui::Ui, tiles: &mut Vec<(String, egui::Rect)>) -> Option<Primitive> {
    let mut clicked = None;
    ui.weak("Drag onto the viewport to place (Shift: along the surface's normal); click to add at the view's centre.");
    ui.add_space(4.0);
    egui::ScrollArea::vertical()
        .auto_shrink([false; 2])
        .show(ui, |ui| {
            ui.horizontal_wrapped(|ui| {
                for shape in Primitive::ALL {
                    let tile = egui::Button::new(egui::RichText::new(shape.label()).size(13.0))
                        .min_size(egui::vec2(84.0, 52.0))
                        .sense(egui::Sense::click_and_drag());
                    let response = ui.add(tile);
                    tiles.push((shape.label().to_owned(), response.rect));
                    if response.drag_started() {
                        response.dnd_set_drag_payload(PaletteItem(shape));
                    } else if response.clicked() {
                        clicked = Some(shape);
                    }
                    if response.dragged()
                        && let Some(p) = ui.ctx().pointer_interact_pos()
                    {
                        ui.ctx()
                            .layer_painter(egui::LayerId::new(
                                egui::Order::Tooltip,
                                egui::Id::new("palette-drag"),
                            ))
                            .text(
                                p + egui::vec2(14.0, 4.0),
                                egui::Align2::LEFT_TOP,
                                shape.label(),
                                egui::FontId::proportional(13.0),
                                egui::Color32::WHITE,
                            );
                    }
                }
            });
        });
    clicked
}
