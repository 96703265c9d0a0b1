//! GPU records with their child boxes quantized to bytes (after Ylitie, Karras, Laine 2017): a record
//! holds the minimum corner of its children's boxes and a power-of-two step per axis, and each
//! child's box as whole steps from that corner, rounded outwards so it still holds the child.
//!
//! The path tracer's record is 4-wide: 64 bytes for four children where the binary record takes 64
//! for two, laid out by [`crate::WideRecords`] at the inner nodes the traversal reads. The binary
//! record with its boxes in bytes ([`GpuCompressedBinaryNode`], 48 bytes) is kept for measuring
//! layouts.

use crate::{GpuNode, GpuWideNode, NodeRef};
use bytemuck::{Pod, Zeroable};

/// One compressed 4-wide node for the GPU, 64 bytes. Child `k`'s box on axis `a` is
/// `origin[a] + q * step(a)` for byte `k` of the axis's minimum and maximum words, where
/// `step(a)` is the float whose exponent bits are byte `a` of `exponents` (a power of two).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct GpuCompressedNode {
    /// The minimum corner of the union of the children's boxes.
    pub origin: [f32; 3],
    /// The steps' biased exponents, x in the low byte, then y and z.
    pub exponents: u32,
    /// Quantized boxes on x, four children per word (child 0 in the low byte): minima, maxima.
    pub quantized_x: [u32; 2],
    /// The same on y.
    pub quantized_y: [u32; 2],
    /// The same on z.
    pub quantized_z: [u32; 2],
    /// Unused; keeps `refs` 16-byte aligned as WGSL lays out the record.
    pub pad: [u32; 2],
    /// Child references (as in [`GpuWideNode`]; `NONE` for an empty slot).
    pub refs: [u32; 4],
}

/// One compressed binary node for the GPU, 48 bytes: [`GpuNode`] with its two boxes in bytes.
/// `quantized` holds, a byte each from the low byte of word 0: the left child's minimum x, y, z and
/// maximum x, y, z, then the right child's the same; a coordinate is `origin + q * step` as in
/// [`GpuCompressedNode`].
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct GpuCompressedBinaryNode {
    /// The minimum corner of the union of the children's boxes.
    pub origin: [f32; 3],
    /// The steps' biased exponents, x in the low byte, then y and z.
    pub exponents: u32,
    /// The twelve quantized coordinates.
    pub quantized: [u32; 3],
    /// Left child reference.
    pub a_ref: u32,
    /// Right child reference.
    pub b_ref: u32,
    /// Padding to 48 bytes, the record's size in a WGSL array.
    pub pad: [u32; 3],
}

fn step(exponent: u32) -> f32 {
    f32::from_bits(exponent << 23)
}

/// One axis of a record: the boxes' `[min, max]` on it in, the origin, the biased exponent and each
/// box's quantized `[min, max]` out.
fn quantize_axis<const N: usize>(boxes: [[f32; 2]; N]) -> (f32, u32, [[u32; 2]; N]) {
    let origin = boxes.iter().map(|b| b[0]).fold(f32::INFINITY, f32::min);
    let top = boxes.iter().map(|b| b[1]).fold(f32::NEG_INFINITY, f32::max);
    if !origin.is_finite() || !top.is_finite() {
        return (0.0, 1, [[0, 0]; N]);
    }
    let top = top.max(origin);
    // The smallest step for which 255 of them reach `top` in f32 arithmetic: the exponent of
    // d / 255, d = top - origin as rounded, is enough only where that is a power of two; the next
    // one always is (d < 255 * its step, so origin plus that is above `top` and rounds to no
    // less). `q * step` is exact, so the kernel's sum rounds as this one does, monotonically: a
    // bound checked here holds there.
    let mut e = (((top - origin) / 255.0).to_bits() >> 23 & 0xff).clamp(1, 254);
    if e < 254 && origin + step(e) * 255.0 < top {
        e += 1;
    }
    let s = step(e);
    // `s` is a power of two, so multiplying by its inverse divides exactly; the casts floor the
    // non-negative quotients (and saturate an empty slot's infinities), without a libm call.
    let inv = if e < 254 { step(254 - e) } else { 1.0 / s };
    let mut q = [[0u32; 2]; N];
    for ([lo, hi], out) in boxes.into_iter().zip(&mut q) {
        let a = (((lo - origin) * inv).clamp(0.0, 256.0) as u32).min(255);
        let t = ((hi - origin) * inv).clamp(0.0, 256.0);
        let b = ((t as u32) + u32::from((t as u32 as f32) < t)).min(255);
        // The quotients are nearly always right; the walks correct a rounded one.
        out[0] = if a > 0 && origin + a as f32 * s > lo {
            walk_down(a, origin, s, lo)
        } else {
            a
        };
        out[1] = if b < 255 && origin + b as f32 * s < hi {
            walk_up(b, origin, s, hi)
        } else {
            b
        };
    }
    (origin, e, q)
}

/// The largest `q <= a` with `origin + q * s <= lo` (0 at the least). Out of line, as is
/// [`walk_up`]: inlined, the compiler unrolls each into a vector search that costs more than the
/// rest of the record, where the first guess nearly always stands.
#[cold]
#[inline(never)]
fn walk_down(mut a: u32, origin: f32, s: f32, lo: f32) -> u32 {
    #[cfg(test)]
    tests::WALKS.with(|w| w[0].set(w[0].get() + 1));
    while a > 0 && origin + a as f32 * s > lo {
        a -= 1;
    }
    a
}

/// The smallest `q >= b` with `origin + q * s >= hi` (255 at the most).
#[cold]
#[inline(never)]
fn walk_up(mut b: u32, origin: f32, s: f32, hi: f32) -> u32 {
    #[cfg(test)]
    tests::WALKS.with(|w| w[1].set(w[1].get() + 1));
    while b < 255 && origin + b as f32 * s < hi {
        b += 1;
    }
    b
}

impl GpuCompressedNode {
    /// Child `k`'s box on `axis` (0 to 2) as the kernel decodes it: `[min, max]`.
    pub fn child_bounds(&self, k: usize, axis: usize) -> [f32; 2] {
        let s = step(self.exponents >> (8 * axis) & 0xff);
        let [lo, hi] = [self.quantized_x, self.quantized_y, self.quantized_z][axis];
        let byte = |w: u32| (w >> (8 * k) & 0xff) as f32;
        [
            self.origin[axis] + byte(lo) * s,
            self.origin[axis] + byte(hi) * s,
        ]
    }

    /// `node`'s children quantized outwards (empty slots decode as empty boxes at the origin; the
    /// kernel skips them by their references).
    pub fn quantize(node: &GpuWideNode) -> Self {
        let used = |k: usize| node.refs[k] != NodeRef::NONE.0;
        let rows = [
            (node.min_x, node.max_x),
            (node.min_y, node.max_y),
            (node.min_z, node.max_z),
        ];
        let mut out = Self {
            origin: [0.0; 3],
            exponents: 0,
            quantized_x: [0; 2],
            quantized_y: [0; 2],
            quantized_z: [0; 2],
            pad: [0; 2],
            refs: node.refs,
        };
        for (axis, (lo, hi)) in rows.into_iter().enumerate() {
            let boxes: [[f32; 2]; 4] = std::array::from_fn(|k| {
                if used(k) {
                    [lo[k], hi[k]]
                } else {
                    [f32::INFINITY, f32::NEG_INFINITY]
                }
            });
            let (origin, e, q) = quantize_axis(boxes);
            let (mut qlo, mut qhi) = (0u32, 0u32);
            for (k, [a, b]) in q.into_iter().enumerate() {
                if used(k) {
                    qlo |= a << (8 * k);
                    qhi |= b << (8 * k);
                }
            }
            out.origin[axis] = origin;
            out.exponents |= e << (8 * axis);
            *[
                &mut out.quantized_x,
                &mut out.quantized_y,
                &mut out.quantized_z,
            ][axis] = [qlo, qhi];
        }
        out
    }
}

impl GpuCompressedBinaryNode {
    /// The left (`k` 0) or right (1) child's box on `axis` as the kernel decodes it: `[min, max]`.
    pub fn child_bounds(&self, k: usize, axis: usize) -> [f32; 2] {
        let s = step(self.exponents >> (8 * axis) & 0xff);
        let byte = |i: usize| (self.quantized[i / 4] >> (8 * (i % 4)) & 0xff) as f32;
        [
            self.origin[axis] + byte(6 * k + axis) * s,
            self.origin[axis] + byte(6 * k + 3 + axis) * s,
        ]
    }

    /// `node`'s boxes quantized outwards (a freed slot, with null children, keeps them null).
    pub fn quantize(node: &GpuNode) -> Self {
        let mut out = Self {
            origin: [0.0; 3],
            exponents: 0,
            quantized: [0; 3],
            a_ref: node.a_ref,
            b_ref: node.b_ref,
            pad: [0; 3],
        };
        for axis in 0..3 {
            let (origin, e, [a, b]) = quantize_axis([
                [node.a_min[axis], node.a_max[axis]],
                [node.b_min[axis], node.b_max[axis]],
            ]);
            out.origin[axis] = origin;
            out.exponents |= e << (8 * axis);
            for (i, q) in [
                (axis, a[0]),
                (3 + axis, a[1]),
                (6 + axis, b[0]),
                (9 + axis, b[1]),
            ] {
                out.quantized[i / 4] |= q << (8 * (i % 4));
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::cell::Cell;

    thread_local! {
        /// Calls of the walks on this thread: down, up.
        pub(super) static WALKS: [Cell<u32>; 2] = const { [Cell::new(0), Cell::new(0)] };
    }

    /// Records of coordinates at every scale, half of them just under or over 255 steps of a
    /// power of two: each walk is needed somewhere, 255 steps always reach the top, and every
    /// decoded box holds its child as tightly as the step allows.
    #[test]
    fn rounded_guesses_are_walked_to_boxes_that_hold() {
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut next = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            seed
        };
        for _ in 0..200_000 {
            let mut value = || {
                let r = next();
                let mantissa = 1.0 + (r >> 40) as f32 / (1u64 << 24) as f32;
                let v = mantissa * 2f32.powi((r % 60) as i32 - 30);
                if r & 1 << 20 == 0 { v } else { -v }
            };
            let mut boxes: [[f32; 2]; 4] = std::array::from_fn(|_| {
                let (a, b) = (value(), value());
                [a.min(b), a.max(b)]
            });
            let r = next();
            if r & 1 == 0 {
                let step = 2f32.powi((r >> 8) as i32 % 50 - 25);
                let nudge = ((r >> 16) % 3) as f32 - 1.0;
                let span = 255.0 * step * (1.0 + nudge * 2f32.powi(-(((r >> 24) % 8) as i32 + 17)));
                boxes[1] = [boxes[0][0] + span * 0.5, boxes[0][0] + span];
            }
            let (origin, e, q) = quantize_axis(boxes);
            let s = step(e);
            let top = boxes.iter().map(|b| b[1]).fold(f32::NEG_INFINITY, f32::max);
            assert!(
                origin + s * 255.0 >= top,
                "{boxes:?}: step {s} short of {top}"
            );
            for ([lo, hi], [a, b]) in boxes.into_iter().zip(q) {
                let (dlo, dhi) = (origin + a as f32 * s, origin + b as f32 * s);
                assert!(
                    dlo <= lo && dhi >= hi,
                    "{boxes:?}: [{dlo}, {dhi}] misses [{lo}, {hi}]"
                );
                assert!(
                    a == 255 || origin + (a + 1) as f32 * s > lo,
                    "{boxes:?}: {a} not the last below {lo}"
                );
                assert!(
                    b == 0 || origin + (b - 1) as f32 * s < hi,
                    "{boxes:?}: {b} not the first above {hi}"
                );
            }
        }
        let walks = WALKS.with(|w| w.each_ref().map(Cell::get));
        assert!(walks.iter().all(|&n| n > 0), "walks taken: {walks:?}");
        // A record as wide as floats go keeps a finite step.
        let (_, e, _) = quantize_axis([[-3e38, 0.0], [0.0, 3e38]]);
        assert!(e <= 254 && step(e).is_finite());
    }
}
