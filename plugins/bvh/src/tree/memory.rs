//! What a tree holds in memory, for the figures that say where an editor's memory goes.

use crate::Bvh;

/// Bytes a vector's buffer holds: its capacity, not its length.
pub(crate) fn vec_bytes<T>(v: &Vec<T>) -> usize {
    v.capacity() * size_of::<T>()
}

/// Where a tree's heap bytes are, by what holds them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MemoryBytes {
    /// Inner nodes and their free list.
    pub nodes: usize,
    /// Triangles as stored (world space, or object space in a group kept whole), with their
    /// parents, groups and free list.
    pub triangles: usize,
    /// Groups: their object-space copies of the triangles and their triangle-id lists.
    pub groups: usize,
    /// Instances.
    pub instances: usize,
    /// The update cache, the change log for renderers, and scratch space.
    pub bookkeeping: usize,
}

impl MemoryBytes {
    /// All of it.
    pub fn total(&self) -> usize {
        self.nodes + self.triangles + self.groups + self.instances + self.bookkeeping
    }
}

impl Bvh {
    /// The heap bytes the tree holds, at its arrays' capacities.
    pub fn memory_bytes(&self) -> MemoryBytes {
        let t = &self.tri;
        let groups = self
            .groups
            .iter()
            .map(|g| vec_bytes(&g.triangles) + vec_bytes(&g.object))
            .sum::<usize>()
            + vec_bytes(&self.groups)
            + vec_bytes(&self.group_free);
        MemoryBytes {
            nodes: vec_bytes(&self.inner) + vec_bytes(&self.inner_free),
            triangles: vec_bytes(&t.items)
                + vec_bytes(&t.parent)
                + vec_bytes(&t.group)
                + vec_bytes(&t.free),
            groups,
            instances: vec_bytes(&self.instances) + vec_bytes(&self.inst_free),
            bookkeeping: vec_bytes(&self.cache.nodes)
                + vec_bytes(&self.cache.queued)
                + self.changes.heap_bytes()
                + self.scratch.heap_bytes(),
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::{Bvh, BvhConfig, Triangle};
    use glam::{Affine3A, Vec3};

    #[test]
    fn the_figures_grow_with_what_the_tree_holds() {
        let tris: Vec<Triangle> = (0..1000)
            .map(|i| {
                let o = Vec3::new(i as f32, 0.0, 0.0);
                Triangle::new(o, o + Vec3::X, o + Vec3::Y)
            })
            .collect();
        let mut bvh = Bvh::new(BvhConfig::default());
        let empty = bvh.memory_bytes();
        bvh.insert_triangles(&tris).unwrap();
        let loose = bvh.memory_bytes();
        // At least the triangles themselves, their parents and groups, and one inner node each.
        assert!(loose.triangles >= 1000 * (36 + 8));
        assert!(loose.nodes >= 999 * 36);
        assert_eq!(empty.groups, 0);
        let g = bvh
            .insert_group(&tris, Affine3A::from_translation(Vec3::Y), false)
            .unwrap();
        let grouped = bvh.memory_bytes();
        // An unedited baked group holds its triangle ids, not a second copy of its triangles.
        assert!(grouped.groups >= 1000 * 4 && grouped.groups < 1000 * 36);
        // Once moved and baked again, it keeps its object-space triangles, so that later moves
        // start from them exactly.
        bvh.set_group_transform(g, Affine3A::from_translation(Vec3::Z))
            .unwrap();
        bvh.bake_group(g).unwrap();
        assert!(bvh.memory_bytes().groups >= 1000 * (36 + 4));
        assert!(grouped.total() > loose.total());
    }
}
