//! Node references and inner nodes.
//!
//! A leaf *is* its triangle: a leaf's id is the triangle id, so the GPU layout needs no slots for leaves
//! and the node arrays hold only inner nodes. Instance nodes (groups kept whole under a transform) have
//! their own array. A [`NodeRef`] says which of the three a child is.

use crate::Aabb;

/// Marks the absence of a node (no parent, empty tree).
pub const NONE: u32 = u32::MAX;
/// Marks a freed slot in a node or triangle array.
pub(crate) const FREE: u32 = u32::MAX - 1;

const TAG_SHIFT: u32 = 30;
const INDEX_MASK: u32 = (1 << TAG_SHIFT) - 1;
/// Largest index any array may reach (2^30 - 1), because two bits of a reference hold its kind.
pub const MAX_INDEX: u32 = INDEX_MASK - 1;

/// What a [`NodeRef`] points at.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NodeKind {
    /// An inner node with two children.
    Inner,
    /// A leaf, identified by its triangle id.
    Leaf,
    /// A transformed group's root, identified by its instance index.
    Instance,
    /// No node.
    None,
}

/// A tagged 32-bit reference: two bits of kind, thirty of index. The same encoding goes to the GPU.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct NodeRef(pub u32);

impl Default for NodeRef {
    fn default() -> Self {
        NodeRef::NONE
    }
}

impl NodeRef {
    /// The null reference.
    pub const NONE: NodeRef = NodeRef(u32::MAX);

    /// Reference to inner node `i`.
    #[inline]
    pub const fn inner(i: u32) -> Self {
        NodeRef(i)
    }
    /// Reference to the leaf of triangle `t`.
    #[inline]
    pub const fn leaf(t: u32) -> Self {
        NodeRef(t | (1 << TAG_SHIFT))
    }
    /// Reference to instance `i`.
    #[inline]
    pub const fn instance(i: u32) -> Self {
        NodeRef(i | (2 << TAG_SHIFT))
    }
    /// The kind of node referred to.
    #[inline]
    pub const fn kind(self) -> NodeKind {
        match self.0 >> TAG_SHIFT {
            0 => NodeKind::Inner,
            1 => NodeKind::Leaf,
            2 => NodeKind::Instance,
            _ => NodeKind::None,
        }
    }
    /// Index within the array of its kind.
    #[inline]
    pub const fn index(self) -> u32 {
        self.0 & INDEX_MASK
    }
    /// Whether this is the null reference.
    #[inline]
    pub const fn is_none(self) -> bool {
        self.0 == u32::MAX
    }
    /// Whether this refers to an inner node.
    #[inline]
    pub const fn is_inner(self) -> bool {
        self.0 >> TAG_SHIFT == 0
    }
}

/// An inner node: its box, two children and a parent (an inner node index or [`NONE`]).
#[derive(Clone, Copy, Debug)]
pub struct InnerNode {
    /// Bounds of both children.
    pub aabb: Aabb,
    /// Left and right child.
    pub children: [NodeRef; 2],
    /// Parent inner node, [`NONE`] for a root (of the global tree or of an instanced subtree).
    pub parent: u32,
}

impl InnerNode {
    /// A freshly allocated slot, before anything links it: empty box, no children, no parent.
    pub(crate) const UNLINKED: InnerNode = InnerNode {
        aabb: Aabb::EMPTY,
        children: [NodeRef::NONE; 2],
        parent: NONE,
    };

    /// Whether the slot holds a live node under some parent: not free, and not a root (of the
    /// global tree, of an instanced subtree, or a node detached for the moment).
    #[inline]
    pub(crate) fn has_parent(&self) -> bool {
        self.parent != NONE && self.parent != FREE
    }
}
