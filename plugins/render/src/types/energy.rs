//! The GGX lobe's directional albedo, tabulated for the kernel's energy compensation: a
//! single-scattering microfacet lobe loses the light that would bounce between microfacets (up to
//! half of it at roughness 1 near grazing), so a rough metal looks darker than it is. The kernel
//! scales the lobe by `1 + f0 (1 - E) / E` (Kulla and Conty's compensation in Turquin's form) and
//! weights what lies under a dielectric's specular by `1 - E_spec`, so a white furnace returns the
//! light it receives.
//!
//! `E(μ, r) = f0 A + B` for Schlick's Fresnel: the table holds `A` and `B` over `√μ` (μ the cosine
//! of the view angle) and the perceptual roughness `r`, each on [`ENERGY_SIZE`] points from 0 to 1,
//! integrated here by importance sampling the same D and Smith G the kernel evaluates.

use std::f64::consts::PI;
use std::sync::OnceLock;

/// Points along each axis of the table.
pub const ENERGY_SIZE: usize = 32;

/// Samples per table entry (a Hammersley set).
const SAMPLES: u32 = 4096;

/// The smallest perceptual roughness the kernel uses (Bevy's clamp).
pub const MIN_ROUGHNESS: f64 = 0.089;

fn radical_inverse(mut bits: u32) -> f64 {
    bits = bits.reverse_bits();
    f64::from(bits) / 4_294_967_296.0
}

fn smith_g1(nx: f64, a2: f64) -> f64 {
    2.0 * nx / (nx + (a2 + (1.0 - a2) * nx * nx).sqrt())
}

/// `(A, B)` at view cosine `mu` and perceptual roughness `r`: the lobe's albedo is `f0 A + B`.
pub fn split_sum(mu: f64, r: f64) -> (f64, f64) {
    let r = r.clamp(MIN_ROUGHNESS, 1.0);
    let alpha = r * r;
    let a2 = alpha * alpha;
    let nv = mu.clamp(1e-4, 1.0);
    let wo = [(1.0 - nv * nv).max(0.0).sqrt(), 0.0, nv];
    let (mut a, mut b) = (0.0, 0.0);
    for i in 0..SAMPLES {
        let u1 = (f64::from(i) + 0.5) / f64::from(SAMPLES);
        let u2 = radical_inverse(i);
        // The kernel's half-vector sampling: pdf(h) = D(h) (n.h).
        let cos_t = ((1.0 - u1) / (1.0 + (a2 - 1.0) * u1)).sqrt();
        let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
        let phi = 2.0 * PI * u2;
        let h = [sin_t * phi.cos(), sin_t * phi.sin(), cos_t];
        let vh = wo[0] * h[0] + wo[1] * h[1] + wo[2] * h[2];
        let nl = 2.0 * vh * h[2] - wo[2];
        if nl <= 0.0 || vh <= 0.0 {
            continue;
        }
        // brdf cos / pdf for the reflection about h, with F factored out.
        let weight = smith_g1(nl, a2) * smith_g1(nv, a2) * vh / (nv * cos_t);
        let fc = (1.0 - vh).powi(5);
        a += (1.0 - fc) * weight;
        b += fc * weight;
    }
    (a / f64::from(SAMPLES), b / f64::from(SAMPLES))
}

/// The table as the kernel's uniform holds it: entry `j * ENERGY_SIZE + i` (view cosine
/// `(i / (ENERGY_SIZE - 1))²`, denser towards grazing where the albedo changes fastest; roughness
/// `j / (ENERGY_SIZE - 1)`) is `(A, B)`, two entries to a `vec4`.
pub fn energy_table() -> &'static [f32] {
    static TABLE: OnceLock<Vec<f32>> = OnceLock::new();
    TABLE.get_or_init(|| {
        let last = (ENERGY_SIZE - 1) as f64;
        let mut out = Vec::with_capacity(ENERGY_SIZE * ENERGY_SIZE * 2);
        for j in 0..ENERGY_SIZE {
            for i in 0..ENERGY_SIZE {
                let x = i as f64 / last;
                let (a, b) = split_sum(x * x, j as f64 / last);
                out.extend([a as f32, b as f32]);
            }
        }
        out
    })
}

/// The table's bytes, for the kernel's uniform (binding [`ENERGY_BINDING`] of group 0).
pub fn energy_bytes() -> &'static [u8] {
    bytemuck::cast_slice(energy_table())
}

/// The group-0 binding of the energy table.
pub const ENERGY_BINDING: u32 = 29;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_smooth_lobe_reflects_everything_and_a_rough_one_loses_some() {
        let (a, b) = split_sum(1.0, 0.0);
        assert!(
            (a + b - 1.0).abs() < 0.01,
            "smooth at normal incidence: {}",
            a + b
        );
        let (a, b) = split_sum(0.5, 1.0);
        let e = a + b;
        assert!(e > 0.4 && e < 0.9, "rough: {e}");
        // More is lost the rougher the lobe.
        let (a2, b2) = split_sum(0.5, 0.5);
        assert!(a2 + b2 > e);
    }

    #[test]
    fn the_table_has_every_entry_finite_and_at_most_one() {
        let t = energy_table();
        assert_eq!(t.len(), ENERGY_SIZE * ENERGY_SIZE * 2);
        for pair in t.chunks_exact(2) {
            assert!(pair[0].is_finite() && pair[1].is_finite());
            assert!(
                pair[0] >= 0.0 && pair[1] >= 0.0 && pair[0] + pair[1] <= 1.001,
                "{pair:?}"
            );
        }
    }
}
