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
    /// boxes, parents, groups and free list.
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
                + vec_bytes(&t.boxes)
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

impl Bvh {
    /// Gives the arrays' spare capacity back to the allocator. The arrays grow by doubling, so
    /// after a large import up to half of each can be unused; a tree done growing for now (the
    /// scene worker's, once idle) need not keep it. The next insertion grows them again, and the
    /// builders' scratch comes back on first use.
    pub fn shrink_to_fit(&mut self) {
        self.inner.shrink_to_fit();
        self.inner_free.shrink_to_fit();
        let t = &mut self.tri;
        t.items.shrink_to_fit();
        t.boxes.shrink_to_fit();
        t.parent.shrink_to_fit();
        t.group.shrink_to_fit();
        t.free.shrink_to_fit();
        self.instances.shrink_to_fit();
        self.inst_free.shrink_to_fit();
        for g in &mut self.groups {
            g.triangles.shrink_to_fit();
            g.object.shrink_to_fit();
        }
        self.groups.shrink_to_fit();
        self.group_free.shrink_to_fit();
        self.cache.nodes.shrink_to_fit();
        self.cache.queued.shrink_to_fit();
        self.changes.shrink_to_fit();
        self.scratch.shrink_to_fit();
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
        // At least the triangles themselves, their boxes and one inner node each.
        assert!(loose.triangles >= 1000 * (36 + 24));
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

    #[test]
    fn shrinking_gives_back_the_spare_capacity_and_keeps_the_tree() {
        let tris: Vec<Triangle> = (0..3000)
            .map(|i| {
                let o = Vec3::new((i % 50) as f32, (i / 50) as f32, 0.0);
                Triangle::new(o, o + Vec3::X, o + Vec3::Y)
            })
            .collect();
        let mut bvh = Bvh::new(BvhConfig::default());
        // Grown a mesh at a time, as the scene worker grows it: by doubling.
        for chunk in tris.chunks(700) {
            bvh.insert_group(chunk, Affine3A::IDENTITY, false).unwrap();
        }
        bvh.take_changes();
        let nodes: Vec<_> = bvh.gpu_nodes();
        let triangles: Vec<_> = (0..3000).map(|i| bvh.gpu_triangle(i)).collect();
        let before = bvh.memory_bytes();
        bvh.shrink_to_fit();
        let after = bvh.memory_bytes();
        assert!(after.total() < before.total(), "{before:?} -> {after:?}");
        // Nothing but capacity went: the arrays hold what they held, at their lengths.
        assert_eq!(after.triangles, 3000 * (36 + 24 + 4 + 4));
        assert_eq!(bvh.gpu_nodes(), nodes);
        assert_eq!(
            (0..3000).map(|i| bvh.gpu_triangle(i)).collect::<Vec<_>>(),
            triangles
        );
        bvh.validate().unwrap();
        // And it grows again.
        bvh.insert_triangles(&tris[..10]).unwrap();
        bvh.validate().unwrap();
    }
}
