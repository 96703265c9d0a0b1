//! Groups that share another group's triangles: each is one instance node over the same
//! object-space subtree, so a copy of a mesh costs one node and one search, never its triangles.

use crate::edit::group::GroupId;
use crate::tree::bvh::Group;
use crate::tree::node::{NONE, NodeRef};
use crate::{Bvh, BvhError, Hit, Triangle, TriangleIds};
use glam::Affine3A;

impl Bvh {
    /// Adds a group that shares `of`'s triangles under its own `transform` (an instance of the same
    /// object-space subtree). `of` may itself share another's; the triangles are then that group's.
    /// The triangles stay while any group using them is alive, whichever is removed first.
    pub fn insert_instance(
        &mut self,
        of: GroupId,
        transform: Affine3A,
    ) -> Result<GroupId, BvhError> {
        if !transform.is_finite() || !transform.matrix3.determinant().is_normal() {
            return Err(BvhError::BadTransform);
        }
        let g = self.group(of)?;
        let (source, instance, placed) = (g.source, g.instance, g.transform);
        let owner = if source != NONE { source } else { of.index() };
        if self.groups[owner as usize].triangles.is_empty() {
            return self.insert_group(&[], transform, true);
        }
        if instance == NONE {
            // A baked owner goes back to object space once; it stays where it is.
            self.set_group_transform(of, placed)?;
        }
        let root = self.instances[self.groups[of.index() as usize].instance as usize].root;
        let index = self.take_group_slot();
        let instance = self.make_instance(root, transform, index);
        self.insert_item(NodeRef::instance(instance));
        let slot = &mut self.groups[index as usize];
        slot.alive = true;
        slot.retired = false;
        slot.triangles = TriangleIds::default();
        slot.vertices = Vec::new();
        slot.object = Vec::new();
        slot.transform = transform;
        slot.instance = instance;
        slot.source = owner;
        slot.users = 0;
        let generation = slot.generation;
        self.groups[owner as usize].users += 1;
        Ok(GroupId::new(index, generation))
    }

    /// The triangle ids a group is made of: its own, or those of the group it shares them with.
    pub fn shared_triangles(&self, id: GroupId) -> Result<&TriangleIds, BvhError> {
        let g = self.group(id)?;
        let owner = if g.source != NONE {
            g.source
        } else {
            id.index()
        };
        Ok(&self.groups[owner as usize].triangles)
    }

    /// Whether the group shares another's triangles, or others share its.
    pub fn is_group_shared(&self, id: GroupId) -> Result<bool, BvhError> {
        let g = self.group(id)?;
        Ok(g.source != NONE || g.users > 0)
    }

    /// The group a hit belongs to: the instance it was reached through, or its triangle's group.
    pub fn hit_group(&self, hit: &Hit) -> Option<GroupId> {
        if hit.instance != NONE {
            let g = self.instance(hit.instance)?.group;
            let slot = self.groups.get(g as usize)?;
            return (slot.alive && !slot.retired).then(|| GroupId::new(g, slot.generation));
        }
        self.triangle_group(hit.triangle)
    }

    /// The hit triangle in world space, placed by the instance the ray reached it through.
    pub fn hit_world_triangle(&self, hit: &Hit) -> Option<Triangle> {
        if hit.instance != NONE {
            let inst = self.instance(hit.instance)?;
            return Some(self.triangle(hit.triangle)?.transformed(&inst.transform));
        }
        self.world_triangle(hit.triangle)
    }

    /// A free group slot (reused or new), not yet alive.
    pub(crate) fn take_group_slot(&mut self) -> u32 {
        match self.group_free.pop() {
            Some(i) => i,
            None => {
                self.groups.push(Group {
                    generation: 0,
                    alive: false,
                    triangles: TriangleIds::default(),
                    vertices: Vec::new(),
                    object: Vec::new(),
                    transform: Affine3A::IDENTITY,
                    instance: NONE,
                    source: NONE,
                    users: 0,
                    retired: false,
                });
                self.groups.len() as u32 - 1
            }
        }
    }

    /// Removes a group that shares another's triangles: its instance node goes; the triangles go
    /// with their last user once their owner was removed.
    pub(crate) fn remove_user(&mut self, index: u32) {
        let g = &self.groups[index as usize];
        let (owner, instance) = (g.source, g.instance);
        let root = self.instances[instance as usize].root;
        self.detach_instance(instance);
        self.free_instance(instance);
        self.free_group_slot(index);
        let o = &mut self.groups[owner as usize];
        o.users -= 1;
        if o.users == 0 && o.retired {
            let triangles = std::mem::take(&mut o.triangles).to_vec();
            let mut inner = Vec::new();
            self.collect_inner(root, &mut inner);
            for i in inner {
                self.free_inner(i);
            }
            for t in triangles {
                self.free_triangle(t);
            }
            self.free_group_slot(owner);
        }
    }

    /// Removes an owner's handle and instance node while others still use its triangles.
    pub(crate) fn retire(&mut self, index: u32) {
        let instance = self.groups[index as usize].instance;
        self.detach_instance(instance);
        self.free_instance(instance);
        let g = &mut self.groups[index as usize];
        g.retired = true;
        g.instance = NONE;
        g.generation = g.generation.wrapping_add(1);
    }

    /// After an owner's triangles changed: every group sharing them gets its box again.
    pub(crate) fn refresh_users(&mut self, owner: u32) {
        if self.groups[owner as usize].users == 0 {
            return;
        }
        let users: Vec<GroupId> = (0..self.groups.len() as u32)
            .filter(|&i| {
                let g = &self.groups[i as usize];
                g.alive && !g.retired && g.source == owner
            })
            .map(|i| GroupId::new(i, self.groups[i as usize].generation))
            .collect();
        for u in users {
            let t = self.groups[u.index() as usize].transform;
            // The handles were made just now from live slots.
            let _ = self.set_group_transform(u, t);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{BvhConfig, Ray};
    use glam::Vec3;

    fn quad(z: f32) -> Vec<Triangle> {
        let (a, b, c, d) = (
            Vec3::new(-1.0, -1.0, z),
            Vec3::new(1.0, -1.0, z),
            Vec3::new(1.0, 1.0, z),
            Vec3::new(-1.0, 1.0, z),
        );
        vec![Triangle::new(a, b, c), Triangle::new(a, c, d)]
    }

    fn down_at(x: f32) -> Ray {
        Ray::new(Vec3::new(x, 0.0, 10.0), Vec3::NEG_Z)
    }

    #[test]
    fn a_shared_mesh_outlives_its_owner_and_goes_with_its_last_user() {
        let mut bvh = Bvh::new(BvhConfig::default());
        let owner = bvh
            .insert_group(&quad(0.0), Affine3A::IDENTITY, false)
            .unwrap();
        let copy = bvh
            .insert_instance(owner, Affine3A::from_translation(Vec3::new(5.0, 0.0, 0.0)))
            .unwrap();
        bvh.validate().unwrap();
        assert_eq!(bvh.triangle_count(), 2);
        assert!(
            bvh.is_group_whole(owner).unwrap(),
            "the owner left its baked state"
        );
        let hit = bvh.closest_hit(&down_at(5.0)).unwrap();
        assert_eq!(bvh.hit_group(&hit), Some(copy));
        let world = bvh.hit_world_triangle(&hit).unwrap();
        assert!(world.v.iter().all(|p| p.x >= 4.0));
        assert_eq!(
            bvh.hit_group(&bvh.closest_hit(&down_at(0.0)).unwrap()),
            Some(owner)
        );

        // Shared triangles cannot be removed one by one, and never bake.
        let t = bvh.shared_triangles(copy).unwrap().get(0).unwrap();
        assert_eq!(
            bvh.remove_triangles(&[t]),
            Err(BvhError::SharedTriangles(t))
        );
        bvh.bake_group(owner).unwrap();
        assert!(bvh.is_group_whole(owner).unwrap());

        // Editing the owner's vertices moves the copy's too.
        bvh.update_group_vertices(owner, &quad(3.0)).unwrap();
        bvh.validate().unwrap();
        assert!((bvh.closest_hit(&down_at(5.0)).unwrap().t - 7.0).abs() < 1e-5);

        bvh.remove_group(owner).unwrap();
        bvh.validate().unwrap();
        assert_eq!(bvh.remove_group(owner), Err(BvhError::UnknownGroup));
        assert_eq!(bvh.triangle_count(), 2, "the copy keeps the triangles");
        assert!(bvh.closest_hit(&down_at(0.0)).is_none());
        let hit = bvh.closest_hit(&down_at(5.0)).unwrap();
        assert_eq!(bvh.hit_group(&hit), Some(copy));
        // A copy of the copy shares the same triangles.
        let again = bvh
            .insert_instance(copy, Affine3A::from_translation(Vec3::new(-5.0, 0.0, 0.0)))
            .unwrap();
        assert_eq!(bvh.triangle_count(), 2);
        bvh.remove_group(copy).unwrap();
        bvh.validate().unwrap();
        assert_eq!(
            bvh.hit_group(&bvh.closest_hit(&down_at(-5.0)).unwrap()),
            Some(again)
        );
        bvh.remove_group(again).unwrap();
        bvh.validate().unwrap();
        assert_eq!(bvh.triangle_count(), 0);
        assert!(bvh.closest_hit(&down_at(-5.0)).is_none());
    }
}
