//! Ray traversal (closest hit and any hit: nearer child first, explicit stack) and box queries.
//! Instance nodes carry the ray into their group's object space.

use crate::query::ray::RayData;
use crate::tree::node::{NONE, NodeKind, NodeRef};
use crate::{Aabb, Bvh, Hit, Ray, Triangle, TriangleIds};

/// Counters filled by [`Bvh::closest_hit_counted`], the CPU twin of the GPU heatmap view.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TraversalStats {
    /// Nodes whose box was tested.
    pub nodes_visited: u32,
    /// Triangles tested.
    pub triangles_tested: u32,
}

/// A stack that lives on the call stack for ordinary depths and spills to the heap only for trees
/// deeper than `INLINE` (degenerate input can make insertion-built trees deep).
struct NodeStack {
    inline: [NodeRef; 64],
    len: usize,
    spill: Vec<NodeRef>,
}

impl NodeStack {
    #[inline]
    fn new() -> Self {
        Self {
            inline: [NodeRef::NONE; 64],
            len: 0,
            spill: Vec::new(),
        }
    }
    #[inline]
    fn push(&mut self, n: NodeRef) {
        if self.len < self.inline.len() {
            self.inline[self.len] = n;
            self.len += 1;
        } else {
            self.spill.push(n);
        }
    }
    #[inline]
    fn pop(&mut self) -> Option<NodeRef> {
        if let Some(n) = self.spill.pop() {
            return Some(n);
        }
        if self.len == 0 {
            return None;
        }
        self.len -= 1;
        Some(self.inline[self.len])
    }
}

impl Bvh {
    /// The nearest hit along the ray within its range.
    pub fn closest_hit(&self, ray: &Ray) -> Option<Hit> {
        let mut stats = TraversalStats::default();
        self.closest_hit_counted(ray, &mut stats)
    }

    /// [`Bvh::closest_hit`], counting the work done.
    pub fn closest_hit_counted(&self, ray: &Ray, stats: &mut TraversalStats) -> Option<Hit> {
        let mut best = None;
        self.traverse::<false, _>(self.root, ray, NONE, &mut best, stats, &mut |_| true);
        best
    }

    /// The nearest hit on a triangle that `accept` takes, given the candidate hit (its triangle and
    /// the instance it was reached through: [`Bvh::hit_group`] names its group). The others are
    /// seen through, however close to an accepted surface they lie.
    pub fn closest_hit_where(
        &self,
        ray: &Ray,
        mut accept: impl FnMut(&Hit) -> bool,
    ) -> Option<Hit> {
        let mut best = None;
        self.traverse::<false, _>(
            self.root,
            ray,
            NONE,
            &mut best,
            &mut TraversalStats::default(),
            &mut accept,
        );
        best
    }

    /// Some hit along the ray within its range, found as early as possible (for shadow and AO rays).
    pub fn any_hit(&self, ray: &Ray) -> Option<Hit> {
        let mut best = None;
        self.traverse::<true, _>(
            self.root,
            ray,
            NONE,
            &mut best,
            &mut TraversalStats::default(),
            &mut |_| true,
        );
        best
    }

    /// Returns true when something was found and `ANY` asks to stop. `instance` is the instance
    /// `root` hangs under ([`NONE`] at the top); only hits `accept` takes count.
    fn traverse<const ANY: bool, F: FnMut(&Hit) -> bool>(
        &self,
        root: NodeRef,
        ray: &Ray,
        instance: u32,
        best: &mut Option<Hit>,
        stats: &mut TraversalStats,
        accept: &mut F,
    ) -> bool {
        if root.is_none() {
            return false;
        }
        let rd = RayData::new(ray);
        let t_max = |best: &Option<Hit>| best.map_or(ray.t_max, |h| h.t);
        stats.nodes_visited += 1;
        let rb = self.aabb(root);
        if rd.hit_box(rb.min, rb.max, ray.t_min, ray.t_max).is_none() {
            return false;
        }
        let mut stack = NodeStack::new();
        stack.push(root);
        while let Some(n) = stack.pop() {
            match n.kind() {
                NodeKind::Inner => {
                    let [a, b] = self.inner[n.index() as usize].children;
                    let (ba, bb) = (self.aabb(a), self.aabb(b));
                    let tm = t_max(best);
                    stats.nodes_visited += 2;
                    let ta = rd.hit_box(ba.min, ba.max, ray.t_min, tm);
                    let tb = rd.hit_box(bb.min, bb.max, ray.t_min, tm);
                    match (ta, tb) {
                        (Some(ta), Some(tb)) => {
                            // Farther child below, nearer on top.
                            if ta <= tb {
                                stack.push(b);
                                stack.push(a);
                            } else {
                                stack.push(a);
                                stack.push(b);
                            }
                        }
                        (Some(_), None) => stack.push(a),
                        (None, Some(_)) => stack.push(b),
                        (None, None) => {}
                    }
                }
                NodeKind::Leaf => {
                    stats.triangles_tested += 1;
                    let id = n.index();
                    if let Some((t, u, v)) = rd.hit_triangle(&self.tri(id), ray.t_min, t_max(best))
                    {
                        let hit = Hit {
                            triangle: id,
                            t,
                            u,
                            v,
                            instance,
                        };
                        if accept(&hit) {
                            *best = Some(hit);
                            if ANY {
                                return true;
                            }
                        }
                    }
                }
                NodeKind::Instance => {
                    let inst = &self.instances[n.index() as usize];
                    let local = ray
                        .transformed(&inst.inverse)
                        .with_range(ray.t_min, t_max(best));
                    if self.traverse::<ANY, F>(inst.root, &local, n.index(), best, stats, accept)
                        && ANY
                    {
                        return true;
                    }
                }
                NodeKind::None => {}
            }
        }
        best.is_some()
    }

    /// Ids of live triangles whose world-space bounding boxes overlap `query`, appended to `out` (a
    /// triangle shared by several groups once for each instance that places it there).
    pub fn overlapping_triangles(&self, query: &Aabb, out: &mut Vec<u32>) {
        self.overlap_in(self.root, None, query, out);
    }

    /// Inside an instance (`xf` = object to world) every node box is tested after transforming it to
    /// world space: that box contains the world boxes of all triangles below, so nothing is missed.
    fn overlap_in(
        &self,
        root: NodeRef,
        xf: Option<&glam::Affine3A>,
        query: &Aabb,
        out: &mut Vec<u32>,
    ) {
        if root.is_none() {
            return;
        }
        let mut stack = NodeStack::new();
        stack.push(root);
        while let Some(n) = stack.pop() {
            let b = self.aabb(n);
            let world = match (xf, n.kind()) {
                (Some(t), NodeKind::Leaf) => self.tri(n.index()).transformed(t).aabb(),
                (Some(t), _) => b.transformed(t),
                (None, _) => b,
            };
            if !world.overlaps(query) {
                continue;
            }
            match n.kind() {
                NodeKind::Inner => {
                    let [a, b] = self.inner[n.index() as usize].children;
                    stack.push(a);
                    stack.push(b);
                }
                NodeKind::Leaf => out.push(n.index()),
                NodeKind::Instance => {
                    let inst = &self.instances[n.index() as usize];
                    self.overlap_in(inst.root, Some(&inst.transform), query, out);
                }
                NodeKind::None => {}
            }
        }
    }

    /// The nearest hit by testing every live triangle, once for each group that places it: the
    /// independent reference the tests hold the traversal to, exactly. Each triangle is tested
    /// in the space the traversal meets it in (a kept-whole group's in object space, against
    /// the ray carried there by its instance, as the traversal carries it), so a hit must agree
    /// to the last bit; no box is consulted. Of hits at the same distance the first found is
    /// kept (see [`Bvh::hit_at`] to tell a tie).
    pub fn brute_force_closest_hit(&self, ray: &Ray) -> Option<Hit> {
        let mut best: Option<Hit> = None;
        let rd = RayData::new(ray);
        for id in self.world_triangles() {
            let t_max = best.map_or(ray.t_max, |h| h.t);
            if let Some((t, u, v)) = rd.hit_triangle(&self.tri(id), ray.t_min, t_max)
                && best.is_none_or(|b| t < b.t)
            {
                best = Some(Hit {
                    triangle: id,
                    t,
                    u,
                    v,
                    instance: NONE,
                });
            }
        }
        for i in 0..self.instances.len() as u32 {
            let Some((local, tris)) = self.instance_ray(i, ray) else {
                continue;
            };
            let lrd = RayData::new(&local);
            for id in tris {
                let t_max = best.map_or(ray.t_max, |h| h.t);
                if let Some((t, u, v)) = lrd.hit_triangle(&self.tri(id), ray.t_min, t_max)
                    && best.is_none_or(|b| t < b.t)
                {
                    best = Some(Hit {
                        triangle: id,
                        t,
                        u,
                        v,
                        instance: i,
                    });
                }
            }
        }
        best
    }

    /// The distance at which `ray` meets triangle `triangle` placed by `instance` ([`NONE`]: in
    /// world space), tested as the traversal tests it; `None` if it misses or is not placed so.
    /// Two hits at one distance are a tie: either is the nearest.
    pub fn hit_at(&self, ray: &Ray, triangle: u32, instance: u32) -> Option<f32> {
        let tri = self.triangle(triangle)?;
        let local = if instance == NONE {
            self.world_triangles()
                .any(|id| id == triangle)
                .then_some(*ray)?
        } else {
            let (local, tris) = self.instance_ray(instance, ray)?;
            tris.iter().any(|t| t == triangle).then_some(local)?
        };
        RayData::new(&local)
            .hit_triangle(&tri, ray.t_min, ray.t_max)
            .map(|(t, _, _)| t)
    }

    /// Live triangles stored in world space (not those a kept-whole group's instances place).
    fn world_triangles(&self) -> impl Iterator<Item = u32> + '_ {
        (0..self.tri.parent.len() as u32).filter(|&id| {
            let Some(&g) = self.tri.group.get(id as usize) else {
                return false;
            };
            // Triangles kept whole are placed by the instances (a retired owner's by its users').
            let whole = g != NONE
                && (self.groups[g as usize].instance != NONE || self.groups[g as usize].retired);
            !whole && self.triangle(id).is_some()
        })
    }

    /// Live instance `i`: `ray` carried into its object space as the traversal carries it, and
    /// the triangles it places.
    fn instance_ray(&self, i: u32, ray: &Ray) -> Option<(Ray, &TriangleIds)> {
        let inst = self.instance(i)?;
        let g = &self.groups[inst.group as usize];
        let owner = if g.source != NONE {
            g.source
        } else {
            inst.group
        };
        let local = ray
            .transformed(&self.instances[i as usize].inverse)
            .with_range(ray.t_min, ray.t_max);
        Some((local, &self.groups[owner as usize].triangles))
    }

    /// Ids of live triangles whose world boxes overlap `query`, by testing every one (a shared
    /// triangle once for each instance that places it there).
    pub fn brute_force_overlapping(&self, query: &Aabb) -> Vec<u32> {
        self.placed_triangles()
            .filter(|(t, _, _)| t.aabb().overlaps(query))
            .map(|(_, id, _)| id)
            .collect()
    }

    /// Every triangle as placed in world space, with its id and the instance placing it: triangles
    /// stored in world space once, and the triangles under each instance once per instance.
    fn placed_triangles(&self) -> impl Iterator<Item = (Triangle, u32, u32)> + '_ {
        let world = (0..self.tri.parent.len() as u32).filter_map(|id| {
            let g = *self.tri.group.get(id as usize)?;
            // Triangles kept whole are placed by the instances below (a retired owner's by its users').
            let whole = g != NONE
                && (self.groups[g as usize].instance != NONE || self.groups[g as usize].retired);
            (!whole).then(|| self.triangle(id).map(|t| (t, id, NONE)))?
        });
        let placed = (0..self.instances.len() as u32).flat_map(move |i| {
            let inst = self.instance(i);
            let tris = inst.map(|inst| {
                let g = &self.groups[inst.group as usize];
                let owner = if g.source != NONE {
                    g.source
                } else {
                    inst.group
                };
                &self.groups[owner as usize].triangles
            });
            tris.into_iter().flatten().map(move |id| {
                let inst = &self.instances[i as usize];
                (self.tri(id).transformed(&inst.transform), id, i)
            })
        });
        world.chain(placed)
    }
}
