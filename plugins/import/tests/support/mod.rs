//! What the import crate's test binaries share.

/// One triangle's bytes: three float positions (36 bytes), then three u16 indices (6, padded to 8).
pub fn triangle_bin() -> Vec<u8> {
    let mut bin = Vec::new();
    for p in [[0f32, 0., 0.], [1., 0., 0.], [0., 1., 0.]] {
        for c in p {
            bin.extend(c.to_le_bytes());
        }
    }
    for i in [0u16, 1, 2, 0] {
        bin.extend(i.to_le_bytes());
    }
    bin
}
