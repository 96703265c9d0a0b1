//! The triangles for a GPU as the tree keeps them: each grouped triangle three indices into one
//! pool of positions, where each group's vertices take one run (a mesh's positions are shared by
//! the triangles that meet there, half a vertex a triangle on a typical mesh), so a triangle's
//! record is 12 bytes and its share of the pool half a position, against 36 bytes for three
//! corners of its own ([`crate::GpuTriangle`]). A triangle outside any group takes a run of three.
//!
//! Each position record also names the group whose run holds it, so a renderer finds a hit's group
//! from its triangle's first corner instead of keeping a word for it beside every triangle.
//!
//! The pool is kept in step with the tree's change sets ([`PositionPool::update`]), as
//! [`crate::WideRecords`] keeps the node records: a group whose vertices are written gets them
//! written again in its run; a group whose vertex count changed (triangles edited one by one,
//! its vertices compacted) takes a new run, and then every one of its triangles is rewritten.

use super::runs::RunAllocator;
use crate::tree::node::NONE;
use crate::{Bvh, ChangeSet};
use bytemuck::{Pod, Zeroable};
use std::collections::HashMap;

/// One triangle for a GPU: its three corners, records of the position pool, 12 bytes. A freed
/// slot's record names record 0 three times: a triangle of no area, which no ray hits.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct GpuIndexedTriangle {
    /// The pool records of corners 0, 1 and 2.
    pub corners: [u32; 3],
}

/// One record of the position pool, 16 bytes: a vertex's position and the slot of the group whose
/// run holds it ([`NONE`](crate::NONE) in a loose triangle's run). A GPU reads it as a
/// `vec4<f32>` (one load where three floats would be three) and takes the slot from the fourth
/// float's bits, which no arithmetic touches.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuPosition {
    /// The position, as the tree stores it.
    pub position: [f32; 3],
    /// The slot of the group whose run this is, or [`NONE`](crate::NONE).
    pub group: u32,
}

impl GpuPosition {
    /// The record of `position` in a run holding `source`'s positions.
    pub fn new(position: glam::Vec3, source: PositionSource) -> Self {
        Self {
            position: position.to_array(),
            group: match source {
                PositionSource::Group(slot) => slot,
                PositionSource::Loose(_) => NONE,
            },
        }
    }
}

/// Whose positions a run of the pool holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PositionSource {
    /// The vertices of the group in this slot, as stored (world space while baked, object space
    /// while whole).
    Group(u32),
    /// The three corners of this triangle, outside any group.
    Loose(u32),
}

/// What one [`PositionPool::update`] asks a renderer to write.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PositionChanges {
    /// Runs of the pool to write: the first record and whose positions fill the run
    /// ([`PositionPool::positions`]).
    pub runs: Vec<(u32, PositionSource)>,
    /// Triangle records to write besides the change set's written and removed ones: the
    /// triangles of groups whose run moved. Sorted, each once.
    pub triangles: Vec<u32>,
}

/// A group's run.
#[derive(Clone, Copy, Debug)]
struct GroupRun {
    first: u32,
    len: u32,
    generation: u32,
}

/// The pool's runs: one per group with vertices, three records per loose triangle.
#[derive(Clone, Debug, Default)]
pub struct PositionPool {
    runs: RunAllocator,
    /// By group slot.
    groups: Vec<Option<GroupRun>>,
    /// By triangle id: the first of its three records.
    loose: HashMap<u32, u32>,
}

impl PositionPool {
    /// A pool holding every triangle of `bvh`, and its runs to write (everything).
    pub fn of(bvh: &Bvh) -> (Self, PositionChanges) {
        let mut pool = Self::default();
        let changes = pool.update(bvh, &all_written(bvh));
        (pool, changes)
    }

    /// Brings the pool in step with `changes` (taken from `bvh` since the last update). After
    /// [`Bvh::mark_all_changed`], a fresh pool lays out everything.
    pub fn update(&mut self, bvh: &Bvh, changes: &ChangeSet) -> PositionChanges {
        let mut out = PositionChanges::default();
        if changes.written_triangles.is_empty() && changes.removed_triangles.is_empty() {
            // No triangle changed, so no group's vertices did.
            return out;
        }
        self.groups
            .resize(bvh.groups.len().max(self.groups.len()), None);
        let mut touched = vec![false; bvh.groups.len()];
        for &t in changes
            .written_triangles
            .iter()
            .chain(&changes.removed_triangles)
        {
            let live = bvh.is_live_triangle(t);
            let group = if live {
                bvh.tri.group[t as usize]
            } else {
                NONE
            };
            if live && group == NONE {
                let first = match self.loose.get(&t) {
                    Some(&first) => Some(first),
                    None => self.runs.allocate(3).inspect(|&first| {
                        self.loose.insert(t, first);
                    }),
                };
                if let Some(first) = first {
                    out.runs.push((first, PositionSource::Loose(t)));
                }
                continue;
            }
            if let Some(first) = self.loose.remove(&t) {
                self.runs.free(first, 3);
            }
            if group != NONE {
                touched[group as usize] = true;
            }
        }
        for slot in 0..self.groups.len() {
            self.update_group(bvh, slot, touched.get(slot) == Some(&true), &mut out);
        }
        out.triangles.sort_unstable();
        out.triangles.dedup();
        out
    }

    /// Group slot `slot`'s run after an edit: given back if the group is gone, taken anew (and
    /// all its triangles queued) if its vertex count changed, written again if it was touched.
    fn update_group(&mut self, bvh: &Bvh, slot: usize, touched: bool, out: &mut PositionChanges) {
        // A retired owner is not alive to `Bvh::group`, but its triangles live on. A group
        // without triangles (made empty, or whose triangles were all removed) needs no run.
        let group = bvh
            .groups
            .get(slot)
            .filter(|g| (g.alive || g.retired) && !g.triangles.is_empty());
        let len = group.map_or(0, |g| g.vertices.len() as u32);
        let run = &mut self.groups[slot];
        if let Some(r) = *run {
            let same = group.is_some_and(|g| g.generation == r.generation);
            if same && r.len == len {
                if touched {
                    out.runs.push((r.first, PositionSource::Group(slot as u32)));
                }
                return;
            }
            self.runs.free(r.first, r.len);
            *run = None;
        }
        let Some(g) = group.filter(|_| len > 0) else {
            return;
        };
        let Some(first) = self.runs.allocate(len) else {
            return;
        };
        *run = Some(GroupRun {
            first,
            len,
            generation: g.generation,
        });
        out.runs.push((first, PositionSource::Group(slot as u32)));
        out.triangles.extend(g.triangles.iter());
    }

    /// Triangle `t`'s record: its corners in the pool (a freed slot's: record 0 three times).
    pub fn record(&self, bvh: &Bvh, t: u32) -> GpuIndexedTriangle {
        let group = bvh.tri.group.get(t as usize).copied().unwrap_or(NONE);
        let corners = if !bvh.is_live_triangle(t) {
            None
        } else if group == NONE {
            // Looked up only for loose triangles: a fill's frame asks millions of grouped ones.
            self.loose
                .get(&t)
                .map(|&first| [first, first + 1, first + 2])
        } else {
            self.groups
                .get(group as usize)
                .copied()
                .flatten()
                .map(|r| bvh.tri.corners.get(t as usize).map(|c| r.first + c))
        };
        GpuIndexedTriangle {
            corners: corners.unwrap_or([0; 3]),
        }
    }

    /// The positions a run holds, in its order, as the tree stores them.
    pub fn positions<'a>(&self, bvh: &'a Bvh, source: PositionSource) -> &'a [glam::Vec3] {
        match source {
            PositionSource::Group(slot) => bvh
                .groups
                .get(slot as usize)
                .map_or(&[], |g| g.vertices.as_slice()),
            PositionSource::Loose(t) => {
                let at = 3 * t as usize;
                bvh.tri.loose.get(at..at + 3).unwrap_or(&[])
            }
        }
    }

    /// Writes the runs `changes` names into `pool`, a CPU copy of the whole pool (a renderer's
    /// mirror, a test's), first growing it to [`Self::end`] records; records it grows by hold NaN
    /// until a run is written there.
    pub fn write_runs(&self, bvh: &Bvh, changes: &PositionChanges, pool: &mut Vec<GpuPosition>) {
        let unwritten = GpuPosition::new(glam::Vec3::NAN, PositionSource::Loose(0));
        pool.resize(self.end() as usize, unwritten);
        for &(first, source) in &changes.runs {
            let run = self.positions(bvh, source);
            let at = first as usize;
            for (record, &p) in pool[at..at + run.len()].iter_mut().zip(run) {
                *record = GpuPosition::new(p, source);
            }
        }
    }

    /// Records the runs reach: what the pool's buffer must hold.
    pub fn end(&self) -> u32 {
        self.runs.end()
    }

    /// Records in live runs.
    pub fn live_records(&self) -> u64 {
        u64::from(self.runs.end()) - self.runs.free_records()
    }

    /// Bytes of this bookkeeping on the heap (the runs by slot and by loose triangle; the free
    /// runs' maps are counted by their entries).
    pub fn heap_bytes(&self) -> usize {
        self.groups.capacity() * size_of::<Option<GroupRun>>()
            + self.loose.capacity() * (size_of::<(u32, u32)>() + 1)
            + self.runs.heap_bytes()
    }
}

/// A change set with every live triangle of `bvh` written: what a pool laid out afresh reads.
fn all_written(bvh: &Bvh) -> ChangeSet {
    ChangeSet {
        written_triangles: (0..bvh.triangle_capacity())
            .filter(|&t| bvh.is_live_triangle(t))
            .collect(),
        ..Default::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{BvhConfig, Triangle};
    use glam::{Affine3A, Vec3};

    /// The positions of triangle `t` as a GPU reads them from CPU copies of the two buffers, and
    /// the group its first corner names.
    fn gathered(records: &[GpuIndexedTriangle], pool: &[GpuPosition], t: u32) -> ([Vec3; 3], u32) {
        let corners = records[t as usize].corners;
        (
            corners.map(|c| Vec3::from_array(pool[c as usize].position)),
            pool[corners[0] as usize].group,
        )
    }

    /// Triangle `t` as the tree has it, and its group's slot (`NONE` when loose).
    fn stored(bvh: &Bvh, t: u32) -> ([Vec3; 3], u32) {
        let group = bvh.triangle_group(t).map_or(NONE, |g| g.index());
        (bvh.triangle(t).unwrap().v, group)
    }

    /// Applies an update to CPU copies of the buffers.
    fn apply(
        bvh: &Bvh,
        pool: &PositionPool,
        c: &ChangeSet,
        out: &PositionChanges,
        records: &mut Vec<GpuIndexedTriangle>,
        positions: &mut Vec<GpuPosition>,
    ) {
        pool.write_runs(bvh, out, positions);
        records.resize(c.triangle_capacity as usize, GpuIndexedTriangle::default());
        let ids = c.written_triangles.iter().chain(&c.removed_triangles);
        for &t in ids.chain(&out.triangles) {
            records[t as usize] = pool.record(bvh, t);
        }
    }

    fn grid(n: usize, z: f32) -> Vec<Triangle> {
        (0..n)
            .map(|i| {
                let x = i as f32;
                Triangle::new(
                    Vec3::new(x, 0.0, z),
                    Vec3::new(x + 1.0, 0.0, z),
                    Vec3::new(x, 1.0, z),
                )
            })
            .collect()
    }

    #[test]
    fn a_group_s_triangles_share_its_run_and_loose_ones_take_three() {
        let mut bvh = Bvh::new(BvhConfig::default());
        let strip = grid(50, 0.0);
        let g = bvh.insert_group(&strip, Affine3A::IDENTITY, false).unwrap();
        let loose = bvh.insert_triangles(&grid(3, 5.0)).unwrap();
        let c = bvh.take_changes();
        let mut pool = PositionPool::default();
        let out = pool.update(&bvh, &c);
        let (mut records, mut positions) = (Vec::new(), Vec::new());
        apply(&bvh, &pool, &c, &out, &mut records, &mut positions);
        // The strip's 50 triangles share 101 distinct corners; the loose ones take 9.
        let vertices = pool.positions(&bvh, PositionSource::Group(g.index())).len();
        assert_eq!(vertices, 101);
        assert_eq!(pool.live_records(), 101 + 9);
        for t in bvh
            .group_triangles(g)
            .unwrap()
            .iter()
            .chain(loose.iter().copied())
        {
            assert_eq!(gathered(&records, &positions, t), stored(&bvh, t));
        }
        // A pool laid out afresh reads the same triangles.
        let (fresh, all) = PositionPool::of(&bvh);
        let (mut fresh_records, mut fresh_positions) = (Vec::new(), Vec::new());
        let whole = ChangeSet {
            triangle_capacity: c.triangle_capacity,
            ..all_written(&bvh)
        };
        apply(
            &bvh,
            &fresh,
            &whole,
            &all,
            &mut fresh_records,
            &mut fresh_positions,
        );
        for t in bvh
            .group_triangles(g)
            .unwrap()
            .iter()
            .chain(loose.iter().copied())
        {
            let expected = stored(&bvh, t);
            assert_eq!(gathered(&fresh_records, &fresh_positions, t), expected);
        }
        bvh.remove_group(g).unwrap();
        let c = bvh.take_changes();
        let out = pool.update(&bvh, &c);
        apply(&bvh, &pool, &c, &out, &mut records, &mut positions);
        assert_eq!(pool.live_records(), 9, "the group's run is given back");
        bvh.remove_triangles(&loose).unwrap();
        let c = bvh.take_changes();
        pool.update(&bvh, &c);
        assert_eq!((pool.end(), pool.live_records()), (0, 0));
    }
}
