//! Errors the engine reports instead of panicking.

use thiserror::Error;

/// What can go wrong when feeding the engine.
#[derive(Debug, Error, PartialEq)]
pub enum BvhError {
    /// A vertex had a NaN or infinite coordinate.
    #[error("triangle {index} has a NaN or infinite vertex coordinate")]
    NonFiniteVertex {
        /// Position of the triangle in the batch given.
        index: usize,
    },
    /// A vertex coordinate was beyond what the cost model can sum.
    #[error("triangle {index} has a coordinate beyond ±{limit:e}")]
    CoordinateTooLarge {
        /// Position of the triangle in the batch given.
        index: usize,
        /// The largest magnitude accepted.
        limit: f32,
    },
    /// A triangle's corner indexed past the vertices given.
    #[error("triangle {index} has a corner past the {vertices} vertices given")]
    CornerOutOfRange {
        /// Position of the triangle in the batch given.
        index: usize,
        /// Vertices given.
        vertices: usize,
    },
    /// A transform had a NaN, infinite or singular matrix.
    #[error("the transform is not finite and invertible")]
    BadTransform,
    /// More triangles or nodes than 30-bit indices can address.
    #[error("the tree would exceed {limit} entries")]
    TooLarge {
        /// The largest count accepted.
        limit: u32,
    },
    /// Triangles shared by several groups ([`crate::Bvh::insert_instance`]) cannot be removed one by
    /// one: the groups that use them would change too.
    #[error("triangle {0} is shared by several groups")]
    SharedTriangles(u32),
    /// A group handle that was removed or never existed.
    #[error("unknown or removed group")]
    UnknownGroup,
    /// A triangle id that is not alive.
    #[error("unknown or removed triangle {0}")]
    UnknownTriangle(u32),
    /// A group update with a different number of triangles than the group holds.
    #[error("the group holds {expected} triangles, {got} were given")]
    TriangleCountMismatch {
        /// Triangles in the group.
        expected: usize,
        /// Triangles given.
        got: usize,
    },
    /// A file that is not a valid Treelight BVH file.
    #[error("not a valid TLBVH1 file: {0}")]
    BadFile(String),
}
