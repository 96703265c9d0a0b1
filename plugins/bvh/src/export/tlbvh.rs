//! The TLBVH1 file, for checking trees with other tools. Little-endian: 8-byte magic `TLBVH1\0\0`;
//! u32 node count; u32 root index; u32 triangle count; then per node 6 × f32 (min xyz, max xyz),
//! i32 left, i32 right, i32 triangle (−1 for inner nodes; leaves have left = right = −1).
//! Nodes are written in depth-first pre-order, so the root is node 0. Groups kept whole are written
//! baked: their subtrees are inlined with boxes refitted over world-space triangles.

use crate::tree::node::{NodeKind, NodeRef};
use crate::{Aabb, Bvh, BvhError};
use std::io::{Read, Write};

/// The file's magic bytes.
pub const MAGIC: &[u8; 8] = b"TLBVH1\0\0";

/// One node as stored in the file.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FileNode {
    /// Bounds.
    pub aabb: Aabb,
    /// Left child index, −1 for leaves.
    pub left: i32,
    /// Right child index, −1 for leaves.
    pub right: i32,
    /// Triangle id, −1 for inner nodes.
    pub triangle: i32,
}

/// A tree read back from a file.
#[derive(Clone, Debug, PartialEq)]
pub struct FileBvh {
    /// Nodes in file order.
    pub nodes: Vec<FileNode>,
    /// Root index.
    pub root: u32,
    /// Triangle count field: one more than the largest triangle id (equal to the count for a tree built
    /// from a list, whose ids are the input order).
    pub triangle_count: u32,
}

impl Bvh {
    /// The tree in file form, groups baked.
    pub fn to_file_nodes(&self) -> Vec<FileNode> {
        let mut out: Vec<FileNode> = Vec::new();
        if !self.root.is_none() {
            self.emit(self.root, None, &mut out);
        }
        out
    }

    /// Appends the subtree under `n` (pre-order) and returns its index; `xf` maps object to world space.
    fn emit(&self, n: NodeRef, xf: Option<&glam::Affine3A>, out: &mut Vec<FileNode>) -> usize {
        let me = out.len();
        match n.kind() {
            NodeKind::Inner => {
                out.push(FileNode {
                    aabb: Aabb::EMPTY,
                    left: -1,
                    right: -1,
                    triangle: -1,
                });
                let [a, b] = self.inner[n.index() as usize].children;
                let l = self.emit(a, xf, out);
                let r = self.emit(b, xf, out);
                out[me].left = l as i32;
                out[me].right = r as i32;
                out[me].aabb = out[l].aabb.union(&out[r].aabb);
            }
            NodeKind::Leaf => {
                let t = self.tri(n.index());
                let t = xf.map_or(t, |x| t.transformed(x));
                out.push(FileNode {
                    aabb: t.aabb(),
                    left: -1,
                    right: -1,
                    triangle: n.index() as i32,
                });
            }
            NodeKind::Instance => {
                let inst = &self.instances[n.index() as usize];
                return self.emit(inst.root, Some(&inst.transform), out);
            }
            NodeKind::None => {}
        }
        me
    }

    /// Writes the TLBVH1 file.
    pub fn write_tlbvh(&self, w: &mut impl Write) -> std::io::Result<()> {
        self.write_tlbvh_mapped(w, None)
    }

    /// Writes the TLBVH1 file with triangle ids mapped through `input_index` (triangle id → index in
    /// the caller's input), for trees built from a reordered input. The count field is then its length.
    pub fn write_tlbvh_mapped(
        &self,
        w: &mut impl Write,
        input_index: Option<&[u32]>,
    ) -> std::io::Result<()> {
        let mut nodes = self.to_file_nodes();
        if let Some(map) = input_index {
            for n in nodes.iter_mut().filter(|n| n.triangle >= 0) {
                n.triangle = map.get(n.triangle as usize).map_or(-1, |&i| i as i32);
            }
        }
        let count = input_index.map_or(self.triangle_capacity(), |m| m.len() as u32);
        w.write_all(MAGIC)?;
        w.write_all(&(nodes.len() as u32).to_le_bytes())?;
        w.write_all(&0u32.to_le_bytes())?;
        w.write_all(&count.to_le_bytes())?;
        let mut buf = Vec::with_capacity(nodes.len() * 36);
        for n in &nodes {
            for f in n
                .aabb
                .min
                .to_array()
                .into_iter()
                .chain(n.aabb.max.to_array())
            {
                buf.extend_from_slice(&f.to_le_bytes());
            }
            for i in [n.left, n.right, n.triangle] {
                buf.extend_from_slice(&i.to_le_bytes());
            }
        }
        w.write_all(&buf)
    }
}

/// Reads a TLBVH1 file, checking its structure (sizes, index ranges) but not its geometry.
pub fn read_tlbvh(r: &mut impl Read) -> Result<FileBvh, BvhError> {
    let bad = |m: &str| BvhError::BadFile(m.to_string());
    let mut head = [0u8; 20];
    r.read_exact(&mut head)
        .map_err(|_| bad("shorter than its header"))?;
    if &head[..8] != MAGIC {
        return Err(bad("wrong magic"));
    }
    let word = |k: usize| u32::from_le_bytes(head[8 + 4 * k..12 + 4 * k].try_into().unwrap());
    let (count, root, triangle_count) = (word(0), word(1), word(2));
    // Read in bounded chunks so a lying count cannot make us allocate gigabytes up front.
    let mut nodes = Vec::new();
    let mut rec = [0u8; 36];
    for _ in 0..count {
        r.read_exact(&mut rec)
            .map_err(|_| bad("shorter than its node count says"))?;
        let f = |k: usize| f32::from_le_bytes(rec[4 * k..4 * k + 4].try_into().unwrap());
        let i = |k: usize| i32::from_le_bytes(rec[4 * k..4 * k + 4].try_into().unwrap());
        nodes.push(FileNode {
            aabb: Aabb::new(
                glam::Vec3::new(f(0), f(1), f(2)),
                glam::Vec3::new(f(3), f(4), f(5)),
            ),
            left: i(6),
            right: i(7),
            triangle: i(8),
        });
    }
    if count > 0 && root >= count {
        return Err(bad("root index out of range"));
    }
    for (k, n) in nodes.iter().enumerate() {
        let in_range = |c: i32| c >= 0 && (c as u32) < count;
        let ok = if n.triangle >= 0 {
            n.left == -1 && n.right == -1 && (n.triangle as u32) < triangle_count
        } else {
            n.triangle == -1 && in_range(n.left) && in_range(n.right)
        };
        if !ok {
            return Err(bad(&format!("node {k} has bad links")));
        }
    }
    Ok(FileBvh {
        nodes,
        root,
        triangle_count,
    })
}
