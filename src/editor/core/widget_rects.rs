//! Where named widgets were laid out last frame (the palette's tiles, the outliner's rows, the
//! dialogs' buttons), for the state report that tests and scripts read.

use bevy::prelude::*;
use bevy_egui::egui;

/// Name and rectangle (x, y, width, height, logical pixels) of each named widget, as the panels
/// laid them out this frame.
#[derive(Resource, Debug, Default, Clone)]
pub struct WidgetRects(pub Vec<(String, [f32; 4])>);

impl WidgetRects {
    /// Records where the widget `name` is.
    pub fn push(&mut self, name: impl Into<String>, r: egui::Rect) {
        self.0
            .push((name.into(), [r.min.x, r.min.y, r.width(), r.height()]));
    }

    /// Records every `(name, rect)` of `rects`.
    pub fn extend(&mut self, rects: impl IntoIterator<Item = (String, egui::Rect)>) {
        for (name, r) in rects {
            self.push(name, r);
        }
    }
}
