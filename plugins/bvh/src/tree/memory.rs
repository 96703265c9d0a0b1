//! What a tree holds in memory, for the figures that say where an editor's memory goes.

use crate::Bvh;

/// Bytes a vector's buffer holds: its capacity, not its length.
pub(crate) fn vec_bytes<T>(v: &Vec<T>) -> usize {
    v.capacity() * size_of::<T>()
}

/// Bytes a vector holds beyond its length.
pub(crate) fn spare<T>(v: &Vec<T>) -> usize {
    (v.capacity() - v.len()) * size_of::<T>()
}

/// Where a tree's heap bytes are, by what holds them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MemoryBytes {
    /// Inner nodes and their free list.
    pub nodes: usize,
    /// Triangles as stored (world space, or object space in a group kept whole): a grouped
    /// triangle's corners and its group's vertices, a loose one's own corners; with their parents,
    /// groups and free list.
    pub triangles: usize,
    /// Groups: their object-space copies of the vertices and their triangle-id lists.
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

    /// The figure `owner`'s bytes count under.
    fn of(&mut self, owner: Owner) -> &mut usize {
        match owner {
            Owner::Nodes => &mut self.nodes,
            Owner::Triangles => &mut self.triangles,
            Owner::Groups => &mut self.groups,
            Owner::Instances => &mut self.instances,
            Owner::Bookkeeping => &mut self.bookkeeping,
        }
    }
}

/// Which of [`MemoryBytes`]' figures an array counts under.
#[derive(Clone, Copy)]
enum Owner {
    Nodes,
    Triangles,
    Groups,
    Instances,
    Bookkeeping,
}

/// One of the tree's flat arrays, whatever it holds.
trait FlatArray {
    /// Bytes its buffer holds.
    fn heap_bytes(&self) -> usize;
    /// Bytes its buffer holds beyond its length.
    fn spare_bytes(&self) -> usize;
    /// Gives the spare bytes back.
    fn shrink(&mut self);
}

impl FlatArray for crate::tree::corners::Corners {
    fn heap_bytes(&self) -> usize {
        crate::tree::corners::Corners::heap_bytes(self)
    }
    fn spare_bytes(&self) -> usize {
        crate::tree::corners::Corners::spare_bytes(self)
    }
    fn shrink(&mut self) {
        self.trim();
    }
}

impl FlatArray for crate::tree::flags::Flags {
    fn heap_bytes(&self) -> usize {
        crate::tree::flags::Flags::heap_bytes(self)
    }
    fn spare_bytes(&self) -> usize {
        crate::tree::flags::Flags::spare_bytes(self)
    }
    fn shrink(&mut self) {
        self.shrink_to_fit();
    }
}

impl<T> FlatArray for Vec<T> {
    fn heap_bytes(&self) -> usize {
        vec_bytes(self)
    }
    fn spare_bytes(&self) -> usize {
        spare(self)
    }
    fn shrink(&mut self) {
        self.shrink_to_fit();
    }
}

/// The tree's flat arrays, listed once for the figures, the spare room and the trim, so that no
/// array is counted by one of them and missed by another.
macro_rules! flat_arrays {
    ($($owner:ident: $($field:ident).+),* $(,)?) => {
        impl Bvh {
            fn flat_arrays(&self) -> Vec<(Owner, &dyn FlatArray)> {
                vec![$((Owner::$owner, &self.$($field).+ as &dyn FlatArray)),*]
            }
            fn flat_arrays_mut(&mut self) -> Vec<&mut dyn FlatArray> {
                vec![$(&mut self.$($field).+ as &mut dyn FlatArray),*]
            }
        }
    };
}

flat_arrays! {
    Nodes: inner,
    Nodes: inner_free,
    Triangles: tri.corners,
    Triangles: tri.loose,
    Triangles: tri.parent,
    Triangles: tri.group,
    Triangles: tri.free,
    Groups: groups,
    Groups: group_free,
    Instances: instances,
    Instances: inst_free,
    Bookkeeping: cache.nodes,
    Bookkeeping: cache.queued,
}

impl Bvh {
    /// The heap bytes the tree holds, at its arrays' capacities.
    pub fn memory_bytes(&self) -> MemoryBytes {
        let mut bytes = MemoryBytes::default();
        for (owner, array) in self.flat_arrays() {
            *bytes.of(owner) += array.heap_bytes();
        }
        bytes.groups += self
            .groups
            .iter()
            .map(|g| g.triangles.heap_bytes() + vec_bytes(&g.object))
            .sum::<usize>();
        bytes.triangles += self
            .groups
            .iter()
            .map(|g| vec_bytes(&g.vertices))
            .sum::<usize>();
        bytes.bookkeeping += self.changes.heap_bytes() + self.scratch.heap_bytes();
        bytes
    }

    /// Heap bytes the tree holds and does not use now: its arrays' room to grow (up to as much
    /// again as they use, after growing by doubling through a large fill) and the working
    /// memory its passes keep between calls (some sized by the whole tree). [`Bvh::trim`] gives
    /// them back.
    pub fn spare_bytes(&self) -> usize {
        self.flat_arrays()
            .iter()
            .map(|(_, a)| a.spare_bytes())
            .sum::<usize>()
            + self
                .groups
                .iter()
                .map(|g| spare(&g.vertices))
                .sum::<usize>()
            + self.changes.spare_bytes()
            + self.scratch.heap_bytes()
    }

    /// Gives back what [`Bvh::spare_bytes`] counts, for an owner whose tree has come to rest
    /// after a large change (the scene worker after a fill). Nothing the tree holds changes; the
    /// next growth or pass allocates again what it needs.
    pub fn trim(&mut self) {
        for array in self.flat_arrays_mut() {
            array.shrink();
        }
        for g in &mut self.groups {
            g.vertices.shrink_to_fit();
        }
        self.changes.trim();
        self.scratch.trim();
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
        // An unedited baked group holds its triangle ids, not a second copy of its triangles: one
        // run of them, the ids that followed the loose triangles'.
        let slots =
            bvh.groups.capacity() * size_of_val(&bvh.groups[0]) + bvh.group_free.capacity() * 4;
        assert_eq!(grouped.groups, slots + 8);
        // Once moved and baked again, it keeps its object-space vertices (the strip's 2,001), so
        // that later moves start from them exactly.
        bvh.set_group_transform(g, Affine3A::from_translation(Vec3::Z))
            .unwrap();
        bvh.bake_group(g).unwrap();
        assert!(bvh.memory_bytes().groups >= 8 + 2001 * 12);
        assert!(grouped.total() > loose.total());
    }

    #[test]
    fn a_grouped_mesh_keeps_each_vertex_once() {
        // A 100 x 100 grid of quads: 20,000 triangles over 10,201 vertices.
        let n = 100;
        let p = |i: usize, j: usize| Vec3::new(i as f32, j as f32, 0.0);
        let tris: Vec<Triangle> = (0..n * n)
            .flat_map(|k| {
                let (i, j) = (k % n, k / n);
                [
                    Triangle::new(p(i, j), p(i + 1, j), p(i + 1, j + 1)),
                    Triangle::new(p(i, j), p(i + 1, j + 1), p(i, j + 1)),
                ]
            })
            .collect();
        let mut soup = Bvh::new(BvhConfig::default());
        soup.insert_triangles(&tris).unwrap();
        let mut grouped = Bvh::new(BvhConfig::default());
        grouped
            .insert_group(&tris, Affine3A::IDENTITY, false)
            .unwrap();
        soup.trim();
        grouped.trim();
        // Corners 6 B a triangle (the grid's 10,201 vertices need no high halves) and 12 B a
        // vertex, against 36 B of corners apiece; parents and groups (8 B) alike.
        let (soup, grouped) = (soup.memory_bytes(), grouped.memory_bytes());
        assert_eq!(soup.triangles, 20_000 * (36 + 8));
        assert_eq!(grouped.triangles, 20_000 * (6 + 8) + 10_201 * 12);
    }

    #[test]
    fn a_trimmed_tree_holds_less_and_answers_as_before() {
        use crate::Ray;
        let tri = |i: usize| {
            let o = Vec3::new((i % 97) as f32, (i / 97) as f32, (i % 7) as f32 * 0.1);
            Triangle::new(o, o + Vec3::X, o + Vec3::Y)
        };
        let mut bvh = Bvh::new(BvhConfig::default());
        // Meshes one after another: the arrays grow by doubling, as in a fill.
        for m in 0..20 {
            let tris: Vec<Triangle> = (m * 500..(m + 1) * 500).map(tri).collect();
            bvh.insert_group(&tris, Affine3A::IDENTITY, false).unwrap();
        }
        bvh.take_changes();
        let rays: Vec<Ray> = (0..400)
            .map(|i| {
                // Inside the triangles, away from their edges.
                let o = Vec3::new((i % 97) as f32 + 0.2371, (i % 20) as f32 + 0.3113, -1.0);
                Ray::new(o, Vec3::Z)
            })
            .collect();
        let before: Vec<_> = rays.iter().map(|r| bvh.closest_hit(r)).collect();
        assert!(before.iter().any(Option::is_some));
        let (held, spare) = (bvh.memory_bytes().total(), bvh.spare_bytes());
        assert!(spare > 0);
        bvh.trim();
        assert_eq!(bvh.spare_bytes(), 0);
        assert_eq!(bvh.memory_bytes().total(), held - spare);
        bvh.validate().unwrap();
        // The same hits, and each the brute-force closest.
        let after: Vec<_> = rays.iter().map(|r| bvh.closest_hit(r)).collect();
        assert_eq!(before, after);
        for (r, h) in rays.iter().zip(&after) {
            assert_eq!(*h, bvh.brute_force_closest_hit(r));
        }
        // It goes on growing and editing as before.
        let g = bvh
            .insert_group(&[tri(9000)], Affine3A::IDENTITY, false)
            .unwrap();
        bvh.remove_group(g).unwrap();
        bvh.validate().unwrap();
    }
}
