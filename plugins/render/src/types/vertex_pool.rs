//! Runs of the shading vertices' pool: each mesh's vertices take one run of records
//! ([`RunAllocator`]), given back when no group shows the mesh any more.

use crate::types::shading::{
    GpuAttribute, MAX_SHADING_VERTEX_RECORDS, VertexLayout, shading_record, vertex_records,
};
use crate::types::upload::{BufferKind, Writes};
use std::collections::HashMap;
use std::sync::Arc;
use treelight_bvh::RunAllocator;
use treelight_scene::{MeshShading, ShadingVertices};

/// The pool's runs by mesh: each set of vertex arrays (shared by a mesh's chunks and by the groups
/// that show one mesh) under each layout it is shown with. A run lives while some group names it
/// in a pass over the live groups ([`ShadingPool::begin_pass`], [`ShadingPool::group`] for each,
/// [`ShadingPool::end_pass`]); the runs made in a pass are written by
/// [`ShadingPool::write_new_vertices`], and each triangle's record names its group's run
/// ([`ShadingPool::record`]).
pub struct ShadingPool {
    /// Never past the records a shading record's corner can name.
    runs: RunAllocator,
    /// By the arrays' address and the layout. The run holds the arrays, so the address is not
    /// reused while it lives.
    meshes: HashMap<(usize, VertexLayout), MeshRun>,
    pass: u64,
    /// By group slot: the run its shading records name (its first record and layout) as last
    /// decided; `None` for a group without shading.
    by_slot: Vec<Option<(u32, VertexLayout)>>,
    /// Runs made this pass, whose vertices are still to be written.
    fresh: Vec<(u32, VertexLayout, Arc<ShadingVertices>)>,
}

impl Default for ShadingPool {
    fn default() -> Self {
        Self {
            runs: RunAllocator::with_limit(MAX_SHADING_VERTEX_RECORDS),
            meshes: HashMap::new(),
            pass: 0,
            by_slot: Vec::new(),
            fresh: Vec::new(),
        }
    }
}

/// One mesh's run.
struct MeshRun {
    _vertices: Arc<ShadingVertices>,
    first: u32,
    len: u32,
    /// The last pass that named it.
    seen: u64,
}

impl ShadingPool {
    /// Starts a pass over the live groups, whose slots are below `slots`.
    pub fn begin_pass(&mut self, slots: u32) {
        self.pass += 1;
        self.by_slot.resize(slots as usize, None);
    }

    /// Group `slot` is live with `shading` (`None`: it has none), its material reading the
    /// second UV set or not. Returns whether its triangles' records must be written again (its
    /// vertices took a run anew, or another layout), beside any reason the caller has.
    pub fn group(
        &mut self,
        slot: u32,
        shading: Option<&MeshShading>,
        second_set_read: bool,
    ) -> bool {
        let run = shading.and_then(|s| {
            let vertices = s.shared_vertices();
            let layout = VertexLayout::of(vertices, second_set_read);
            Some((self.run_of(vertices, layout)?, layout))
        });
        if self.by_slot.len() <= slot as usize {
            self.by_slot.resize(slot as usize + 1, None);
        }
        std::mem::replace(&mut self.by_slot[slot as usize], run) != run
    }

    /// The first record of `vertices`' run under `layout`, made (and queued to be written) when
    /// there is none; `None` when the run would reach past the records a shading record's corner
    /// can name ([`MAX_SHADING_VERTEX_RECORDS`]: 2^31, 32 GiB of vertices): the group then shades
    /// flat.
    fn run_of(&mut self, vertices: &Arc<ShadingVertices>, layout: VertexLayout) -> Option<u32> {
        let key = (Arc::as_ptr(vertices) as usize, layout);
        if let Some(run) = self.meshes.get_mut(&key) {
            run.seen = self.pass;
            return Some(run.first);
        }
        let len = u32::try_from(vertices.len() as u64 * u64::from(layout.stride())).ok()?;
        let first = self.runs.allocate(len)?;
        self.meshes.insert(
            key,
            MeshRun {
                _vertices: Arc::clone(vertices),
                first,
                len,
                seen: self.pass,
            },
        );
        self.fresh.push((first, layout, Arc::clone(vertices)));
        Some(first)
    }

    /// Ends the pass: the runs no group named are given back.
    pub fn end_pass(&mut self) {
        let (pass, runs) = (self.pass, &mut self.runs);
        self.meshes.retain(|_, run| {
            let live = run.seen == pass;
            if !live {
                runs.free(run.first, run.len);
            }
            live
        });
    }

    /// Writes the vertices of the runs made since the last call, a round at a time.
    pub fn write_new_vertices(
        &mut self,
        writes: &mut Writes,
        round: u64,
        flush: &mut dyn FnMut(&mut Writes),
    ) {
        for (first, layout, vertices) in self.fresh.drain(..) {
            let stride = layout.stride() as usize;
            let count = (vertices.len() * stride) as u32;
            writes.push_records_in_rounds(
                BufferKind::ShadingVertices,
                std::iter::once(first..first + count),
                |j, _| vertex_records(&vertices, j / stride)[j % stride],
                round,
                flush,
            );
        }
    }

    /// The shading record of triangle `k` of the group in `slot` with `shading`, naming the
    /// group's run (the record does not name the group: its first corner's position does).
    /// Corners past its vertices name none (never another mesh's).
    pub fn record(&self, slot: u32, shading: Option<&MeshShading>, k: usize) -> GpuAttribute {
        let (Some(shading), Some(Some((first, layout)))) =
            (shading, self.by_slot.get(slot as usize).copied())
        else {
            return shading_record(0, None, VertexLayout::default());
        };
        let vertices = shading.vertices().len() as u32;
        let corners = shading
            .corners(k)
            .filter(|c| c.iter().all(|&i| i < vertices));
        shading_record(first, corners, layout)
    }

    /// Records the runs reach: what the pool's buffer must hold.
    pub fn end(&self) -> u32 {
        self.runs.end()
    }

    /// Records in live runs.
    pub fn live_records(&self) -> u64 {
        u64::from(self.runs.end()) - self.runs.free_records()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::types::shading::{ATTRIBUTE_BYTES, GpuShadingVertex, SHADING_VERTEX_BYTES};

    /// Pseudo-random numbers below the bound each call gives, from `seed` (a 64-bit LCG).
    fn numbers(mut seed: u64) -> impl FnMut(u64) -> u64 {
        move |n| {
            seed = seed
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (seed >> 33) % n
        }
    }

    /// A mesh of `n` vertices with the attributes `kinds` says (bits: normals, UVs, a second
    /// set, tangents), each entry naming its mesh and vertex, and `t` random triangles.
    fn mesh(id: u32, n: u32, kinds: u32, t: u32, next: &mut impl FnMut(u32) -> u32) -> MeshShading {
        let has = |bit: u32| kinds & (1 << bit) != 0;
        let tag = |v: u32| (id << 16) | v;
        let v = ShadingVertices {
            normals: if has(0) {
                (0..n).map(tag).collect()
            } else {
                Vec::new()
            },
            uvs: if has(1) {
                (0..n)
                    .map(|v| bevy::math::Vec2::new(id as f32, v as f32))
                    .collect()
            } else {
                Vec::new()
            },
            uvs1: if has(2) {
                (0..n)
                    .map(|v| bevy::math::Vec2::new(-(v as f32), id as f32))
                    .collect()
            } else {
                Vec::new()
            },
            tangents: if has(3) {
                (0..n).map(|v| tag(v) | (1 << 31)).collect()
            } else {
                Vec::new()
            },
        };
        let corners: Vec<[u32; 3]> = (0..t).map(|_| [next(n), next(n), next(n)]).collect();
        MeshShading::new(v, &corners)
    }

    /// Applies `writes` to CPU copies of the two shading buffers.
    fn apply(writes: &Writes, attrs: &mut Vec<u8>, vertices: &mut Vec<u8>) {
        for w in writes.iter() {
            let target = match w.buffer {
                BufferKind::Attributes => &mut *attrs,
                BufferKind::ShadingVertices => &mut *vertices,
                other => panic!("a write to {other:?}"),
            };
            let end = w.offset as usize + w.bytes.len();
            if target.len() < end {
                target.resize(end, 0);
            }
            target[w.offset as usize..end].copy_from_slice(w.bytes);
        }
    }

    #[test]
    fn every_live_triangle_reads_its_own_mesh_s_shading_through_random_edits() {
        let mut random = numbers(0x9e37_79b9);
        let mut next = |n: u32| random(u64::from(n.max(1))) as u32;
        // Meshes, some shown by several groups and some cut into chunks sharing their vertices.
        let mut meshes: Vec<Arc<MeshShading>> = Vec::new();
        for id in 0..12 {
            let (n, kinds, t) = (1 + next(60), next(16), 1 + next(40));
            let m = mesh(id, n, kinds, t, &mut next);
            if id % 4 == 3 {
                let half: Vec<u32> = (0..t / 2).collect();
                let rest: Vec<u32> = (t / 2..t).collect();
                meshes.push(Arc::new(m.subset(&half)));
                meshes.push(Arc::new(m.subset(&rest)));
            }
            meshes.push(Arc::new(m));
        }
        // Live groups by slot: (mesh, reads the second set, triangle ids).
        let mut groups: Vec<Option<(usize, bool, Vec<u32>)>> = Vec::new();
        let mut next_id = 0u32;
        let mut pool = ShadingPool::default();
        let (mut attrs, mut vertices) = (Vec::new(), Vec::new());
        for frame in 0..300 {
            let mut fresh: Vec<u32> = Vec::new();
            for _ in 0..1 + next(3) {
                match next(4) {
                    0 | 1 => {
                        let m = next(meshes.len() as u32) as usize;
                        let ids: Vec<u32> = (next_id..next_id + meshes[m].len() as u32).collect();
                        next_id += ids.len() as u32;
                        let slot = groups
                            .iter()
                            .position(Option::is_none)
                            .unwrap_or(groups.len());
                        if slot == groups.len() {
                            groups.push(None);
                        }
                        groups[slot] = Some((m, next(2) == 0, ids));
                        fresh.push(slot as u32);
                    }
                    2 => {
                        let slot = next(groups.len() as u32) as usize;
                        if let Some(g) = groups.get_mut(slot) {
                            *g = None;
                        }
                    }
                    _ => {
                        let slot = next(groups.len() as u32) as usize;
                        if let Some(Some(g)) = groups.get_mut(slot) {
                            g.1 = !g.1;
                        }
                    }
                }
            }
            // A pass, as the extraction makes it, its writes applied to the CPU copies.
            pool.begin_pass(groups.len() as u32);
            let mut relay = fresh;
            for (slot, g) in groups.iter().enumerate() {
                if let Some((m, second, _)) = g
                    && pool.group(slot as u32, Some(&meshes[*m]), *second)
                {
                    relay.push(slot as u32);
                }
            }
            pool.end_pass();
            let mut writes = Writes::default();
            let mut flush = |w: &mut Writes| {
                apply(w, &mut attrs, &mut vertices);
                w.clear();
            };
            pool.write_new_vertices(&mut writes, 512, &mut flush);
            for slot in relay {
                // A group added and removed within the frame has no records.
                let Some((m, _, ids)) = groups[slot as usize].as_ref() else {
                    continue;
                };
                for (k, &id) in ids.iter().enumerate() {
                    let r = pool.record(slot, Some(&meshes[*m]), k);
                    writes.push(
                        BufferKind::Attributes,
                        u64::from(id) * ATTRIBUTE_BYTES,
                        bytemuck::bytes_of(&r),
                    );
                }
            }
            apply(&writes, &mut attrs, &mut vertices);
            assert!(u64::from(pool.end()) * SHADING_VERTEX_BYTES <= vertices.len() as u64);
            // Every live triangle, read as the kernel reads it.
            let records: Vec<GpuAttribute> = bytemuck::pod_collect_to_vec(&attrs);
            let pooled: Vec<GpuShadingVertex> = bytemuck::pod_collect_to_vec(&vertices);
            for (slot, g) in groups.iter().enumerate() {
                let Some((m, second, ids)) = g else { continue };
                let s = &meshes[*m];
                for (k, &id) in ids.iter().enumerate() {
                    let r = records[id as usize];
                    if !r.names_vertices() {
                        assert!(
                            s.vertices().is_empty(),
                            "frame {frame}: {slot} lost its vertices"
                        );
                        continue;
                    }
                    let two = r.has_two_uv_sets();
                    assert_eq!(two, *second && s.has_second_uv_set(), "frame {frame}");
                    assert_eq!(r.has_normals(), !s.vertices().normals.is_empty());
                    let corners = r.vertex_records();
                    let at = |c: usize, second: u32| pooled[(corners[c] + second) as usize];
                    for c in 0..3 {
                        let v = at(c, 0);
                        assert_eq!(Some(v.normal), s.normals(k).map(|n| n[c]).or(Some(0)));
                        assert_eq!(
                            Some(v.tangent),
                            s.vertex_tangents(k).map(|t| t[c]).or(Some(0))
                        );
                        let uv = bevy::math::Vec2::from_array(v.uv);
                        assert_eq!(uv, s.uvs(k).map_or(bevy::math::Vec2::ZERO, |u| u[c]));
                        if two {
                            let uv1 = bevy::math::Vec2::from_array(at(c, 1).uv);
                            assert_eq!(Some(uv1), s.uvs1(k).map(|u| u[c]), "frame {frame}");
                        }
                    }
                }
            }
        }
        // Everything given back at the end is the pool's whole length.
        groups.clear();
        pool.begin_pass(0);
        pool.end_pass();
        assert_eq!((pool.end(), pool.live_records()), (0, 0));
    }

    #[test]
    fn a_run_past_what_a_corner_can_name_is_refused_and_its_group_shades_flat() {
        let mut next = {
            let mut random = numbers(7);
            move |n: u32| random(u64::from(n.max(1))) as u32
        };
        let mut pool = ShadingPool::default();
        // Records up to two short of the corners' reach are taken (the allocator keeps ranges,
        // not memory).
        pool.runs.allocate(MAX_SHADING_VERTEX_RECORDS - 2).unwrap();
        let four = mesh(1, 4, 0b11, 3, &mut next);
        let two = mesh(2, 2, 0b11, 3, &mut next);
        pool.begin_pass(2);
        pool.group(0, Some(&four), false);
        pool.group(1, Some(&two), false);
        pool.end_pass();
        // Four vertices would reach past 2^31: refused, the group's records name no vertices.
        for k in 0..3 {
            assert!(!pool.record(0, Some(&four), k).names_vertices());
        }
        // Two end exactly at the reach: taken, named without touching the flag bits.
        let r = pool.record(1, Some(&two), 0);
        assert!(r.names_vertices() && r.has_normals());
        for c in r.vertex_records() {
            assert!((MAX_SHADING_VERTEX_RECORDS - 2..MAX_SHADING_VERTEX_RECORDS).contains(&c));
        }
    }
}
