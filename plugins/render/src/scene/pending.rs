//! What the extraction hands the render world for this frame: the record writes left after the
//! rounds it streamed, the records each buffer must hold, and what else changed.

use crate::types::upload::{BufferKind, Writes};
use bevy::prelude::*;

/// What the render world must write before tracing this frame.
#[derive(Resource, Default)]
pub(crate) struct PendingUpload {
    /// Kept from frame to frame: the render world clears it once written.
    pub writes: Writes,
    /// Records each buffer must hold, in [`BufferKind::ALL`] order.
    pub needed: [u64; BufferKind::COUNT],
    /// Records each buffer is about to need, with the triangles on their way into the tree: a
    /// buffer that grows takes them at once.
    pub expected: [u64; BufferKind::COUNT],
    pub root: Option<u32>,
    pub light_count: Option<u32>,
    /// The groups in the emitters' table after the lights and the triangles' total weight, when
    /// they changed.
    pub emitters: Option<(u32, f32)>,
    /// Whether anything but the tree's organisation changed (a pure restructuring leaves every
    /// pixel's samples valid).
    pub geometry_changed: bool,
    /// The outline buffer's new words and the slots they cover (0: nothing outlined), when they
    /// changed.
    pub outlines: Option<(Vec<u32>, u32)>,
    /// World-space bounds of the outlined meshes this frame; `None` when some mesh's are unknown
    /// (then the whole view is searched for outlines).
    pub outline_bounds: Option<[Vec3; 2]>,
    /// The whole table of per-map UV transform sets, when it gained one.
    pub map_transforms: Option<Vec<u8>>,
    /// Whether new geometry is on its way into the scene's tree (`SceneBvh::is_filling`).
    pub filling: bool,
    /// The tree's version the writes bring the GPU copy up to, when changes were taken.
    pub version: Option<u64>,
}

impl PendingUpload {
    /// Raises what `kind`'s buffer must hold to at least `records`.
    pub(crate) fn need(&mut self, kind: BufferKind, records: u64) {
        let i = kind.index();
        self.needed[i] = self.needed[i].max(records);
    }

    /// Raises what `kind`'s buffer is about to need to at least `records`.
    pub(crate) fn expect(&mut self, kind: BufferKind, records: u64) {
        let i = kind.index();
        self.expected[i] = self.expected[i].max(records);
    }
}
