//! Scene sources: files (OBJ, PLY, glTF/GLB) and deterministic generators, labelled synthetic.

use crate::rng::Rng;
use std::ops::Range;
use std::path::Path;
use treelight_bvh::Triangle;
use treelight_bvh::glam::{Quat, Vec3};

/// A loaded scene.
pub struct Scene {
    /// Name as given on the command line (generated ones say "synthetic").
    pub name: String,
    /// Triangles in file order.
    pub triangles: Vec<Triangle>,
    /// The scene's meshes, as spans of `triangles` in order: a file's meshes, a hairball's tubes,
    /// a scatter's copies. The editor inserts each as a group of its own.
    pub meshes: Vec<Range<usize>>,
}

impl Scene {
    /// A scene whose meshes are the spans between consecutive `starts` (each a triangle index).
    fn new(name: String, triangles: Vec<Triangle>, starts: &[usize]) -> Self {
        let n = triangles.len();
        let mut bounds: Vec<usize> = starts.iter().copied().filter(|&s| s < n).collect();
        bounds.dedup();
        bounds.push(n);
        let meshes = bounds.windows(2).map(|w| w[0]..w[1]).collect();
        Self {
            name,
            triangles,
            meshes,
        }
    }
}

/// Parses a `--scene` argument: a file path, `hairball:N`, `scatter:N:FILE` or `subdivide:K:FILE`.
pub fn load(spec: &str, seed: u64) -> Result<Scene, String> {
    let parts: Vec<&str> = spec.splitn(3, ':').collect();
    match parts.as_slice() {
        ["hairball", n] => {
            let n: usize = n
                .parse()
                .map_err(|_| format!("{spec}: N must be a number"))?;
            let (triangles, starts) = hairball_tubes(n, seed);
            Ok(Scene::new(
                format!("hairball:{n} (synthetic)"),
                triangles,
                &starts,
            ))
        }
        ["scatter", n, file] => {
            let n: usize = n
                .parse()
                .map_err(|_| format!("{spec}: N must be a number"))?;
            let (base, _) = load_file(Path::new(file))?;
            let triangles = scatter(&base, n, seed);
            let starts: Vec<usize> = (0..triangles.len()).step_by(base.len().max(1)).collect();
            Ok(Scene::new(
                format!("scatter:{n}:{file} (synthetic)"),
                triangles,
                &starts,
            ))
        }
        ["subdivide", k, file] => {
            let k: u32 = k
                .parse()
                .map_err(|_| format!("{spec}: K must be a number"))?;
            if k > 8 {
                return Err(format!(
                    "{spec}: K above 8 gives more than 65536 triangles per input triangle"
                ));
            }
            let (mut tris, starts) = load_file(Path::new(file))?;
            for _ in 0..k {
                tris = subdivide(&tris);
            }
            // Subdivision keeps the order, four triangles for each.
            let starts: Vec<usize> = starts.iter().map(|s| s << (2 * k)).collect();
            Ok(Scene::new(
                format!("subdivide:{k}:{file} (synthetic)"),
                tris,
                &starts,
            ))
        }
        _ => {
            let (triangles, starts) = load_file(Path::new(spec))?;
            Ok(Scene::new(spec.to_owned(), triangles, &starts))
        }
    }
}

/// A file's triangles in world space, mesh by mesh, and where each mesh starts.
fn load_file(path: &Path) -> Result<(Vec<Triangle>, Vec<usize>), String> {
    let scene = treelight_import::load_scene(path).map_err(|e| e.to_string())?;
    let mut triangles = Vec::with_capacity(scene.triangle_count());
    let mut starts = Vec::with_capacity(scene.meshes.len());
    for mesh in &scene.meshes {
        starts.push(triangles.len());
        triangles.extend(
            mesh.world_triangles()
                .map(|[a, b, c]| Triangle::new(a, b, c)),
        );
    }
    Ok((triangles, starts))
}

/// Random-walk tubes inside the unit sphere, like the paper's Hairball: each step adds a three-sided
/// tube segment (six triangles).
pub fn hairball(n: usize, seed: u64) -> Vec<Triangle> {
    hairball_tubes(n, seed).0
}

/// [`hairball`], and where each tube starts.
fn hairball_tubes(n: usize, seed: u64) -> (Vec<Triangle>, Vec<usize>) {
    let mut r = Rng::new(seed);
    let mut out = Vec::with_capacity(n + 6);
    let mut starts = Vec::new();
    let radius = 0.0025;
    while out.len() < n {
        starts.push(out.len());
        let mut p = r.in_unit_sphere() * 0.9;
        let mut d = r.unit_vector();
        for _ in 0..200 {
            if out.len() >= n {
                break;
            }
            d = (d + r.unit_vector() * 0.35).normalize();
            let mut q = p + d * 0.02;
            if q.length() > 1.0 {
                d = -d;
                q = p + d * 0.02;
            }
            let side = d.any_orthonormal_vector();
            let up = d.cross(side);
            let ring = |c: Vec3| -> [Vec3; 3] {
                [0.0f32, 2.094, 4.189].map(|a| c + (side * a.cos() + up * a.sin()) * radius)
            };
            let (a, b) = (ring(p), ring(q));
            for k in 0..3 {
                let j = (k + 1) % 3;
                out.push(Triangle::new(a[k], b[k], b[j]));
                out.push(Triangle::new(a[k], b[j], a[j]));
            }
            p = q;
        }
    }
    out.truncate(n);
    (out, starts)
}

/// Copies of `base` with random rotations, scales over three orders of magnitude and positions, until
/// about `n` triangles.
pub fn scatter(base: &[Triangle], n: usize, seed: u64) -> Vec<Triangle> {
    if base.is_empty() {
        return Vec::new();
    }
    let mut r = Rng::new(seed);
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for t in base {
        for v in t.v {
            lo = lo.min(v);
            hi = hi.max(v);
        }
    }
    let center = (lo + hi) * 0.5;
    let size = (hi - lo).max_element().max(1e-6);
    let copies = n.div_ceil(base.len());
    let world = (copies as f32).cbrt() * 4.0;
    let mut out = Vec::with_capacity(copies * base.len());
    for _ in 0..copies {
        let scale = 10f32.powf(r.range(-1.5, 1.5)) / size;
        let rot = Quat::from_axis_angle(r.unit_vector(), r.range(0.0, std::f32::consts::TAU));
        let pos = Vec3::new(
            r.range(-world, world),
            r.range(-world, world),
            r.range(-world, world),
        );
        for t in base {
            out.push(Triangle {
                v: t.v.map(|v| pos + rot * ((v - center) * scale)),
            });
        }
    }
    out.truncate(n.max(base.len()));
    out
}

/// Every triangle split into four at its edge midpoints.
pub fn subdivide(tris: &[Triangle]) -> Vec<Triangle> {
    let mut out = Vec::with_capacity(tris.len() * 4);
    for t in tris {
        let [a, b, c] = t.v;
        let (ab, bc, ca) = ((a + b) * 0.5, (b + c) * 0.5, (c + a) * 0.5);
        out.extend([
            Triangle::new(a, ab, ca),
            Triangle::new(ab, b, bc),
            Triangle::new(ca, bc, c),
            Triangle::new(ab, bc, ca),
        ]);
    }
    out
}
