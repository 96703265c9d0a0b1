//! What changed since the last export, so a renderer uploads only that.

use crate::tree::flags::Flags;
use std::ops::Range;

/// Dirty flags and lists, cleared by [`crate::Bvh::take_changes`].
#[derive(Clone, Default)]
pub(crate) struct ChangeLog {
    inner_dirty: Flags,
    inner_list: Vec<u32>,
    tri_dirty: Flags,
    tri_list: Vec<u32>,
    inst_dirty: Flags,
    inst_list: Vec<u32>,
    pub(crate) root_changed: bool,
    /// Inside [`crate::Bvh::keeping_geometry`] (nested scopes count): triangle and instance marks
    /// re-lay what is there, so they do not count as an edit.
    pub(crate) keeping: u32,
    /// A triangle or instance was written or removed outside such a scope since the last take.
    edited: bool,
}

impl ChangeLog {
    /// Heap bytes its flags and lists hold.
    pub(crate) fn heap_bytes(&self) -> usize {
        use crate::tree::memory::vec_bytes;
        self.inner_dirty.heap_bytes()
            + vec_bytes(&self.inner_list)
            + self.tri_dirty.heap_bytes()
            + vec_bytes(&self.tri_list)
            + self.inst_dirty.heap_bytes()
            + vec_bytes(&self.inst_list)
    }

    /// Bytes its flags and lists hold beyond their lengths (the lists are empty between takes).
    pub(crate) fn spare_bytes(&self) -> usize {
        use crate::tree::memory::spare;
        self.inner_dirty.spare_bytes()
            + spare(&self.inner_list)
            + self.tri_dirty.spare_bytes()
            + spare(&self.tri_list)
            + self.inst_dirty.spare_bytes()
            + spare(&self.inst_list)
    }

    /// Gives back the room counted by [`ChangeLog::spare_bytes`].
    pub(crate) fn trim(&mut self) {
        self.inner_dirty.shrink_to_fit();
        self.tri_dirty.shrink_to_fit();
        self.inst_dirty.shrink_to_fit();
        self.inner_list.shrink_to_fit();
        self.tri_list.shrink_to_fit();
        self.inst_list.shrink_to_fit();
    }

    /// Makes room for inner nodes up to `len` slots, so that growing to it copies nothing.
    pub(crate) fn reserve_inner(&mut self, len: usize) {
        self.inner_dirty.reserve_to(len);
    }

    pub(crate) fn grow_inner(&mut self, len: usize) {
        self.inner_dirty.resize(len, false);
    }

    #[inline]
    pub(crate) fn mark_inner(&mut self, i: u32) {
        mark_one(&mut self.inner_dirty, &mut self.inner_list, i, 0);
    }

    /// Marks inner node ids just appended to the node array.
    pub(crate) fn mark_new_inner(&mut self, ids: Range<u32>) {
        mark_appended(&mut self.inner_dirty, &mut self.inner_list, ids);
    }

    /// Room for triangle ids below `len` and for `n` more entries in the list.
    pub(crate) fn reserve_triangles(&mut self, len: usize, n: usize) {
        if self.tri_dirty.len() < len {
            self.tri_dirty.resize(len, false);
        }
        self.tri_list.reserve(n);
    }

    #[inline]
    pub(crate) fn mark_triangle(&mut self, id: u32, len: usize) {
        self.edited |= self.keeping == 0;
        mark_one(&mut self.tri_dirty, &mut self.tri_list, id, len);
    }

    /// Marks ids appended at the end of the triangle array.
    pub(crate) fn mark_new_triangles(&mut self, ids: Range<u32>) {
        self.edited |= self.keeping == 0;
        mark_appended(&mut self.tri_dirty, &mut self.tri_list, ids);
    }

    pub(crate) fn mark_instance(&mut self, i: u32) {
        self.edited |= self.keeping == 0;
        mark_one(&mut self.inst_dirty, &mut self.inst_list, i, 0);
    }

    /// Marks everything dirty, for a consumer that must start over.
    pub(crate) fn mark_all(&mut self, inner: u32, tris: u32, instances: u32) {
        for i in 0..inner {
            self.mark_inner(i);
        }
        for t in 0..tris {
            self.mark_triangle(t, tris as usize);
        }
        for i in 0..instances {
            self.mark_instance(i);
        }
        self.root_changed = true;
        self.edited = true;
    }

    pub(crate) fn take(
        &mut self,
        live_tri: impl Fn(u32) -> bool,
        sizes: (u32, u32, u32),
    ) -> ChangeSet {
        let mut inner = std::mem::take(&mut self.inner_list);
        for &i in &inner {
            self.inner_dirty.set(i as usize, false);
        }
        inner.sort_unstable();
        let mut tris = std::mem::take(&mut self.tri_list);
        for &t in &tris {
            self.tri_dirty.set(t as usize, false);
        }
        tris.sort_unstable();
        let (written, removed): (Vec<u32>, Vec<u32>) = tris.into_iter().partition(|&t| live_tri(t));
        let mut instances = std::mem::take(&mut self.inst_list);
        for &i in &instances {
            self.inst_dirty.set(i as usize, false);
        }
        instances.sort_unstable();
        let root_changed = std::mem::replace(&mut self.root_changed, false);
        let geometry_edited = std::mem::replace(&mut self.edited, false);
        ChangeSet {
            geometry_edited,
            inner_ranges: coalesce(&inner),
            written_triangles: written,
            removed_triangles: removed,
            instances,
            root_changed,
            inner_capacity: sizes.0,
            triangle_capacity: sizes.1,
            instance_capacity: sizes.2,
        }
    }
}

/// Marks one id, listing it the first time. The flags grow to at least `len` at once (the
/// triangle count, so that a run of marks resizes once) and always past `id`.
#[inline]
fn mark_one(dirty: &mut Flags, list: &mut Vec<u32>, id: u32, len: usize) {
    let len = len.max(id as usize + 1);
    if dirty.len() < len {
        dirty.resize(len, false);
    }
    if !dirty.replace(id as usize, true) {
        list.push(id);
    }
}

/// Marks a range of ids just appended to an array dirty at once. They were never marked before
/// (they are new), so none is in `list` yet.
fn mark_appended(dirty: &mut Flags, list: &mut Vec<u32>, ids: Range<u32>) {
    if dirty.len() < ids.end as usize {
        dirty.resize(ids.end as usize, false);
    }
    dirty.set_range(ids.start as usize..ids.end as usize);
    list.extend(ids);
}

/// Turns sorted ids into ranges of consecutive ids.
pub(crate) fn coalesce(ids: &[u32]) -> Vec<Range<u32>> {
    let mut out: Vec<Range<u32>> = Vec::new();
    for &i in ids {
        match out.last_mut() {
            Some(r) if r.end == i => r.end += 1,
            _ => out.push(i..i + 1),
        }
    }
    out
}

/// Everything that changed since the previous [`crate::Bvh::take_changes`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ChangeSet {
    /// Whether a triangle or instance was written or removed by an edit, not only re-laid
    /// ([`crate::Bvh::keeping_geometry`]): see [`ChangeSet::geometry_changed`].
    pub geometry_edited: bool,
    /// Inner node ids whose GPU records must be rewritten, as sorted disjoint ranges.
    pub inner_ranges: Vec<Range<u32>>,
    /// Triangle ids added or moved: their vertex data must be uploaded.
    pub written_triangles: Vec<u32>,
    /// Triangle ids removed (their slots may be reused later).
    pub removed_triangles: Vec<u32>,
    /// Instance ids added, moved or removed.
    pub instances: Vec<u32>,
    /// Whether the root reference changed.
    pub root_changed: bool,
    /// Inner node array length now (the GPU buffer must hold this many).
    pub inner_capacity: u32,
    /// Triangle array length now.
    pub triangle_capacity: u32,
    /// Instance array length now.
    pub instance_capacity: u32,
}

impl ChangeSet {
    /// Whether what a ray hits may have changed: triangles written or removed, or instances changed,
    /// by an edit. A change set without any is a restructuring (global updates, re-insertions, a
    /// group baked or rebuilt within [`crate::Bvh::keeping_geometry`]), after which every ray still
    /// finds the same closest hit: its records must be uploaded, an accumulated image kept.
    pub fn geometry_changed(&self) -> bool {
        self.geometry_edited
    }

    /// Number of inner node records to rewrite.
    pub fn inner_count(&self) -> u32 {
        self.inner_ranges.iter().map(|r| r.end - r.start).sum()
    }

    /// Whether nothing changed.
    pub fn is_empty(&self) -> bool {
        self.inner_ranges.is_empty()
            && self.written_triangles.is_empty()
            && self.removed_triangles.is_empty()
            && self.instances.is_empty()
            && !self.root_changed
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn coalesce_ranges() {
        assert_eq!(
            super::coalesce(&[1, 2, 3, 7, 9, 10]),
            vec![1..4, 7..8, 9..11]
        );
        assert!(super::coalesce(&[]).is_empty());
    }
}
