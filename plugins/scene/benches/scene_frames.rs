//! What `SceneBvhPlugin` costs the main thread, and how soon a spawned mesh can be traced.
//!
//! 1. Frame time: a 1M-triangle mesh (synthetic hairball, with normals and UVs) is spawned into an
//!    empty headless app; every frame until the tree holds it, the time spent in the plugin's systems
//!    ([`SceneBvhSystems`]) and the whole frame are recorded.
//! 2. Latency: into that 1M-triangle scene, 10k-triangle meshes are spawned one at a time; the
//!    spawn-to-ready latency is the time from the frame that spawned it to the moment the worker has
//!    grafted it (published as `SceneStats::last_latency`), and the wall time until a frame sees it.
//!
//! Run: `cargo bench -p treelight_scene --bench scene_frames` (release). Prints markdown tables.

#[path = "../tests/support/mod.rs"]
mod support;

use bevy::asset::RenderAssetUsages;
use bevy::mesh::{Indices, Mesh, PrimitiveTopology};
use bevy::prelude::*;
use std::time::{Duration, Instant};
use support::headless_app;
use treelight_bench::scenes::hairball;
use treelight_bvh::Triangle;
use treelight_scene::{SceneBvh, SceneBvhConfig, SceneBvhSystems};

#[derive(Resource, Default)]
struct PluginClock {
    started: Option<Instant>,
    spent: Duration,
}

fn start_clock(mut c: ResMut<PluginClock>) {
    c.started = Some(Instant::now());
}

fn stop_clock(mut c: ResMut<PluginClock>) {
    if let Some(t) = c.started.take() {
        c.spent = t.elapsed();
    }
}

fn app() -> App {
    let mut app = headless_app(SceneBvhConfig::default());
    app.init_resource::<PluginClock>().add_systems(
        PostUpdate,
        (
            start_clock.before(SceneBvhSystems),
            stop_clock.after(SceneBvhSystems),
        ),
    );
    app
}

/// A mesh as an importer would make it: indexed, with per-vertex normals and UVs.
fn mesh_of(tris: &[Triangle]) -> Mesh {
    let mut positions = Vec::with_capacity(tris.len() * 3);
    let mut normals = Vec::with_capacity(tris.len() * 3);
    let mut uvs = Vec::with_capacity(tris.len() * 3);
    for t in tris {
        let n = (t.v[1] - t.v[0])
            .cross(t.v[2] - t.v[0])
            .normalize_or(Vec3::Z);
        for (k, v) in t.v.iter().enumerate() {
            positions.push(v.to_array());
            normals.push(n.to_array());
            uvs.push([k as f32 * 0.5, (k == 2) as u32 as f32]);
        }
    }
    let indices = (0..positions.len() as u32).collect();
    Mesh::new(
        PrimitiveTopology::TriangleList,
        RenderAssetUsages::default(),
    )
    .with_inserted_attribute(Mesh::ATTRIBUTE_POSITION, positions)
    .with_inserted_attribute(Mesh::ATTRIBUTE_NORMAL, normals)
    .with_inserted_attribute(Mesh::ATTRIBUTE_UV_0, uvs)
    .with_inserted_indices(Indices::U32(indices))
}

fn triangles(app: &App) -> u32 {
    app.world().resource::<SceneBvh>().stats().triangles
}

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

fn percentile(v: &mut [f64], p: f64) -> f64 {
    v.sort_by(f64::total_cmp);
    v[((v.len() - 1) as f64 * p).round() as usize]
}

fn main() {
    // Criterion-style arguments (--bench) are accepted and ignored.
    let mut app = app();
    app.update();

    // 1. A million triangles.
    let big = hairball(1_000_000, 1);
    let handle = app
        .world_mut()
        .resource_mut::<Assets<Mesh>>()
        .add(mesh_of(&big));
    app.world_mut()
        .spawn((Mesh3d(handle), Transform::default()));
    let spawned = Instant::now();
    let mut plugin = Vec::new();
    let mut frames = Vec::new();
    let mut first: Option<Duration> = None;
    while triangles(&app) < 1_000_000 {
        if first.is_none() && triangles(&app) > 0 {
            first = Some(spawned.elapsed());
        }
        let t = Instant::now();
        app.update();
        frames.push(ms(t.elapsed()));
        plugin.push(ms(app.world().resource::<PluginClock>().spent));
        // An editor's frame rate, not a busy loop.
        std::thread::sleep(Duration::from_millis(8));
        assert!(spawned.elapsed() < Duration::from_secs(120), "never ready");
    }
    let ready = spawned.elapsed();
    let stats = app.world().resource::<SceneBvh>().stats();
    println!("## Main thread while a 1M-triangle mesh is inserted (synthetic hairball:1000000)\n");
    println!(
        "| frames until traced | first chunk traced | time to traced | plugin max | plugin p99 | plugin median | frame max | frame median | insertion |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    println!(
        "| {} | {:.0} ms | {:.0} ms | {:.2} ms | {:.2} ms | {:.3} ms | {:.1} ms | {:.2} ms | {:.2} MTris/s |",
        frames.len(),
        ms(first.unwrap_or(ready)),
        ms(ready),
        plugin.iter().cloned().fold(0.0, f64::max),
        percentile(&mut plugin.clone(), 0.99),
        percentile(&mut plugin.clone(), 0.5),
        frames.iter().cloned().fold(0.0, f64::max),
        percentile(&mut frames.clone(), 0.5),
        stats.insertion_mtris_per_s,
    );
    println!(
        "\nPer frame (ms), plugin / frame: {}\n",
        plugin
            .iter()
            .zip(&frames)
            .map(|(p, f)| format!("{p:.2}/{f:.1}"))
            .collect::<Vec<_>>()
            .join(", ")
    );

    // 2. 10k-triangle meshes into the 1M scene, each once the worker is idle again, and each
    //    immediately after the previous one (while the worker may be busy with update rounds).
    for busy in [false, true] {
        let mut worker = Vec::new();
        let mut wall = Vec::new();
        let mut frame_spent = Vec::new();
        for rep in 0..20u64 {
            if !busy {
                let t = Instant::now();
                while !app.world().resource::<SceneBvh>().is_idle()
                    || t.elapsed() < Duration::from_millis(1500)
                {
                    app.update();
                    std::thread::sleep(Duration::from_millis(8));
                }
            }
            let small = hairball(10_000, 100 + rep);
            let handle = app
                .world_mut()
                .resource_mut::<Assets<Mesh>>()
                .add(mesh_of(&small));
            let before = triangles(&app);
            app.world_mut().spawn((
                Mesh3d(handle),
                Transform::from_xyz(rep as f32 * 0.1, 0.0, 0.0),
            ));
            let t = Instant::now();
            app.update();
            frame_spent.push(ms(app.world().resource::<PluginClock>().spent));
            while triangles(&app) < before + 10_000 {
                std::thread::sleep(Duration::from_micros(200));
                app.update();
            }
            wall.push(ms(t.elapsed()));
            worker.push(ms(app.world().resource::<SceneBvh>().stats().last_latency));
        }
        println!(
            "## Spawn-to-ready of a 10k-triangle mesh into the 1M scene ({})\n",
            if busy {
                "back to back, worker possibly busy"
            } else {
                "worker idle"
            }
        );
        println!("| | median | max |\n|---|---|---|");
        println!(
            "| send to grafted (`last_latency`) | {:.2} ms | {:.2} ms |",
            percentile(&mut worker, 0.5),
            worker.iter().cloned().fold(0.0, f64::max)
        );
        println!(
            "| spawn frame to a frame that sees it | {:.2} ms | {:.2} ms |",
            percentile(&mut wall, 0.5),
            wall.iter().cloned().fold(0.0, f64::max)
        );
        println!(
            "| plugin time in the spawn frame | {:.3} ms | {:.3} ms |\n",
            percentile(&mut frame_spent, 0.5),
            frame_spent.iter().cloned().fold(0.0, f64::max)
        );
    }
}
