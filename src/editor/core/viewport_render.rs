//! How the viewport is drawn (rasterised or path traced, and the tracer's settings): chosen in
//! the toolbar and menus, shown in the status bar, put on the camera by the viewport.

use bevy::prelude::*;
use treelight_document::app::SceneLoading;
use treelight_render::{DebugView, PathTraced, PathTracerStats};

/// How the viewport is drawn.
#[derive(Resource, Clone, Copy, Debug, PartialEq)]
pub struct ViewportRender {
    /// `None`: Bevy's rasteriser; otherwise the path tracer showing this view.
    pub traced: Option<DebugView>,
    /// The path tracer's settings for the viewport camera.
    pub settings: PathTraced,
    /// Whether the user chose the resolution scale (on the command line or in the toolbar), so the
    /// adapter's default does not replace it.
    pub scale_chosen: bool,
}

/// The resolution scales the toolbar offers, with their names.
pub const TRACE_SCALES: [(f32, &str); 3] = [(1.0, "Full"), (0.5, "Half"), (0.25, "Quarter")];

impl Default for ViewportRender {
    fn default() -> Self {
        Self {
            traced: Some(DebugView::PathTraced),
            settings: PathTraced::default(),
            scale_chosen: false,
        }
    }
}

impl ViewportRender {
    /// The modes the switch offers, in order: raster first, then every path-traced view.
    pub fn modes() -> impl Iterator<Item = Option<DebugView>> {
        std::iter::once(None).chain(DebugView::ALL.into_iter().map(Some))
    }

    /// A name for a mode.
    pub fn label(mode: Option<DebugView>) -> &'static str {
        mode.map_or("Raster", DebugView::label)
    }

    /// Whether the scene has settled (`SceneLoading::settled`) and the view draws it as it
    /// settled: rasterised (the meshes are drawn as they are), or the path tracer's copy current,
    /// or the scene too large to trace. What the state report calls settled and what `--frames`
    /// waits for before it counts.
    pub fn draws_settled_scene(&self, loading: &SceneLoading, tracer: &PathTracerStats) -> bool {
        loading.settled()
            && (self.traced.is_none()
                || tracer.figures().trace_off.is_some()
                || tracer.figures().uploaded_version >= loading.scene_version())
    }
}
