//! The Assets panel's built-in sample meshes, made here and kept as OBJ files in `assets/samples`
//! (a test holds the files equal to this code, and writes them again on request).

use bevy::math::Vec3;
use std::f32::consts::{PI, TAU};
use std::fmt::Write;

/// Each sample's file name and its OBJ text.
pub fn samples() -> Vec<(&'static str, String)> {
    vec![
        ("stairs.obj", obj("stairs", &stairs())),
        ("arch.obj", obj("arch", &arch())),
        ("torus_knot.obj", obj("torus_knot", &torus_knot())),
    ]
}

/// Triangles as corner positions, counter-clockwise seen from outside.
type Mesh = Vec<[Vec3; 3]>;

fn obj(name: &str, tris: &Mesh) -> String {
    // Corners that print the same are one vertex, so neighbouring faces share them.
    let mut index: std::collections::HashMap<String, usize> = std::collections::HashMap::new();
    let mut vertices = String::new();
    let mut faces = String::new();
    for t in tris {
        let ids = t.map(|v| {
            let line = format!("v {:.4} {:.4} {:.4}", v.x, v.y, v.z);
            let next = index.len() + 1;
            *index.entry(line.clone()).or_insert_with(|| {
                let _ = writeln!(vertices, "{line}");
                next
            })
        });
        let _ = writeln!(faces, "f {} {} {}", ids[0], ids[1], ids[2]);
    }
    format!(
        "# {name}: made by Treelight's src/editor/assets/samples.rs\no {name}\n{vertices}{faces}"
    )
}

/// A box from `min` to `max`, twelve triangles facing out.
fn cuboid(min: Vec3, max: Vec3) -> Mesh {
    let c = |i: u32| {
        Vec3::new(
            if i & 1 == 0 { min.x } else { max.x },
            if i & 2 == 0 { min.y } else { max.y },
            if i & 4 == 0 { min.z } else { max.z },
        )
    };
    let quads = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    quads
        .iter()
        .flat_map(|q| {
            let [a, b, c2, d] = q.map(c);
            [[a, b, c2], [a, c2, d]]
        })
        .collect()
}

/// Six steps, 1 wide, rising to 1.2.
fn stairs() -> Mesh {
    (0..6)
        .flat_map(|i| {
            let z0 = i as f32 * 0.25;
            cuboid(
                Vec3::new(-0.5, 0.0, z0 - 0.75),
                Vec3::new(0.5, 0.2 * (i + 1) as f32, z0 - 0.5),
            )
        })
        .collect()
}

/// A round arch of 17 voussoirs on two piers, 2 wide and 2 high.
fn arch() -> Mesh {
    let mut tris = cuboid(Vec3::new(-1.0, 0.0, -0.2), Vec3::new(-0.7, 1.0, 0.2));
    tris.extend(cuboid(Vec3::new(0.7, 0.0, -0.2), Vec3::new(1.0, 1.0, 0.2)));
    let (inner, outer, n) = (0.7f32, 1.0f32, 17);
    for k in 0..n {
        let (a0, a1) = (PI * k as f32 / n as f32, PI * (k + 1) as f32 / n as f32);
        let at = |r: f32, a: f32, z: f32| Vec3::new(r * a.cos(), 1.0 + r * a.sin(), z);
        let (f, b) = (0.2, -0.2);
        let quad = |p: [Vec3; 4]| [[p[0], p[1], p[2]], [p[0], p[2], p[3]]];
        for q in [
            // front, back, outside, inside
            [
                at(inner, a0, f),
                at(outer, a0, f),
                at(outer, a1, f),
                at(inner, a1, f),
            ],
            [
                at(inner, a1, b),
                at(outer, a1, b),
                at(outer, a0, b),
                at(inner, a0, b),
            ],
            [
                at(outer, a0, f),
                at(outer, a0, b),
                at(outer, a1, b),
                at(outer, a1, f),
            ],
            [
                at(inner, a1, f),
                at(inner, a1, b),
                at(inner, a0, b),
                at(inner, a0, f),
            ],
        ] {
            tris.extend(quad(q));
        }
    }
    tris
}

/// A (2, 3) torus knot: a tube of radius 0.12 along the knot, 1.6 across, standing on y = 0.
fn torus_knot() -> Mesh {
    let (segments, sides) = (120, 8);
    let curve = |t: f32| {
        let (p, q) = (2.0, 3.0);
        let r = 0.5 + 0.25 * (q * t).cos();
        Vec3::new(r * (p * t).cos(), 0.25 * (q * t).sin(), r * (p * t).sin())
    };
    let ring = |i: u32| -> Vec<Vec3> {
        let t = TAU * i as f32 / segments as f32;
        let c = curve(t);
        let tangent = (curve(t + 1e-3) - curve(t - 1e-3)).normalize();
        let normal = tangent.cross(Vec3::Y).normalize();
        let binormal = tangent.cross(normal);
        (0..sides)
            .map(|s| {
                let a = TAU * s as f32 / sides as f32;
                c + (normal * a.cos() + binormal * a.sin()) * 0.12 + Vec3::Y * 0.37
            })
            .collect()
    };
    let mut tris = Vec::new();
    for i in 0..segments {
        let (r0, r1) = (ring(i), ring((i + 1) % segments));
        for s in 0..sides as usize {
            let s1 = (s + 1) % sides as usize;
            tris.push([r0[s], r1[s1], r1[s]]);
            tris.push([r0[s], r0[s1], r1[s1]]);
        }
    }
    tris
}
