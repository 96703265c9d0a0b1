//! Emissive triangles as lights: the list next-event estimation draws from, each triangle in
//! proportion to its power (its material's emitted luminance times its world-space area), kept per
//! group so that a change re-lists only the groups it touched.
//!
//! The records follow the punctual lights in the lights buffer, in [`GpuLight`]'s layout (kind
//! [`EMITTER_KIND`]): corner 0 in `position`, the edges to corners 1 and 2 in `radiance` and
//! `direction`, the cumulative share of the list's power up to and including the triangle in
//! `inv_range2`, the triangle's id (its shading record: the UVs an emission map is read at) and its
//! group's object slot in `ids`. A triangle's chance of being drawn, over its area, is its
//! material's luminance over the list's total weight, which the kernel computes again where a
//! BSDF sample meets the triangle (multiple importance sampling): the two must agree, so the list
//! holds every triangle of every group whose material emits, or none.

use crate::types::records::GpuLight;
use bevy::math::{Affine3A, Vec3};
use std::collections::HashMap;
use treelight_bvh::{Bvh, GroupId};

/// `Light::kind` of an emissive triangle's record.
pub const EMITTER_KIND: u32 = 3;

/// The most emissive triangles the list holds (64 MiB of records); a scene with more samples
/// none directly, and finds them by its BSDF samples alone, as if none were listed.
pub const MAX_EMITTERS: usize = 1 << 20;

/// Group `g`'s triangles as it places them: each one's id and world-space corners. A group that
/// shares another's triangles (a copy) places the owner's ids under its own transform.
pub fn placed_triangles(bvh: &Bvh, g: GroupId) -> Vec<(u32, [Vec3; 3])> {
    let (Ok(ids), Ok(whole), Ok(transform)) = (
        bvh.shared_triangles(g),
        bvh.is_group_whole(g),
        bvh.group_transform(g),
    ) else {
        return Vec::new();
    };
    ids.iter()
        .filter_map(|&id| {
            // A group kept whole stores its triangles in object space; a baked one in world space.
            let t = *bvh.triangle(id)?;
            Some((id, if whole { t.transformed(&transform) } else { t }.v))
        })
        .collect()
}

/// The luminance of linear RGB, as the kernel's `luminance` weighs it.
pub fn luminance(c: Vec3) -> f32 {
    c.dot(Vec3::new(0.2126, 0.7152, 0.0722))
}

/// One emissive triangle of one group, in world space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Emitter {
    /// World-space corners.
    pub corners: [Vec3; 3],
    /// The triangle's id (its shading record).
    pub triangle: u32,
    /// Its group's object slot (its material).
    pub slot: u32,
    /// Its power up to a constant: the material's emitted luminance times the area.
    pub weight: f32,
}

/// What a group's triangles were listed from: a group is listed again when its transform or its
/// material's emission changes, or when its triangles were laid out again.
#[derive(Clone, Debug, PartialEq)]
struct Listed {
    transform: Affine3A,
    emissive: Vec3,
    emitters: Vec<Emitter>,
    /// The pass that last saw the group (one not seen in a pass is gone).
    seen: u64,
}

/// Every emissive group's triangles, and the records made from them.
#[derive(Default)]
pub struct EmitterList {
    groups: HashMap<u32, Listed>,
    pass: u64,
    changed: bool,
    records: Vec<u8>,
    total: f32,
}

impl EmitterList {
    /// Starts a pass over the scene's groups ([`EmitterList::group`] each, then
    /// [`EmitterList::end_pass`]).
    pub fn begin_pass(&mut self) {
        self.pass += 1;
    }

    /// Group `slot`, placed by `transform`, whose material emits `emissive` (linear, nits),
    /// `relaid` when its triangles changed since the last pass; `world` gives its triangles'
    /// ids and world-space corners, asked only when the group must be listed again.
    pub fn group(
        &mut self,
        slot: u32,
        transform: Affine3A,
        emissive: Vec3,
        relaid: bool,
        world: impl FnOnce() -> Vec<(u32, [Vec3; 3])>,
    ) {
        let pass = self.pass;
        let emits = luminance(emissive) > 0.0 && emissive.is_finite();
        if !emits {
            if self.groups.remove(&slot).is_some() {
                self.changed = true;
            }
            return;
        }
        if let Some(l) = self.groups.get_mut(&slot)
            && !relaid
            && l.transform == transform
            && l.emissive == emissive
        {
            l.seen = pass;
            return;
        }
        let lum = luminance(emissive);
        let emitters = world()
            .into_iter()
            .filter_map(|(triangle, corners)| {
                let area = 0.5
                    * (corners[1] - corners[0])
                        .cross(corners[2] - corners[0])
                        .length();
                let weight = lum * area;
                (weight.is_finite() && weight > 0.0).then_some(Emitter {
                    corners,
                    triangle,
                    slot,
                    weight,
                })
            })
            .collect();
        self.groups.insert(
            slot,
            Listed {
                transform,
                emissive,
                emitters,
                seen: pass,
            },
        );
        self.changed = true;
    }

    /// Ends a pass: groups it did not see are dropped, and the records are made again if anything
    /// changed. Returns whether they were.
    pub fn end_pass(&mut self) -> bool {
        let pass = self.pass;
        let before = self.groups.len();
        self.groups.retain(|_, l| l.seen == pass);
        self.changed |= self.groups.len() != before;
        if !std::mem::take(&mut self.changed) {
            return false;
        }
        // By slot, so the same scene lists the same records whatever the map's order.
        let mut slots: Vec<u32> = self.groups.keys().copied().collect();
        slots.sort_unstable();
        let all: Vec<&Emitter> = slots
            .iter()
            .flat_map(|s| self.groups[s].emitters.iter())
            .collect();
        (self.records, self.total) = if all.len() > MAX_EMITTERS {
            (Vec::new(), 0.0)
        } else {
            emitter_records(all.into_iter().copied())
        };
        true
    }

    /// A list made in one pass over `groups` (each group and its material's emission) of `bvh`;
    /// a group the tree does not hold has no triangles to list.
    pub fn of_groups(bvh: &Bvh, groups: impl IntoIterator<Item = (GroupId, Vec3)>) -> Self {
        let mut list = Self::default();
        list.begin_pass();
        for (g, emissive) in groups {
            if let Ok(transform) = bvh.group_transform(g) {
                list.group(g.index(), transform, emissive, true, || {
                    placed_triangles(bvh, g)
                });
            }
        }
        list.end_pass();
        list
    }

    /// The records, for the lights buffer after the punctual lights.
    pub fn records(&self) -> &[u8] {
        &self.records
    }

    /// How many triangles the records list.
    pub fn count(&self) -> u32 {
        (self.records.len() / size_of::<GpuLight>()) as u32
    }

    /// The sum of the listed triangles' weights (0 with none listed).
    pub fn total(&self) -> f32 {
        self.total
    }
}

/// The records of `emitters`, in order, and the sum of their weights: each record's `inv_range2`
/// the cumulative share of the total up to and including it, the last exactly 1.
pub fn emitter_records(emitters: impl Iterator<Item = Emitter> + Clone) -> (Vec<u8>, f32) {
    let total: f64 = emitters.clone().map(|e| f64::from(e.weight)).sum();
    if !(total > 0.0 && total.is_finite()) {
        return (Vec::new(), 0.0);
    }
    let mut bytes = Vec::new();
    let mut sum = 0.0f64;
    let mut records: Vec<GpuLight> = emitters
        .map(|e| {
            sum += f64::from(e.weight);
            let [a, b, c] = e.corners;
            GpuLight {
                position: a.to_array(),
                kind: EMITTER_KIND,
                radiance: (b - a).to_array(),
                direction: (c - a).to_array(),
                inv_range2: (sum / total) as f32,
                ids: [e.triangle, e.slot],
                ..Default::default()
            }
        })
        .collect();
    if let Some(last) = records.last_mut() {
        last.inv_range2 = 1.0;
    }
    for r in &records {
        bytes.extend_from_slice(bytemuck::bytes_of(r));
    }
    (bytes, total as f32)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square(at: Vec3, side: f32) -> Vec<(u32, [Vec3; 3])> {
        let (x, z) = (Vec3::X * side, Vec3::Z * side);
        vec![(0, [at, at + x, at + x + z]), (1, [at, at + x + z, at + z])]
    }

    fn records(list: &EmitterList) -> Vec<GpuLight> {
        bytemuck::pod_collect_to_vec(list.records())
    }

    #[test]
    fn triangles_are_drawn_in_proportion_to_luminance_times_area() {
        let mut list = EmitterList::default();
        list.begin_pass();
        list.group(4, Affine3A::IDENTITY, Vec3::ONE, true, || {
            square(Vec3::ZERO, 1.0)
        });
        // Twice the side (four times the area) and half the luminance: twice the power.
        list.group(7, Affine3A::IDENTITY, Vec3::splat(0.5), true, || {
            square(Vec3::Y, 2.0)
        });
        list.group(9, Affine3A::IDENTITY, Vec3::ZERO, true, || unreachable!());
        assert!(list.end_pass());
        let r = records(&list);
        assert_eq!(r.len(), 4);
        assert_eq!(list.count(), 4);
        assert!((list.total() - 3.0).abs() < 1e-5, "{}", list.total());
        let cdf: Vec<f32> = r.iter().map(|l| l.inv_range2).collect();
        let want = [1.0 / 6.0, 2.0 / 6.0, 4.0 / 6.0, 1.0];
        for (a, b) in cdf.iter().zip(want) {
            assert!((a - b).abs() < 1e-6, "{cdf:?}");
        }
        assert_eq!(r[3].inv_range2, 1.0);
        assert!(r.iter().all(|l| l.kind == EMITTER_KIND));
        assert_eq!(r[2].ids, [0, 7]);
        assert_eq!(r[2].position, [0.0, 1.0, 0.0]);
        assert_eq!(r[2].radiance, [2.0, 0.0, 0.0]);
        assert_eq!(r[2].direction, [2.0, 0.0, 2.0]);
    }

    #[test]
    fn a_pass_lists_again_only_what_changed() {
        let mut list = EmitterList::default();
        let pass = |list: &mut EmitterList, t: Affine3A, e: Vec3, relaid: bool| {
            let mut asked = false;
            list.begin_pass();
            list.group(1, t, e, relaid, || {
                asked = true;
                square(t.translation.into(), 1.0)
            });
            (list.end_pass(), asked)
        };
        let here = Affine3A::IDENTITY;
        assert_eq!(pass(&mut list, here, Vec3::ONE, true), (true, true));
        // The same group, unchanged: nothing to do.
        assert_eq!(pass(&mut list, here, Vec3::ONE, false), (false, false));
        // Moved, brighter, relaid: listed again.
        let moved = Affine3A::from_translation(Vec3::X);
        assert_eq!(pass(&mut list, moved, Vec3::ONE, false), (true, true));
        assert_eq!(records(&list)[0].position, [1.0, 0.0, 0.0]);
        assert_eq!(
            pass(&mut list, moved, Vec3::splat(2.0), false),
            (true, true)
        );
        assert_eq!(pass(&mut list, moved, Vec3::splat(2.0), true), (true, true));
        // No longer emitting, then gone: the records go with it.
        assert_eq!(pass(&mut list, moved, Vec3::ZERO, false), (true, false));
        assert_eq!(list.count(), 0);
        assert_eq!(list.total(), 0.0);
        assert_eq!(pass(&mut list, moved, Vec3::ONE, false), (true, true));
        list.begin_pass();
        assert!(list.end_pass());
        assert!(list.records().is_empty());
    }

    #[test]
    fn a_copy_is_placed_from_the_triangles_it_shares() {
        use treelight_bvh::Triangle;
        let mut bvh = Bvh::default();
        let tri = Triangle::new(Vec3::ZERO, Vec3::X, Vec3::Y);
        let owner = bvh
            .insert_group(&[tri], Affine3A::from_translation(Vec3::Z), true)
            .unwrap();
        let baked = bvh
            .insert_group(&[tri], Affine3A::from_translation(Vec3::Y), false)
            .unwrap();
        let copy = bvh
            .insert_instance(owner, Affine3A::from_scale(Vec3::splat(2.0)))
            .unwrap();
        let owner_ids = bvh.group_triangles(owner).unwrap().to_vec();
        assert_eq!(
            placed_triangles(&bvh, owner),
            vec![(
                owner_ids[0],
                [Vec3::Z, Vec3::new(1.0, 0.0, 1.0), Vec3::new(0.0, 1.0, 1.0)]
            )]
        );
        assert_eq!(
            placed_triangles(&bvh, copy),
            vec![(owner_ids[0], [Vec3::ZERO, Vec3::X * 2.0, Vec3::Y * 2.0])]
        );
        let baked_ids = bvh.group_triangles(baked).unwrap().to_vec();
        assert_eq!(
            placed_triangles(&bvh, baked),
            vec![(
                baked_ids[0],
                [Vec3::Y, Vec3::new(1.0, 1.0, 0.0), Vec3::Y * 2.0]
            )]
        );
    }

    #[test]
    fn too_many_emitters_list_none() {
        let many = (0..=MAX_EMITTERS as u32).map(|k| Emitter {
            corners: [Vec3::ZERO, Vec3::X, Vec3::Y],
            triangle: k,
            slot: 0,
            weight: 1.0,
        });
        let mut list = EmitterList::default();
        list.begin_pass();
        list.group(0, Affine3A::IDENTITY, Vec3::ONE, true, || {
            many.map(|e| (e.triangle, e.corners)).collect()
        });
        assert!(list.end_pass());
        assert_eq!((list.count(), list.total()), (0, 0.0));
    }
}
