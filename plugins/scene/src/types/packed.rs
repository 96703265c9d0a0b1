//! Unit vectors in few bits: the corners' normals and tangents a scene keeps per triangle, packed as
//! a renderer uploads them (octahedral mapping), so the scene's copy of a mesh's shading is a third
//! of f32 vectors' size for normals and a sixth for tangents. The shaders' `octahedral.wgsl` decodes
//! the same words.

use bevy::math::{Vec3, Vec4};

/// A unit vector in 32 bits: octahedral mapping, two snorm16 (x in the low half, as WGSL's
/// `unpack2x16snorm` reads it). Precise to about 0.005°.
pub fn encode_normal(n: Vec3) -> u32 {
    let [x, y] = octahedral(n.normalize_or(Vec3::Z));
    let snorm = |v: f32| ((v.clamp(-1.0, 1.0) * 32767.0).round() as i16) as u16 as u32;
    snorm(x) | (snorm(y) << 16)
}

/// The inverse of [`encode_normal`], as the shader computes it.
pub fn decode_normal(w: u32) -> Vec3 {
    let unorm = |h: u32| ((h as u16 as i16) as f32 / 32767.0).max(-1.0);
    octahedral_direction(unorm(w & 0xffff), unorm(w >> 16))
}

/// Steps of a tangent's octahedral coordinates either side of zero (10-bit snorm).
const TANGENT_STEPS: f32 = 511.0;

/// A triangle's three corner tangents (xyz, and the bitangent's sign in w, glTF's convention) in 64
/// bits: each direction octahedral in two 10-bit snorms (within a quarter degree, ample for a frame
/// that bends a normal map), one bitangent sign for the triangle (from corner 0: a sign flips only
/// across a UV seam, where the corners are split), and a flag. The first word holds corner 0's two
/// and corner 1's x, the sign (bit 30) and the flag (bit 31); the second corner 1's y and corner
/// 2's two.
pub fn encode_tangents(t: [Vec4; 3]) -> [u32; 2] {
    triangle_tangents(t.map(encode_tangent))
}

/// One vertex's tangent (xyz, and the bitangent's sign in w) in 32 bits, as a mesh's shading keeps
/// it by vertex: the direction's two 10-bit octahedral fields (bits 0–19), the sign (bit 30) and a
/// flag (bit 31). [`triangle_tangents`] lays three of them out as a triangle's words.
pub fn encode_tangent(t: Vec4) -> u32 {
    let q = |v: f32| ((v.clamp(-1.0, 1.0) * TANGENT_STEPS).round() + TANGENT_STEPS) as u32;
    let [x, y] = octahedral(t.truncate().normalize_or(Vec3::X)).map(q);
    x | (y << 10) | (u32::from(t.w < 0.0) << 30) | (1 << 31)
}

/// A triangle's tangent words ([`encode_tangents`]' layout) from its corners' vertex words
/// ([`encode_tangent`]): the bitangent's sign is corner 0's.
pub fn triangle_tangents(corners: [u32; 3]) -> [u32; 2] {
    let field = |w: u32, at: u32| (w >> at) & 0x3ff;
    let [a, b, c] = corners;
    [
        field(a, 0) | (field(a, 10) << 10) | (field(b, 0) << 20) | (a & (1 << 30)) | (1 << 31),
        field(b, 10) | (field(c, 0) << 10) | (field(c, 10) << 20),
    ]
}

/// The inverse of [`encode_tangents`], as the kernel computes it: the corners' unit directions and
/// the bitangent's sign, or `None` for words without tangents (all zero).
pub fn decode_tangents(w: [u32; 2]) -> Option<([Vec3; 3], f32)> {
    if w[0] >> 31 == 0 {
        return None;
    }
    let field = |word: u32, at: u32| ((word >> at) & 0x3ff) as f32 / TANGENT_STEPS - 1.0;
    let dir = octahedral_direction;
    let sign = if (w[0] >> 30) & 1 == 1 { -1.0 } else { 1.0 };
    Some((
        [
            dir(field(w[0], 0), field(w[0], 10)),
            dir(field(w[0], 20), field(w[1], 0)),
            dir(field(w[1], 10), field(w[1], 20)),
        ],
        sign,
    ))
}

/// The octahedral coordinates (each -1..1) of unit vector `n`: the normals' and the tangents'.
fn octahedral(n: Vec3) -> [f32; 2] {
    let l1 = n.x.abs() + n.y.abs() + n.z.abs();
    let (x, y) = (n.x / l1, n.y / l1);
    if n.z >= 0.0 {
        return [x, y];
    }
    let sign = |v: f32| if v >= 0.0 { 1.0 } else { -1.0 };
    [(1.0 - y.abs()) * sign(x), (1.0 - x.abs()) * sign(y)]
}

/// The unit vector at octahedral coordinates `(x, y)`, [`octahedral`]'s inverse (the shaders'
/// `octahedral_direction`).
fn octahedral_direction(x: f32, y: f32) -> Vec3 {
    let mut n = Vec3::new(x, y, 1.0 - x.abs() - y.abs());
    let t = (-n.z).max(0.0);
    n.x += if n.x >= 0.0 { -t } else { t };
    n.y += if n.y >= 0.0 { -t } else { t };
    n.normalize()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normals_and_tangents_come_back_within_their_precision() {
        let mut seed = 7u32;
        let mut next = || {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (seed >> 8) as f32 / (1u32 << 24) as f32 * 2.0 - 1.0
        };
        for _ in 0..2000 {
            let n = Vec3::new(next(), next(), next()).normalize_or(Vec3::Y);
            assert!(decode_normal(encode_normal(n)).dot(n) > 0.999_999, "{n}");
            let w = if next() < 0.0 { -1.0 } else { 1.0 };
            let t: [Vec4; 3] = std::array::from_fn(|_| {
                Vec3::new(next(), next(), next())
                    .normalize_or(Vec3::X)
                    .extend(w)
            });
            let (back, sign) = decode_tangents(encode_tangents(t)).unwrap();
            assert_eq!(sign, w);
            for (b, t) in back.iter().zip(t) {
                assert!(b.dot(t.truncate()) > 0.9999, "{b} vs {t}");
            }
        }
        assert_eq!(decode_tangents([0, 0]), None);
    }
}
