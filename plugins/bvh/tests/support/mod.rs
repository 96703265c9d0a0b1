//! Shared helpers for the engine's integration tests: scenes, rays, brute-force checks.
#![allow(dead_code)]

use treelight_bvh::glam::Vec3;
use treelight_bvh::{Bvh, Ray, Triangle};

/// Small deterministic PRNG (xorshift64*), so tests need no extra crates and repeat exactly.
pub struct Rng(pub u64);
impl Rng {
    pub fn next_u64(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    pub fn f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32
    }
    pub fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.f32()
    }
    pub fn vec3(&mut self, lo: f32, hi: f32) -> Vec3 {
        Vec3::new(self.range(lo, hi), self.range(lo, hi), self.range(lo, hi))
    }
}

/// Random small triangles scattered in a cube, with some shared edges and some big ones.
pub fn soup(n: usize, seed: u64) -> Vec<Triangle> {
    let mut r = Rng(seed | 1);
    (0..n)
        .map(|_| {
            let c = r.vec3(-10.0, 10.0);
            let s = if r.f32() < 0.1 { 5.0 } else { 0.6 };
            Triangle::new(c + r.vec3(-s, s), c + r.vec3(-s, s), c + r.vec3(-s, s))
        })
        .collect()
}

/// A random mesh of `n` triangles as a mesh keeps them: a strip over a random walk of vertices
/// (each triangle shares two corners with the next), with some vertices split in two at the same
/// position, as a mesh splits them where its normals or UVs part.
pub fn indexed_mesh(n: usize, seed: u64) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let mut r = Rng(seed | 1);
    let mut p = r.vec3(-10.0, 10.0);
    let mut vertices: Vec<Vec3> = Vec::with_capacity(n + 2);
    for _ in 0..n + 2 {
        vertices.push(p);
        p += r.vec3(-0.8, 0.8);
    }
    let corners = (0..n as u32)
        .map(|k| {
            let mut c = [k, k + 1, k + 2];
            if r.f32() < 0.2 {
                let split = vertices.len() as u32;
                vertices.push(vertices[c[0] as usize]);
                c[0] = split;
            }
            c
        })
        .collect();
    (vertices, corners)
}

/// Rays from points around the scene towards points inside it.
pub fn rays(n: usize, seed: u64, extent: f32) -> Vec<Ray> {
    let mut r = Rng(seed | 1);
    (0..n)
        .map(|_| {
            let o = r.vec3(-extent * 1.5, extent * 1.5);
            let target = r.vec3(-extent, extent);
            Ray::new(o, target - o)
        })
        .collect()
}

/// Asserts that the tree's closest hits equal brute force over its triangles for every ray,
/// exactly: each triangle is tested in the space the traversal meets it in
/// ([`Bvh::brute_force_closest_hit`]), so the same distance to the last bit, and the same
/// triangle unless another is hit at exactly that distance (a tie). No tolerance, near edges or
/// anywhere: a tree that loses a triangle, or a box that cuts one off, fails.
pub fn assert_hits_match(bvh: &Bvh, rays: &[Ray]) {
    for (k, ray) in rays.iter().enumerate() {
        let a = bvh.closest_hit(ray);
        let b = bvh.brute_force_closest_hit(ray);
        match (a, b) {
            (None, None) => {}
            (Some(a), Some(b)) => {
                assert_eq!(a.t, b.t, "ray {k}: bvh {a:?} vs brute force {b:?}");
                if (a.triangle, a.instance) == (b.triangle, b.instance) {
                    assert_eq!((a.u, a.v), (b.u, b.v), "ray {k}");
                } else {
                    assert_eq!(
                        bvh.hit_at(ray, a.triangle, a.instance),
                        Some(b.t),
                        "ray {k}: bvh {a:?} vs brute force {b:?}, not a tie"
                    );
                }
            }
            _ => panic!("ray {k}: bvh {a:?} vs brute force {b:?}"),
        }
        let any = bvh.any_hit(&ray.with_range(ray.t_min, b.map_or(ray.t_max, |h| h.t)));
        assert_eq!(
            any.is_some(),
            b.is_some(),
            "ray {k}: any_hit {any:?}, brute force {b:?}"
        );
    }
}

/// Loads an OBJ from ../shared/scenes/obj, fan-triangulated in file order.
pub fn load_obj(name: &str) -> Vec<Triangle> {
    let path = treelight_test_support::shared_scene(&format!("obj/{name}"));
    let scene = treelight_import::load_scene(&path).unwrap_or_else(|e| panic!("{e}"));
    scene
        .world_triangles()
        .into_iter()
        .map(|[a, b, c]| Triangle::new(a, b, c))
        .collect()
}
