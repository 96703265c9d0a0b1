//! Emissive triangles as lights: the list next-event estimation draws from, each triangle in
//! proportion to its power (its material's emitted luminance times its world-space area), kept per
//! group so that a change re-lists, and uploads, only the groups it touched.
//!
//! The records follow the punctual lights in the lights buffer, in [`GpuLight`]'s layout, in two
//! levels. First a table with one record per listed group (kind [`EMITTER_GROUP_KIND`]): the
//! cumulative share of the list's power up to and including the group in `inv_range2`, and in
//! `ids` where its triangles' records start (counted from the table's start) and how many there
//! are. Then each group's triangles (kind [`EMITTER_KIND`]): corner 0 in `position`, the edges to
//! corners 1 and 2 in `radiance` and `direction`, the cumulative share of the group's power up to
//! and including the triangle in `inv_range2`, the triangle's id (its shading record: the UVs an
//! emission map is read at) and its group's object slot in `ids`. The kernel draws a group by its
//! share, then a triangle by its share of the group's, so a triangle's chance over its area is its
//! material's luminance over the list's total weight, as with one list; the kernel computes that
//! again where a BSDF sample meets the triangle (multiple importance sampling): the two must
//! agree, so the list holds every triangle of every group whose material emits, or none. A group
//! that moves, or whose emission changes, keeps its range: its records and the table are all
//! that is written again.

use crate::types::records::GpuLight;
use bevy::math::{Affine3A, Vec3};
use std::collections::HashMap;
use treelight_bvh::{Bvh, GroupId};

/// `Light::kind` of an emissive triangle's record.
pub const EMITTER_KIND: u32 = 3;

/// `Light::kind` of a group's record in the emitters' table.
pub const EMITTER_GROUP_KIND: u32 = 4;

/// The most emissive triangles the list holds (64 MiB of records); a scene with more samples
/// none directly, and finds them by its BSDF samples alone, as if none were listed.
pub const MAX_EMITTERS: usize = 1 << 20;

/// Bytes of one record.
const RECORD_BYTES: u64 = size_of::<GpuLight>() as u64;

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
        .filter_map(|id| {
            // A group kept whole stores its triangles in object space; a baked one in world space.
            let t = bvh.triangle(id)?;
            Some((id, if whole { t.transformed(&transform) } else { t }.v))
        })
        .collect()
}

/// The luminance of linear RGB, as the kernel's `luminance` weighs it.
pub fn luminance(c: Vec3) -> f32 {
    c.dot(Vec3::new(0.2126, 0.7152, 0.0722))
}

/// What a group's triangles were listed from, and their records: a group is listed again when its
/// transform or its material's emission changes, or when its triangles were laid out again.
#[derive(Clone, Debug, PartialEq)]
struct Listed {
    transform: Affine3A,
    emissive: Vec3,
    /// Its triangles' records, each with its cumulative share of the group's power.
    records: Vec<GpuLight>,
    /// The group's power up to a constant (its triangles' luminance times area).
    weight: f64,
    /// Where its records start, counted in records from the table's start (when listed).
    first: u32,
    /// The pass that last saw the group (one not seen in a pass is gone).
    seen: u64,
}

/// Every emissive group's triangles, the table over them, and what the GPU's copy lacks.
#[derive(Default)]
pub struct EmitterList {
    groups: HashMap<u32, Listed>,
    /// The listed groups (with a triangle of some power), in the records' order: by slot.
    order: Vec<u32>,
    pass: u64,
    changed: bool,
    /// Whether the groups' ranges moved since the last [`EmitterList::take_writes`].
    relaid: bool,
    /// Groups whose records were made again in their range since then.
    rewritten: Vec<u32>,
    table: Vec<GpuLight>,
    /// Triangles listed.
    count: u32,
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
                (self.changed, self.relaid) = (true, true);
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
        let (records, weight) = group_records(slot, luminance(emissive), world());
        let listed = Listed {
            transform,
            emissive,
            records,
            weight,
            first: 0,
            seen: pass,
        };
        match self.groups.get_mut(&slot) {
            // The same number of records: they fit its range.
            Some(old) if old.records.len() == listed.records.len() => {
                *old = Listed {
                    first: old.first,
                    ..listed
                };
                self.rewritten.push(slot);
            }
            _ => {
                self.groups.insert(slot, listed);
                self.relaid = true;
            }
        }
        self.changed = true;
    }

    /// Ends a pass: groups it did not see are dropped, and the table is made again if anything
    /// changed (the groups' ranges too if one was added, dropped or changed its count). Returns
    /// whether anything did.
    pub fn end_pass(&mut self) -> bool {
        let pass = self.pass;
        let before = self.groups.len();
        self.groups.retain(|_, l| l.seen == pass);
        if self.groups.len() != before {
            (self.changed, self.relaid) = (true, true);
        }
        if !std::mem::take(&mut self.changed) {
            return false;
        }
        if self.relaid {
            self.lay_out();
        }
        self.make_table();
        true
    }

    /// The groups' ranges after the table, by slot (so the same scene lists the same records
    /// whatever the map's order), or none when the scene has more triangles than the list holds.
    fn lay_out(&mut self) {
        let mut order: Vec<u32> = self
            .groups
            .iter()
            .filter(|(_, l)| !l.records.is_empty())
            .map(|(&s, _)| s)
            .collect();
        order.sort_unstable();
        let triangles: usize = order.iter().map(|s| self.groups[s].records.len()).sum();
        if triangles > MAX_EMITTERS {
            order.clear();
        }
        let mut first = order.len() as u32;
        for s in &order {
            let l = self.groups.get_mut(s).expect("a listed group");
            l.first = first;
            first += l.records.len() as u32;
        }
        self.count = first - order.len() as u32;
        self.order = order;
    }

    /// The table: each listed group's cumulative share of the total, the last exactly 1.
    fn make_table(&mut self) {
        let total: f64 = self.order.iter().map(|s| self.groups[s].weight).sum();
        self.table.clear();
        if !(total > 0.0 && total.is_finite()) {
            (self.order, self.count, self.total) = (Vec::new(), 0, 0.0);
            return;
        }
        let mut sum = 0.0f64;
        for s in &self.order {
            let l = &self.groups[s];
            sum += l.weight;
            self.table.push(GpuLight {
                kind: EMITTER_GROUP_KIND,
                inv_range2: (sum / total) as f32,
                ids: [l.first, l.records.len() as u32],
                ..Default::default()
            });
        }
        if let Some(last) = self.table.last_mut() {
            last.inv_range2 = 1.0;
        }
        self.total = total as f32;
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

    /// Every record, the table then each group's triangles: the lights buffer after the punctual
    /// lights.
    pub fn bytes(&self) -> Vec<u8> {
        let mut bytes = Vec::with_capacity((self.record_count() as u64 * RECORD_BYTES) as usize);
        bytes.extend_from_slice(bytemuck::cast_slice(&self.table));
        for s in &self.order {
            bytes.extend_from_slice(bytemuck::cast_slice(&self.groups[s].records));
        }
        bytes
    }

    /// What the GPU's copy lacks since the last call, as (offset in bytes from the table's start,
    /// bytes): everything when the ranges moved or `everything` is asked (the records moved in
    /// the buffer), else the table and the groups made again in their ranges.
    pub fn take_writes(&mut self, everything: bool) -> Vec<(u64, Vec<u8>)> {
        let relaid = std::mem::take(&mut self.relaid) || everything;
        let mut rewritten = std::mem::take(&mut self.rewritten);
        if self.table.is_empty() {
            return Vec::new();
        }
        if relaid {
            return vec![(0, self.bytes())];
        }
        if rewritten.is_empty() {
            return Vec::new();
        }
        rewritten.sort_unstable();
        rewritten.dedup();
        let mut writes = vec![(0, bytemuck::cast_slice(&self.table).to_vec())];
        for s in rewritten {
            if let Some(l) = self.groups.get(&s).filter(|l| !l.records.is_empty()) {
                writes.push((
                    u64::from(l.first) * RECORD_BYTES,
                    bytemuck::cast_slice(&l.records).to_vec(),
                ));
            }
        }
        writes
    }

    /// Records in all: the table's and the triangles'.
    pub fn record_count(&self) -> u32 {
        self.table.len() as u32 + self.count
    }

    /// Groups in the table (0: nothing listed).
    pub fn group_count(&self) -> u32 {
        self.table.len() as u32
    }

    /// How many triangles the records list.
    pub fn count(&self) -> u32 {
        self.count
    }

    /// The sum of the listed triangles' weights (0 with none listed).
    pub fn total(&self) -> f32 {
        self.total
    }
}

/// A group's triangle records and its weight: each triangle of some power, with its cumulative
/// share of the group's (the last exactly 1).
fn group_records(slot: u32, lum: f32, triangles: Vec<(u32, [Vec3; 3])>) -> (Vec<GpuLight>, f64) {
    let weighed: Vec<(u32, [Vec3; 3], f64)> = triangles
        .into_iter()
        .filter_map(|(triangle, [a, b, c])| {
            let weight = lum * 0.5 * (b - a).cross(c - a).length();
            (weight.is_finite() && weight > 0.0).then_some((triangle, [a, b, c], f64::from(weight)))
        })
        .collect();
    let total: f64 = weighed.iter().map(|w| w.2).sum();
    let mut sum = 0.0f64;
    let mut records: Vec<GpuLight> = weighed
        .into_iter()
        .map(|(triangle, [a, b, c], weight)| {
            sum += weight;
            GpuLight {
                position: a.to_array(),
                kind: EMITTER_KIND,
                radiance: (b - a).to_array(),
                direction: (c - a).to_array(),
                inv_range2: (sum / total) as f32,
                ids: [triangle, slot],
                ..Default::default()
            }
        })
        .collect();
    if let Some(last) = records.last_mut() {
        last.inv_range2 = 1.0;
    }
    (records, total)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square(at: Vec3, side: f32) -> Vec<(u32, [Vec3; 3])> {
        let (x, z) = (Vec3::X * side, Vec3::Z * side);
        vec![(0, [at, at + x, at + x + z]), (1, [at, at + x + z, at + z])]
    }

    fn records(list: &EmitterList) -> Vec<GpuLight> {
        bytemuck::pod_collect_to_vec(&list.bytes())
    }

    /// Each triangle record's chance of being drawn: its group's share times its share of the
    /// group's, read from the records as the kernel reads them.
    fn chances(list: &EmitterList) -> Vec<(u32, f64)> {
        let r = records(list);
        let groups = list.group_count() as usize;
        let mut out = Vec::new();
        let mut before = 0.0;
        for g in &r[..groups] {
            assert_eq!(g.kind, EMITTER_GROUP_KIND);
            let share = f64::from(g.inv_range2) - before;
            before = f64::from(g.inv_range2);
            let [first, count] = g.ids;
            let mut within = 0.0;
            for t in &r[first as usize..(first + count) as usize] {
                assert_eq!(t.kind, EMITTER_KIND);
                out.push((t.ids[1], share * (f64::from(t.inv_range2) - within)));
                within = f64::from(t.inv_range2);
            }
            assert_eq!(within, 1.0, "a group's last triangle ends its shares");
        }
        assert_eq!(before, 1.0, "the last group ends the table");
        out
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
        assert_eq!(
            (list.count(), list.group_count(), list.record_count()),
            (4, 2, 6)
        );
        assert!((list.total() - 3.0).abs() < 1e-5, "{}", list.total());
        let want = [
            (4, 1.0 / 6.0),
            (4, 1.0 / 6.0),
            (7, 2.0 / 6.0),
            (7, 2.0 / 6.0),
        ];
        for ((slot, p), (want_slot, q)) in chances(&list).into_iter().zip(want) {
            assert_eq!(slot, want_slot);
            assert!((p - q).abs() < 1e-6, "{p} against {q}");
        }
        let r = records(&list);
        assert_eq!(r[0].ids, [2, 2]);
        assert_eq!(r[1].ids, [4, 2]);
        assert_eq!(r[4].ids, [0, 7]);
        assert_eq!(r[4].position, [0.0, 1.0, 0.0]);
        assert_eq!(r[4].radiance, [2.0, 0.0, 0.0]);
        assert_eq!(r[4].direction, [2.0, 0.0, 2.0]);
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
            list.group(2, Affine3A::IDENTITY, Vec3::ONE, false, || {
                square(Vec3::Y, 1.0)
            });
            (list.end_pass(), asked)
        };
        let here = Affine3A::IDENTITY;
        assert_eq!(pass(&mut list, here, Vec3::ONE, true), (true, true));
        assert_eq!(list.take_writes(false), vec![(0, list.bytes())]);
        // The same group, unchanged: nothing to do.
        assert_eq!(pass(&mut list, here, Vec3::ONE, false), (false, false));
        assert!(list.take_writes(false).is_empty());
        // Moved, brighter, relaid: listed again, in its range: the table and its records.
        let moved = Affine3A::from_translation(Vec3::X);
        assert_eq!(pass(&mut list, moved, Vec3::ONE, false), (true, true));
        assert_eq!(records(&list)[2].position, [1.0, 0.0, 0.0]);
        let writes = list.take_writes(false);
        let bytes = list.bytes();
        let table = 2 * RECORD_BYTES as usize;
        assert_eq!(
            writes,
            vec![
                (0, bytes[..table].to_vec()),
                (table as u64, bytes[table..2 * table].to_vec())
            ]
        );
        assert_eq!(
            pass(&mut list, moved, Vec3::splat(2.0), false),
            (true, true)
        );
        assert_eq!(list.take_writes(false).len(), 2);
        assert_eq!(pass(&mut list, moved, Vec3::splat(2.0), true), (true, true));
        // Asked for everything (the punctual lights before them changed in number): all of it.
        assert_eq!(list.take_writes(true), vec![(0, list.bytes())]);
        // No longer emitting, then gone: the records go with it, the others move up.
        assert_eq!(pass(&mut list, moved, Vec3::ZERO, false), (true, false));
        assert_eq!((list.count(), list.group_count()), (2, 1));
        assert_eq!(list.take_writes(false), vec![(0, list.bytes())]);
        assert_eq!(pass(&mut list, moved, Vec3::ONE, false), (true, true));
        list.begin_pass();
        assert!(list.end_pass());
        assert!(list.bytes().is_empty());
        assert_eq!((list.count(), list.total()), (0, 0.0));
        assert!(list.take_writes(false).is_empty());
    }

    proptest::proptest! {
        /// Whatever passes change, the GPU's copy kept by `take_writes` alone is the list, and
        /// every triangle's chance is its share of the power.
        #[test]
        fn the_copy_kept_by_the_writes_is_the_list(
            passes in proptest::collection::vec(
                proptest::collection::vec((0u32..6, 0u32..4, 1u32..4, proptest::bool::ANY), 0..6),
                1..12,
            )
        ) {
            let mut list = EmitterList::default();
            let mut copy: Vec<u8> = Vec::new();
            // Per slot: place, brightness (0: dark), squares of two triangles.
            let mut scene: HashMap<u32, (u32, u32, u32)> = HashMap::new();
            for edits in passes {
                // An edited group is laid out again (its triangles may change in number).
                let mut edited = std::collections::HashSet::new();
                for (slot, place, size, dark) in edits {
                    scene.insert(slot, (place, if dark { 0 } else { size }, size));
                    edited.insert(slot);
                }
                list.begin_pass();
                for (&slot, &(place, bright, size)) in &scene {
                    let at = Vec3::new(slot as f32 * 3.0, place as f32, 0.0);
                    let t = Affine3A::from_translation(at);
                    let e = Vec3::splat(bright as f32);
                    list.group(slot, t, e, edited.contains(&slot), || {
                        (0..size).flat_map(|k| square(at + Vec3::Z * k as f32, 1.0)).collect()
                    });
                }
                list.end_pass();
                for (at, bytes) in list.take_writes(false) {
                    let end = at as usize + bytes.len();
                    if copy.len() < end {
                        copy.resize(end, 0);
                    }
                    copy[at as usize..end].copy_from_slice(&bytes);
                }
                let bytes = list.bytes();
                proptest::prop_assert_eq!(&copy[..bytes.len()], &bytes[..]);
                if list.group_count() > 0 {
                    let total: f64 = chances(&list).iter().map(|c| c.1).sum();
                    proptest::prop_assert!((total - 1.0).abs() < 1e-5);
                    // A triangle's power is half its square's; a group's, its brightness times
                    // its squares.
                    let power: f64 = scene.values().map(|&(_, b, n)| f64::from(b * n)).sum();
                    for (slot, p) in chances(&list) {
                        let want = 0.5 * f64::from(scene[&slot].1) / power;
                        proptest::prop_assert!((p - want).abs() < 1e-5, "{} {} {}", slot, p, want);
                    }
                }
            }
        }
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
        let mut list = EmitterList::default();
        list.begin_pass();
        list.group(0, Affine3A::IDENTITY, Vec3::ONE, true, || {
            (0..=MAX_EMITTERS as u32)
                .map(|k| (k, [Vec3::ZERO, Vec3::X, Vec3::Y]))
                .collect()
        });
        assert!(list.end_pass());
        assert_eq!(
            (list.count(), list.total(), list.group_count()),
            (0, 0.0, 0)
        );
        assert!(list.take_writes(false).is_empty());
    }
}
