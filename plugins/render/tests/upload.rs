//! Buffers patched only through upload plans equal a full export, and a small edit uploads little.

use treelight_bvh::glam::{Affine3A, Vec3};
use treelight_bvh::{Bvh, GpuPosition, NONE, PositionPool, Triangle, WideRecords};
use treelight_render::{
    BufferKind, PartLayout, UploadPlan, instance_bytes, node_bytes, triangle_bytes,
};

fn grid(n: usize, offset: f32) -> Vec<Triangle> {
    (0..n)
        .map(|i| {
            let x = (i % 100) as f32 + offset;
            let z = (i / 100) as f32;
            Triangle::new(
                Vec3::new(x, 0.0, z),
                Vec3::new(x + 0.9, 0.0, z),
                Vec3::new(x, 0.5, z + 0.9),
            )
        })
        .collect()
}

/// The buffers a tree's plan writes, in the order of a plan's capacities.
const TREE_KINDS: [BufferKind; 4] = [
    BufferKind::Nodes,
    BufferKind::Triangles,
    BufferKind::Instances,
    BufferKind::Positions,
];

fn tree_kind(kind: BufferKind) -> usize {
    TREE_KINDS
        .iter()
        .position(|&k| k == kind)
        .expect("a tree's buffer")
}

#[derive(Default)]
struct FakeGpu {
    buffers: [Vec<u8>; 4],
    caps: [u64; 4],
    uploaded: u64,
    /// The node records' layout, kept by the plans as a renderer keeps it.
    records: WideRecords,
    /// The position pool, the same way.
    positions: PositionPool,
    root: u32,
}

impl FakeGpu {
    fn plan(&mut self, bvh: &mut Bvh) -> UploadPlan {
        let c = bvh.take_changes();
        UploadPlan::new(bvh, &mut self.records, &mut self.positions, &c, self.caps)
    }

    fn apply(&mut self, plan: &UploadPlan) {
        for &(kind, cap) in &plan.grow {
            let k = tree_kind(kind);
            self.caps[k] = cap;
            self.buffers[k].resize((cap * kind.record_bytes()) as usize, 0);
        }
        for w in plan.writes.iter() {
            let buf = &mut self.buffers[tree_kind(w.buffer)];
            let end = w.offset as usize + w.bytes.len();
            assert!(end <= buf.len(), "write past the buffer: grow first");
            buf[w.offset as usize..end].copy_from_slice(w.bytes);
        }
        self.uploaded += plan.upload_bytes();
        self.root = plan.root;
    }

    /// Every live record slot holds its record, the root names the layout's, and the layout
    /// holds no more records than a fresh one by a tenth.
    fn check(&self, bvh: &Bvh) {
        self.records.check(bvh).unwrap();
        assert_eq!(self.root, self.records.root(bvh));
        for s in 0..self.records.capacity() {
            if self.records.node_of(s).is_some() {
                let at = s as usize * 64;
                assert_eq!(
                    &self.buffers[0][at..at + 64],
                    node_bytes(&self.records.record(bvh, s)).as_slice(),
                    "record {s}"
                );
            }
        }
        let fresh = WideRecords::of(bvh).live();
        assert!(
            self.records.live() <= fresh + fresh / 10 + 2,
            "{} records kept, {fresh} laid out afresh",
            self.records.live()
        );
        // Each live triangle's record names, in the pool, the corners the tree stores, the first
        // with the slot of the group that owns the triangle.
        let positions: Vec<GpuPosition> = bytemuck::pod_collect_to_vec(&self.buffers[3]);
        for t in 0..bvh.triangle_capacity() {
            if bvh.is_live_triangle(t) {
                let at = t as usize * 12;
                let record = &self.buffers[1][at..at + 12];
                assert_eq!(
                    record,
                    triangle_bytes(&self.positions.record(bvh, t)).as_slice()
                );
                let corners: Vec<u32> = bytemuck::pod_collect_to_vec(record);
                let gathered: Vec<[f32; 3]> = corners
                    .iter()
                    .map(|&c| positions[c as usize].position)
                    .collect();
                let stored = bvh.triangle(t).unwrap().v.map(|v| v.to_array());
                assert_eq!(gathered, stored, "triangle {t}");
                let group = bvh.triangle_group(t).map_or(NONE, |g| g.index());
                assert_eq!(positions[corners[0] as usize].group, group, "triangle {t}");
            }
        }
        for i in 0..bvh.instance_capacity() {
            if bvh.instance(i).is_some() {
                let at = i as usize * 112;
                assert_eq!(
                    &self.buffers[2][at..at + 112],
                    instance_bytes(&self.records.instance(bvh, i)).as_slice()
                );
            }
        }
    }
}

#[test]
fn patched_buffers_equal_a_full_export_and_small_edits_upload_little() {
    let mut bvh = Bvh::default();
    let mut gpu = FakeGpu::default();
    bvh.insert_triangles_block_parallel(&grid(20_000, 0.0))
        .unwrap();
    let plan = gpu.plan(&mut bvh);
    // 20,000 runs of three positions, laid end to end: one write.
    let position_writes = |plan: &UploadPlan| {
        plan.writes
            .iter()
            .filter(|w| w.buffer == BufferKind::Positions)
            .count()
    };
    assert_eq!(position_writes(&plan), 1);
    gpu.apply(&plan);
    gpu.check(&bvh);
    let full = gpu.uploaded;
    // Records only where the traversal reads them: about half the inner nodes (one each before).
    assert!(
        gpu.records.live() * 5 <= bvh.inner_count() * 3,
        "{} records for {} inner nodes",
        gpu.records.live(),
        bvh.inner_count()
    );

    // A small mesh added incrementally: the upload is proportional to it, not to the scene.
    let before = gpu.uploaded;
    let g = bvh
        .insert_group(&grid(100, 200.0), Affine3A::IDENTITY, false)
        .unwrap();
    let plan = gpu.plan(&mut bvh);
    gpu.apply(&plan);
    gpu.check(&bvh);
    let small = gpu.uploaded - before;
    assert!(
        small < full / 20,
        "adding 100 triangles uploaded {small} bytes of a {full}-byte scene"
    );

    // Moving it as a whole: an instance and a few nodes.
    let before = gpu.uploaded;
    bvh.set_group_transform(g, Affine3A::from_translation(Vec3::new(0.0, 3.0, 0.0)))
        .unwrap();
    let plan = gpu.plan(&mut bvh);
    gpu.apply(&plan);
    bvh.set_group_transform(g, Affine3A::from_translation(Vec3::new(0.0, 4.0, 0.0)))
        .unwrap();
    let before_second = gpu.uploaded;
    let plan = gpu.plan(&mut bvh);
    assert!(
        plan.writes
            .iter()
            .all(|w| w.buffer != BufferKind::Triangles && w.buffer != BufferKind::Positions),
        "a move re-uploaded triangles"
    );
    gpu.apply(&plan);
    gpu.check(&bvh);
    assert!(
        gpu.uploaded - before_second < 4096,
        "a move uploaded {} bytes",
        gpu.uploaded - before_second
    );
    assert!(gpu.uploaded > before);

    // Baked, then swapped for a full-sweep rebuild of the same triangles (the scene worker's
    // idle refinement): the patched buffers still equal a full export.
    bvh.bake_group(g).unwrap();
    let rebuilt = {
        let (vertices, corners) = bvh.group_world_indexed(g).unwrap();
        treelight_bvh::Refinement::build(vertices, corners, bvh.group_transform(g).unwrap())
    }
    .unwrap();
    let g = bvh.swap_group(g, rebuilt).unwrap();
    let plan = gpu.plan(&mut bvh);
    gpu.apply(&plan);
    gpu.check(&bvh);

    // Removal.
    bvh.remove_group(g).unwrap();
    let plan = gpu.plan(&mut bvh);
    gpu.apply(&plan);
    gpu.check(&bvh);
}

#[test]
fn growth_takes_an_eighth_more() {
    assert_eq!(treelight_render::grown_capacity(0, 10), 1024);
    assert_eq!(treelight_render::grown_capacity(1024, 1025), 2048);
    // An eighth more than asked, in whole 1024s, not the next power of two.
    assert_eq!(treelight_render::grown_capacity(1024, 5000), 6144);
    assert_eq!(treelight_render::grown_capacity(1024, 8_000_000), 9_000_960);
    // Never less than the buffer holds already.
    assert_eq!(treelight_render::grown_capacity(16384, 5000), 16384);
}

#[test]
fn buffers_grow_by_an_eighth_up_to_what_the_adapter_binds_and_no_further() {
    let kind = BufferKind::Objects;
    let within = |max_records: u64| PartLayout {
        shift: 10,
        max_binding_bytes: max_records * kind.record_bytes(),
    };
    // Room to grow: 3000 and an eighth, in 1024s.
    assert_eq!(within(1 << 20).grown(kind, 1024, 3000, 0), Some(4096));
    // Growing would pass the limit: the buffer stops at the limit, which still holds the records.
    assert_eq!(within(3500).grown(kind, 1024, 3400, 0), Some(3500));
    assert_eq!(within(3500).grown(kind, 2048, 3500, 0), Some(3500));
    // More on its way than the limit: the limit, while what is needed fits.
    assert_eq!(within(3500).grown(kind, 1024, 2000, 9000), Some(3500));
    // More records than one binding holds, for a kind never split: no buffer at all.
    assert_eq!(within(4000).grown(kind, 1024, 5000, 0), None);
}

#[test]
fn an_update_pass_over_the_whole_tree_is_a_few_writes_joined_over_unchanged_records() {
    // Triangles in shuffled order: incremental insertion leaves the tree many moves to make.
    let mut tris = grid(20_000, 0.0);
    let mut state = 1u64;
    for i in (1..tris.len()).rev() {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        tris.swap(i, (state >> 33) as usize % (i + 1));
    }
    let mut bvh = Bvh::default();
    bvh.insert_triangles(&tris).unwrap();
    let mut gpu = FakeGpu::default();
    let plan = gpu.plan(&mut bvh);
    gpu.apply(&plan);
    gpu.check(&bvh);

    let updates = treelight_bvh::Preset::Best.policy().idle;
    assert!(
        updates.run_to_end(&mut bvh) > 0,
        "the updates moved nothing"
    );
    let c = bvh.take_changes();
    let changed = gpu.records.clone().update(&bvh, &c).ranges;
    let plan = UploadPlan::new(&bvh, &mut gpu.records, &mut gpu.positions, &c, gpu.caps);
    let node_writes = plan
        .writes
        .iter()
        .filter(|w| w.buffer == BufferKind::Nodes)
        .count();
    assert!(
        changed.len() > 200 && node_writes * 20 < changed.len(),
        "{} changed runs of node records became {node_writes} writes",
        changed.len()
    );
    // The records between the changed ones are written as they are: the buffers still equal a
    // full export.
    gpu.apply(&plan);
    gpu.check(&bvh);
}
