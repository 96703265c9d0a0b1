//! Parameters of the cost model and of the incremental construction.

/// Inefficiency measure used to pick nodes for global updates (Bittner et al. 2013).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Inefficiency {
    /// `M_sum * M_min * M_area`, the paper's default.
    #[default]
    Comb,
    /// The node's surface area.
    Area,
    /// Area over the mean of the children's areas.
    Sum,
    /// Area over the smaller child's area.
    Min,
}

/// How IncrUPB builds the bBVH of a batch (the paper allows any builder).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum BatchBvh {
    /// Spatial median splits of the centroid bounds: per level one branch-free partition pass and
    /// one pass measuring the halves. The default: on Sibenik its bBVHs take well under half the
    /// instructions that `Sah`'s take, which lets the building side keep up with the owner, and
    /// the global updates repair most of what the cheaper bBVHs lose (final cost 55.55 against
    /// 54.30 with the batching of `block_min_batch` = 16).
    #[default]
    Median,
    /// SAH-driven: greedy agglomerative clustering for batches of up to 32 triangles, binned SAH
    /// for larger ones.
    Sah,
}

/// Everything the incremental builders and the cost model can be tuned by.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BvhConfig {
    /// Cost of traversing an inner node (c_T in Eq. 1).
    pub c_t: f32,
    /// Cost of intersecting a triangle (c_I in Eq. 1).
    pub c_i: f32,
    /// Whether insertions are interleaved with global updates (IncrU rather than Incr).
    pub global_updates: bool,
    /// N_u: modified nodes collected before a batch of updates runs.
    pub update_cache_size: u32,
    /// k_u: fraction of the cached nodes that are updated in a batch.
    pub update_fraction: f32,
    /// Inefficiency measure ranking the cached nodes.
    pub inefficiency: Inefficiency,
    /// Pair consecutive coherent triangles before insertion.
    pub clustering: bool,
    /// Rounds of clustering (when `clustering` is on): the first pairs coherent consecutive
    /// triangles, as the paper does, and each further round pairs coherent consecutive clusters
    /// that the round before made, by the same R_coh < R_max test on their boxes. 2 makes
    /// subtrees of up to four triangles from a coherent stream and inserts a quarter as many
    /// items as triangles. 0 counts as 1. Not in the paper beyond 1; Incr, IncrU and IncrUP read
    /// it (IncrUPB builds its batches its own way).
    pub cluster_levels: u32,
    /// R_max: pairs with R_coh below it are clustered, batches with R*_coh below it are not split further.
    pub coherence_max: f32,
    /// IncrUPB: the largest batch built into one bBVH, so that coherent streams still give parallel work.
    pub block_max_batch: u32,
    /// IncrUPB: batches this small are not split further while their box's area is below R_max times
    /// the sum of their triangles' box areas (1 is the paper's rule, which splits by R*_coh alone).
    /// On a surface mesh R*_coh grows like the cube root of the batch size (flat boxes tile a
    /// plane, not a volume), so the paper's rule cuts such a stream into batches of a few triangles
    /// and spends its time inserting their roots one by one; the area test still splits the
    /// scattered batches of a random order. The default, 64, trades cost for the owner's time:
    /// on Sibenik 16 -> 64 cuts the owner's instructions from ~64M to ~42M for a cost 55.55 ->
    /// 57.06 (1.068x IncrU's, before `block_crowd_max`), and leaves the bunny and FlightHelmet
    /// within 0.3% of IncrU's.
    pub block_min_batch: u32,
    /// IncrUPB: a batch kept whole by `block_min_batch` is split after all when it is crowded:
    /// when, at the scene's mean density (its triangles over the volume of its bounds), its box
    /// would hold more than this many foreign triangles per own one. That catches pieces of thin
    /// geometry that the rest of the scene crosses (hair, cables, scaffolding), whose own area
    /// ratio looks compact; flat patches have no volume and are never crowded. The default, 0.25:
    /// Sibenik 57.06 -> 54.40 (1.018x IncrU's) for about a tenth more of the owner's work, a
    /// synthetic hairball of 2.88M triangles 1.40x -> 1.15x IncrU's cost, but there 1.94x
    /// instead of 3.06x IncrU's speed on two threads: its batches become tube segments, whose
    /// roots the owner inserts one by one. `f32::INFINITY` (or 0) turns the test off.
    pub block_crowd_max: f32,
    /// IncrUPB: how each batch's bBVH is built.
    pub block_bvh: BatchBvh,
    /// IncrUP: items searched in parallel before they are linked one by one.
    pub parallel_search_batch: u32,
    /// After each insertion, try tree rotations (Kensler 2008) at every node on the path to the
    /// root. Not in the paper: a cheap local update that helps most on scanned meshes.
    pub rotations: bool,
    /// Subtrees per treelet (3 to 8) when an update batch also restructures a treelet (Karras and
    /// Aila 2013) at every node of the node update cache; 0 turns it off. Not in the paper.
    pub update_treelet: u32,
    /// Undo an update that would raise the cost (the paper notes keeping every move works too).
    pub keep_only_improving: bool,
}

impl Default for BvhConfig {
    fn default() -> Self {
        Self {
            c_t: 1.0,
            c_i: 1.0,
            global_updates: true,
            update_cache_size: 8000,
            update_fraction: 0.01,
            inefficiency: Inefficiency::Comb,
            clustering: true,
            cluster_levels: 1,
            coherence_max: 1.5,
            block_max_batch: 1024,
            block_min_batch: 64,
            block_crowd_max: 0.25,
            block_bvh: BatchBvh::Median,
            parallel_search_batch: 16,
            keep_only_improving: false,
            rotations: false,
            update_treelet: 0,
        }
    }
}

impl BvhConfig {
    /// The paper's Incr: insertion only, with clustering.
    pub fn incr() -> Self {
        Self {
            global_updates: false,
            ..Self::default()
        }
    }
    /// The paper's IncrU: insertion with global updates through the node update cache.
    pub fn incr_u() -> Self {
        Self::default()
    }
}
