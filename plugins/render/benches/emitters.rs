//! Criterion benches of the emissive-triangle list ([`EmitterList`]) that next-event estimation
//! draws from, at 100,000 and 1,000,000 emitters in 1,000 groups: a pass over the scene's groups
//! when none changed (what every extract with a change elsewhere in the scene pays), and a pass in
//! which one group moved, with the writes it leaves for the GPU (its triangles placed again in
//! their range, and the groups' table). The bytes a first upload and a move write are printed.
//!
//! Run: `cargo bench --workspace --profile dev --bench emitters` (the dev profile is optimised,
//! and shares the workspace's build).

use bevy::math::{Affine3A, Vec3};
use criterion::{Criterion, criterion_group, criterion_main};
use std::hint::black_box;
use treelight_render::EmitterList;

const GROUPS: u32 = 1000;

/// Group `g`'s triangles in object space: a strip of `n` triangles, ids numbered on from the last
/// group's.
fn strip(g: u32, n: u32) -> Vec<(u32, [Vec3; 3])> {
    (0..n)
        .map(|k| {
            let x = k as f32 * 0.1;
            let corners = [
                Vec3::new(x, 0.0, 0.0),
                Vec3::new(x + 0.1, 0.0, 0.0),
                Vec3::new(x, 0.1, (k % 3) as f32 * 0.01),
            ];
            (g * n + k, corners)
        })
        .collect()
}

fn placed(triangles: &[(u32, [Vec3; 3])], t: Affine3A) -> Vec<(u32, [Vec3; 3])> {
    triangles
        .iter()
        .map(|&(id, c)| (id, c.map(|p| t.transform_point3(p))))
        .collect()
}

fn home(g: u32) -> Affine3A {
    Affine3A::from_translation(Vec3::new(
        (g % 40) as f32 * 12.0,
        (g / 40) as f32 * 2.0,
        0.0,
    ))
}

/// One pass over every group, group 0 at `first` (the others at home), none re-laid.
fn pass(list: &mut EmitterList, groups: &[Vec<(u32, [Vec3; 3])>], first: Affine3A) -> bool {
    list.begin_pass();
    for (g, triangles) in groups.iter().enumerate() {
        let t = if g == 0 { first } else { home(g as u32) };
        list.group(g as u32, t, Vec3::splat(5.0), false, || {
            placed(triangles, t)
        });
    }
    list.end_pass()
}

fn emitters(c: &mut Criterion) {
    for per_group in [100u32, 1000] {
        let groups: Vec<_> = (0..GROUPS).map(|g| strip(g, per_group)).collect();
        let mut list = EmitterList::default();
        assert!(pass(&mut list, &groups, home(0)));
        let count = list.count();
        assert_eq!(count, GROUPS * per_group, "every triangle listed");
        let first: usize = list.take_writes(false).iter().map(|w| w.1.len()).sum();
        assert!(pass(
            &mut list,
            &groups,
            Affine3A::from_translation(Vec3::Y)
        ));
        let moved: usize = list.take_writes(false).iter().map(|w| w.1.len()).sum();
        assert!(pass(&mut list, &groups, home(0)));
        list.take_writes(false);
        println!(
            "{count} emitters in {GROUPS} groups: the first upload writes {:.1} MiB of records, a \
             group's move {:.1} KiB",
            first as f64 / (1 << 20) as f64,
            moved as f64 / 1024.0
        );
        let name = format!("{count} emitters");
        c.bench_function(&format!("{name}: a pass with nothing changed"), |b| {
            b.iter(|| assert!(!pass(&mut list, black_box(&groups), home(0))))
        });
        let moves = [
            home(0),
            Affine3A::from_translation(Vec3::new(0.0, -5.0, 3.0)),
        ];
        let mut k = 0;
        c.bench_function(&format!("{name}: a pass with one group moved"), |b| {
            b.iter(|| {
                k += 1;
                assert!(pass(&mut list, black_box(&groups), moves[k % 2]));
                black_box(list.take_writes(false));
            })
        });
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(10);
    targets = emitters
}
criterion_main!(benches);
