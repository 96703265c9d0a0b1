//! The engine alone: builds a tree over a scene file with each preset, moves one part of it as a
//! group (without a rebuild), and traces rays from a ring of eyes, each hit checked against brute
//! force in the traversal's own space.
//!
//! `cargo run --release -p treelight_bvh --example build_and_trace -- SCENE [RAYS]`
//! (SCENE a .gltf, .glb, .obj or .ply file; RAYS per check, default 4096).

use std::time::Instant;
use treelight_bvh::glam::{Affine3A, Vec3};
use treelight_bvh::{Bvh, Preset, Ray, Triangle};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let path = args.next().ok_or("usage: build_and_trace SCENE [RAYS]")?;
    let rays: usize = args.next().map_or(Ok(4096), |n| n.parse())?;
    let scene = treelight_import::load_scene(std::path::Path::new(&path))?;
    let triangles: Vec<Triangle> = scene
        .world_triangles()
        .into_iter()
        .map(|[a, b, c]| Triangle::new(a, b, c))
        .collect();
    println!("{path}: {} triangles", triangles.len());
    let (min, max) = bounds(&triangles).ok_or("the scene has no triangles")?;
    for preset in Preset::ALL {
        let start = Instant::now();
        let tree = preset.policy().build(&triangles)?;
        println!(
            "{preset:>8}: built in {:.1} ms, SAH cost {:.2}",
            start.elapsed().as_secs_f64() * 1e3,
            tree.sah_cost()
        );
    }
    // The last tenth of the triangles becomes an object of its own, then moves up by a tenth of
    // the scene's height: the tree takes the move as one transform, traced at once.
    let split = triangles.len() - triangles.len() / 10;
    let policy = Preset::Balanced.policy();
    let mut tree = policy.build(&triangles[..split])?;
    let part = tree.insert_group(&triangles[split..], Affine3A::IDENTITY, true)?;
    check(&tree, min, max, rays, "before the move")?;
    let start = Instant::now();
    tree.set_group_transform(
        part,
        Affine3A::from_translation(Vec3::Y * (max.y - min.y) * 0.1),
    )?;
    println!(
        "moved {} triangles in {:.3} ms",
        triangles.len() - split,
        start.elapsed().as_secs_f64() * 1e3
    );
    check(&tree, min, max, rays, "after the move")?;
    Ok(())
}

/// Traces `rays` rays from eyes on a ring around the scene towards its middle, and compares each
/// with brute force; an error names the first ray the two disagree on.
fn check(tree: &Bvh, min: Vec3, max: Vec3, rays: usize, when: &str) -> Result<(), String> {
    let (centre, radius) = ((min + max) * 0.5, (max - min).length().max(1e-3));
    let (mut hits, start) = (0, Instant::now());
    for i in 0..rays {
        let turn = i as f32 * 2.399_963; // the golden angle: eyes spread evenly round the ring
        let height = (i as f32 / rays as f32 - 0.5) * radius;
        let eye = centre + Vec3::new(turn.cos() * radius, height, turn.sin() * radius);
        let ray = Ray::new(eye, (centre - eye).normalize());
        let fast = tree.closest_hit(&ray);
        let slow = tree.brute_force_closest_hit(&ray);
        let agree = match (fast, slow) {
            (None, None) => true,
            // The same distance, and the triangle named really there (of two at one distance,
            // either is the nearest).
            (Some(f), Some(s)) => {
                f.t == s.t && tree.hit_at(&ray, f.triangle, f.instance) == Some(f.t)
            }
            _ => false,
        };
        if !agree {
            return Err(format!(
                "ray {i} {when}: traversal {fast:?}, brute force {slow:?}"
            ));
        }
        hits += usize::from(fast.is_some());
    }
    println!(
        "{when}: {hits} of {rays} rays hit, every hit as brute force finds it ({:.1} ms)",
        start.elapsed().as_secs_f64() * 1e3
    );
    Ok(())
}

/// The scene's bounds, if it has a triangle.
fn bounds(triangles: &[Triangle]) -> Option<(Vec3, Vec3)> {
    let points = triangles.iter().flat_map(|t| t.v);
    points.fold(None, |b, p| match b {
        None => Some((p, p)),
        Some((lo, hi)) => Some((lo.min(p), hi.max(p))),
    })
}
