//! The kernel's BRDF written again from its definition, for CPU references.

use std::f32::consts::PI;
use treelight_bvh::glam::{Vec2, Vec3};
use treelight_render::SurfaceMaterial;

/// `(A, B)` of the GGX lobe from the crate's table, bilinear as the kernel reads it.
pub fn split_sum(mu: f32, r: f32) -> (f32, f32) {
    let t = treelight_render::energy_table();
    let n = treelight_render::ENERGY_SIZE;
    let last = (n - 1) as f32;
    let (x, y) = (mu.clamp(0.0, 1.0).sqrt() * last, r.clamp(0.0, 1.0) * last);
    let (i, j) = ((x as usize).min(n - 2), (y as usize).min(n - 2));
    let (fx, fy) = (x - i as f32, y - j as f32);
    let at = |i: usize, j: usize| {
        let k = (j * n + i) * 2;
        Vec2::new(t[k], t[k + 1])
    };
    let v = at(i, j)
        .lerp(at(i + 1, j), fx)
        .lerp(at(i, j + 1).lerp(at(i + 1, j + 1), fx), fy);
    (v.x, v.y)
}

/// The kernel's BRDF model (opaque, no coat), written again from its definition: a GGX lobe
/// compensated for multiple scattering over a Lambert lobe weighted by what the dielectric's
/// specular leaves.
pub fn brdf(m: &SurfaceMaterial, n: Vec3, wo: Vec3, wi: Vec3) -> Vec3 {
    let (nl, nv) = (n.dot(wi), n.dot(wo));
    if nl <= 0.0 || nv <= 0.0 {
        return Vec3::ZERO;
    }
    let albedo = Vec3::new(m.base_color[0], m.base_color[1], m.base_color[2]);
    let r = m.perceptual_roughness.clamp(0.089, 1.0);
    let a2 = (r * r) * (r * r);
    let h = (wo + wi).normalize();
    let (nh, vh) = (n.dot(h).max(0.0), wo.dot(h).max(0.0));
    let f0_d = Vec3::splat(0.16 * m.reflectance * m.reflectance);
    let f0 = f0_d.lerp(albedo, m.metallic);
    let (a, b) = split_sum(nv.max(1e-4), r);
    let e = (a + b).max(1e-3);
    let compensation = Vec3::ONE + f0 * ((1.0 - e) / e);
    let e_d = (Vec3::ONE + f0_d * ((1.0 - e) / e)) * (f0_d * a + Vec3::splat(b));
    let base = (1.0 - m.metallic) * (Vec3::ONE - e_d).max(Vec3::ZERO);
    let f = f0 + (Vec3::ONE - f0) * (1.0 - vh).powi(5);
    let d = a2 / (PI * (nh * nh * (a2 - 1.0) + 1.0).powi(2));
    let g1 = |x: f32| 2.0 * x / (x + (a2 + (1.0 - a2) * x * x).sqrt());
    compensation * f * (d * g1(nl) * g1(nv) / (4.0 * nl * nv)) + base * albedo / PI
}
