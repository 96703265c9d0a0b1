//! A mesh added to a tree already on the GPU, uploaded as an incremental plan (growth copied on the
//! GPU, then only the changed records), traces exactly like a complete upload of the same records,
//! and meets the same triangles as a layout made afresh (or, where two are equally near, the other).

mod support;

use support::{Gpu, PinholeView, gpu_hits, hits_on, layout_bytes, pool_bytes};
use treelight_bvh::glam::{Affine3A, Quat, Vec3};
use treelight_bvh::{Bvh, BvhConfig, PositionPool, RayData, Triangle, WideRecords};
use treelight_render::{BufferKind, UploadPlan};

fn sibenik() -> Vec<Triangle> {
    let path = treelight_test_support::shared_scene("obj/sibenik.obj");
    treelight_import::load_scene(&path)
        .unwrap()
        .world_triangles()
        .into_iter()
        .map(|[a, b, c]| Triangle::new(a, b, c))
        .collect()
}

/// A closed UV sphere.
fn sphere(center: Vec3, radius: f32, rings: u32, segments: u32) -> Vec<Triangle> {
    let p = |r: u32, s: u32| {
        let theta = std::f32::consts::PI * r as f32 / rings as f32;
        let phi = std::f32::consts::TAU * s as f32 / segments as f32;
        center
            + radius
                * Vec3::new(
                    theta.sin() * phi.cos(),
                    theta.cos(),
                    theta.sin() * phi.sin(),
                )
    };
    let mut out = Vec::new();
    for r in 0..rings {
        for s in 0..segments {
            let (a, b, c, d) = (p(r, s), p(r + 1, s), p(r + 1, s + 1), p(r, s + 1));
            if r > 0 {
                out.push(Triangle::new(a, b, d));
            }
            if r + 1 < rings {
                out.push(Triangle::new(b, c, d));
            }
        }
    }
    out
}

/// GPU buffers patched the way the render plugin patches them.
struct Mirror {
    /// Nodes, triangles, instances, positions.
    buffers: [wgpu::Buffer; 4],
    capacities: [u64; 4],
    /// The node records' layout, made afresh for the first upload, then kept by the plans.
    records: WideRecords,
    /// The position pool, the same way.
    positions: PositionPool,
}

impl Mirror {
    fn upload_all(gpu: &Gpu, bvh: &Bvh) -> Self {
        let records = WideRecords::of(bvh);
        let [n, _, i, _] = layout_bytes(bvh, &records);
        let (positions, runs) = PositionPool::of(bvh);
        let [t, p] = pool_bytes(bvh, &positions, &runs);
        Self {
            capacities: [
                records.capacity() as u64,
                bvh.triangle_capacity() as u64,
                bvh.instance_capacity() as u64,
                u64::from(positions.end()),
            ],
            buffers: [
                gpu.storage("nodes", &n),
                gpu.storage("triangles", &t),
                gpu.storage("instances", &i),
                gpu.storage("positions", &p),
            ],
            records,
            positions,
        }
    }

    /// Applies a plan; returns the bytes written.
    fn apply(&mut self, gpu: &Gpu, plan: &UploadPlan) -> u64 {
        let index = |k: BufferKind| match k {
            BufferKind::Nodes => 0,
            BufferKind::Triangles => 1,
            BufferKind::Instances => 2,
            BufferKind::Positions => 3,
            other => panic!("a tree plan never writes {other:?}"),
        };
        for &(kind, records) in &plan.grow {
            let i = index(kind);
            let bigger = gpu.storage(
                "grown",
                &vec![0u8; (records * kind.record_bytes()) as usize],
            );
            let mut encoder = gpu.device.create_command_encoder(&Default::default());
            encoder.copy_buffer_to_buffer(&self.buffers[i], 0, &bigger, 0, self.buffers[i].size());
            gpu.queue.submit([encoder.finish()]);
            self.buffers[i] = bigger;
            self.capacities[i] = records;
        }
        let mut bytes = 0;
        for w in plan.writes.iter() {
            gpu.queue
                .write_buffer(&self.buffers[index(w.buffer)], w.offset, w.bytes);
            bytes += w.bytes.len() as u64;
        }
        gpu.wait();
        bytes
    }

    /// Takes the tree's changes, patches the buffers with them and traces `view` through the
    /// patched copy: the bytes written and the triangle hit at each pixel.
    fn follow(&mut self, gpu: &Gpu, bvh: &mut Bvh, view: &PinholeView) -> (u64, Vec<u32>) {
        let changes = bvh.take_changes();
        let plan = UploadPlan::new(
            bvh,
            &mut self.records,
            &mut self.positions,
            &changes,
            self.capacities,
        );
        let written = self.apply(gpu, &plan);
        let [n, t, i, p] = &self.buffers;
        (written, hits_on(gpu, [n, t, i, p], plan.root, view))
    }

    /// `patched`, the hits through the patched buffers, equals the hits through a complete upload
    /// of the same records, exactly; and against a complete upload of a layout made afresh (whose
    /// records group the nodes otherwise, so equally near triangles may be met in another order)
    /// each pixel meets the same triangle or one at the same distance along its ray.
    fn assert_traces_like_fresh(&self, gpu: &Gpu, bvh: &Bvh, view: &PinholeView, patched: &[u32]) {
        let [nodes, triangles, instances, positions] = layout_bytes(bvh, &self.records);
        let complete = [
            gpu.storage("nodes", &nodes),
            gpu.storage("triangles", &triangles),
            gpu.storage("instances", &instances),
            gpu.storage("positions", &positions),
        ];
        let [n, t, i, p] = &complete;
        let same = hits_on(gpu, [n, t, i, p], self.records.root(bvh), view);
        let differ = patched.iter().zip(&same).filter(|(a, b)| a != b).count();
        assert_eq!(
            differ, 0,
            "{differ} pixels differ from a complete upload of the same records"
        );
        let fresh = gpu_hits(bvh, view);
        for (k, (&a, &b)) in patched
            .iter()
            .zip(&fresh)
            .enumerate()
            .filter(|(_, (a, b))| a != b)
        {
            let (x, y) = (k as u32 % view.width, k as u32 / view.width);
            let ray = view.ray(x, y);
            let t = |id: u32| {
                bvh.world_triangle(id)
                    .and_then(|tri| RayData::new(&ray).hit_triangle(&tri, 0.0, f32::INFINITY))
                    .map(|(t, _, _)| t)
            };
            let (ta, tb) = (t(a), t(b));
            assert!(
                ta.zip(tb)
                    .is_some_and(|(ta, tb)| (ta - tb).abs() <= 1e-4 * ta.max(1.0)),
                "pixel ({x}, {y}): triangle {a} at {ta:?} through the patched copy, {b} at {tb:?} \
                 through a fresh layout"
            );
        }
    }
}

#[test]
fn incremental_upload_traces_like_a_full_one() {
    let gpu = Gpu::new();
    let mut bvh = Bvh::new(BvhConfig::incr_u());
    bvh.insert_triangles(&sibenik()).unwrap();
    bvh.take_changes();
    let mut mirror = Mirror::upload_all(&gpu, &bvh);
    let full_bytes: u64 = mirror.buffers.iter().map(|b| b.size()).sum();

    let b = bvh.bounds();
    let c = b.center();
    let eye = c + Vec3::new(-(b.max.x - b.min.x) * 0.35, -0.2 * (b.max.y - b.min.y), 0.0);
    let view = PinholeView::looking_at(eye, c, 96, 96);

    // A baked mesh in front of the camera, and one kept whole under a transform.
    let ball = sphere(eye.lerp(c, 0.4), 1.5, 24, 48);
    let baked = bvh.insert_group(&ball, Affine3A::IDENTITY, false).unwrap();
    let whole = bvh
        .insert_group(&sphere(Vec3::ZERO, 1.0, 12, 24), Affine3A::IDENTITY, true)
        .unwrap();
    bvh.set_group_transform(
        whole,
        Affine3A::from_rotation_translation(Quat::from_rotation_x(0.3), eye.lerp(c, 0.6) + Vec3::Y),
    )
    .unwrap();
    let (written, patched) = mirror.follow(&gpu, &mut bvh, &view);
    mirror.assert_traces_like_fresh(&gpu, &bvh, &view, &patched);

    let new_ids: Vec<u32> = bvh
        .group_triangles(baked)
        .unwrap()
        .iter()
        .chain(bvh.group_triangles(whole).unwrap())
        .collect();
    let on_new = patched.iter().filter(|id| new_ids.contains(id)).count();
    assert!(on_new > 200, "the new meshes cover only {on_new} pixels");
    // Proportional to the change: the new triangles, their nodes and the refitted paths.
    assert!(
        written * 10 < full_bytes,
        "{written} bytes uploaded for a change to a {full_bytes}-byte scene"
    );

    // The baked mesh swapped for a full-sweep rebuild of itself (the scene worker's idle
    // refinement): the patched copy still traces like a fresh one.
    let rebuilt = {
        let (vertices, corners) = bvh.group_world_indexed(baked).unwrap();
        treelight_bvh::Refinement::build(vertices, corners, bvh.group_transform(baked).unwrap())
    }
    .unwrap();
    bvh.swap_group(baked, rebuilt).unwrap();
    let (_, patched) = mirror.follow(&gpu, &mut bvh, &view);
    mirror.assert_traces_like_fresh(&gpu, &bvh, &view, &patched);
}

/// Writes staged through the upload belt land whole: larger than its buffers (copied in pieces),
/// over frames that reuse its buffers, after it lets them go once the stream has ended, and in a
/// frame larger than a round (handed to the GPU mid-frame, the rest after it).
#[test]
fn staged_writes_land_whole_across_pieces_reuse_release_and_rounds() {
    use treelight_render::{CHUNK_BYTES, ROUND_BYTES, UploadBelt};
    let gpu = Gpu::new();
    let size = ROUND_BYTES + 3 * CHUNK_BYTES;
    let target = gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("target"),
        size,
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let mut expected = vec![0u8; size as usize];
    let mut belt = UploadBelt::new(&gpu.device);
    let pattern = |seed: u32, len: u64| -> Vec<u8> {
        (0..len as u32)
            .map(|i| (i.wrapping_mul(2_654_435_761) ^ seed).to_le_bytes()[1])
            .collect()
    };
    // Each frame's writes as (offset, length); below, whether new geometry still streams in.
    let frames: [&[(u64, u64)]; 7] = [
        &[(4, CHUNK_BYTES + 400), (3 * CHUNK_BYTES, 4096)],
        &[(CHUNK_BYTES + 8, CHUNK_BYTES + 12)],
        &[(100, 4096)],
        &[(CHUNK_BYTES / 2, 2048)],
        &[(4 * CHUNK_BYTES, 1024), (64, 64)],
        &[(2 * CHUNK_BYTES - 4, CHUNK_BYTES + 20)],
        &[(12, 4096), (CHUNK_BYTES, ROUND_BYTES + 8), (40, 400)],
    ];
    let streaming = [true, true, true, false, false, true, true];
    // Every frame but the last stages less than a round.
    for writes in &frames[..6] {
        assert!(writes.iter().map(|w| w.1).sum::<u64>() < ROUND_BYTES);
    }
    for (k, (writes, &stream)) in frames.iter().zip(&streaming).enumerate() {
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        for &(offset, len) in writes.iter() {
            let bytes = pattern(k as u32 * 7919 + offset as u32, len);
            assert!(belt.write(&mut encoder, &gpu.queue, &target, offset, &bytes));
            expected[offset as usize..(offset + len) as usize].copy_from_slice(&bytes);
        }
        // Not whole words: left out, and said so.
        assert!(!belt.write(&mut encoder, &gpu.queue, &target, 2, &[1, 2, 3, 4]));
        assert!(!belt.write(&mut encoder, &gpu.queue, &target, 8, &[1, 2, 3]));
        belt.finish();
        gpu.queue.submit([encoder.finish()]);
        belt.recall(stream);
        gpu.wait();
        // The fourth frame is the first quiet one, after frames of several buffers, once
        // nothing streams in.
        assert_eq!(belt.releases(), u64::from(k >= 3), "frame {k}");
        // Only the last frame stages more than a round.
        assert_eq!(belt.rounds(), u64::from(k == 6), "frame {k}");
    }
    assert!(
        gpu.read(&target) == expected,
        "the target differs from the writes"
    );
}
