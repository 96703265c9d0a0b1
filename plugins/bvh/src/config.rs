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
    /// scattered batches of a random order. The default, 64, trades a little cost for much of
    /// the owner's time.
    pub block_min_batch: u32,
    /// IncrUPB: a batch kept whole by `block_min_batch` is split after all when it is crowded:
    /// when, at the scene's mean density (its triangles over the volume of its bounds), its box
    /// would hold more than this many foreign triangles per own one. That catches pieces of thin
    /// geometry that the rest of the scene crosses (hair, cables, scaffolding), whose own area
    /// ratio looks compact; flat patches have no volume and are never crowded. It lowers the cost
    /// most on tangled scenes (a hairball), where it also costs the most speed: their batches
    /// become tube segments, whose roots the owner inserts one by one. `f32::INFINITY` (or 0)
    /// turns the test off.
    pub block_crowd_max: f32,
    /// IncrUP: items searched in parallel before they are linked one by one.
    pub parallel_search_batch: u32,
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
            parallel_search_batch: 16,
            keep_only_improving: false,
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
