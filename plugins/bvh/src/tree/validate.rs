//! Structural validation: every invariant the edits must keep, checked in one pass.

use crate::tree::node::{FREE, NONE, NodeKind, NodeRef};
use crate::{Aabb, Bvh};

impl Bvh {
    /// Every live group's triangles name corners within its vertices, and a baked group's
    /// object-space copy, if kept, holds one vertex for each of them: checked before anything
    /// reads a triangle through its corners.
    fn validate_corners(&self) -> Result<(), String> {
        for (gi, g) in self.groups.iter().enumerate().filter(|(_, g)| g.is_alive()) {
            let n = g.vertices.len() as u32;
            for t in g.triangle_ids() {
                match self.tri.corners.checked(t as usize) {
                    Some(c) if c.iter().all(|&i| i < n) => {}
                    c => {
                        return Err(format!(
                            "triangle {t} of group {gi} has corners {c:?} past its {n} vertices"
                        ));
                    }
                }
            }
            if !g.object.is_empty() && g.object.len() != g.vertices.len() {
                return Err(format!(
                    "group {gi} keeps {} object-space vertices for {n}",
                    g.object.len()
                ));
            }
        }
        Ok(())
    }

    /// Checks every invariant: each live triangle in exactly one leaf and no dead one in any; parent and
    /// child links agree; every box contains its children (and a leaf's box is its triangle's); no
    /// NaN; no live node unreachable; groups and instances consistent (each triangle's corners
    /// within its group's vertices, an object-space copy as long as them). Returns the first
    /// violation.
    pub fn validate(&self) -> Result<(), String> {
        self.validate_corners()?;
        let mut seen_tri = vec![0u8; self.tri.parent.len()];
        let mut seen_inner = vec![false; self.inner.len()];
        let mut seen_inst = vec![false; self.instances.len()];
        if !self.root.is_none() {
            if self.parent(self.root) != NONE {
                return Err(format!("root {:?} has a parent", self.root));
            }
            self.validate_subtree(
                self.root,
                &mut seen_tri,
                &mut seen_inner,
                &mut seen_inst,
                false,
            )?;
        }
        for (t, &count) in seen_tri.iter().enumerate() {
            let live = self.tri.parent[t] != FREE;
            match (live, count) {
                (true, 1) | (false, 0) => {}
                (true, c) => return Err(format!("live triangle {t} is in {c} leaves")),
                (false, c) => return Err(format!("freed triangle {t} is in {c} leaves")),
            }
        }
        for (i, n) in self.inner.iter().enumerate() {
            if (n.parent != FREE) != seen_inner[i] {
                return Err(format!(
                    "inner node {i} is live={} but reachable={}",
                    n.parent != FREE,
                    seen_inner[i]
                ));
            }
        }
        for (i, inst) in self.instances.iter().enumerate() {
            if (inst.group != FREE) != seen_inst[i] {
                return Err(format!(
                    "instance {i} is live={} but reachable={}",
                    inst.group != FREE,
                    seen_inst[i]
                ));
            }
        }
        if self.tri.live as usize != seen_tri.iter().filter(|&&c| c == 1).count() {
            return Err("live triangle count is off".into());
        }
        let mut users = vec![0u32; self.groups.len()];
        for (gi, g) in self.groups.iter().enumerate().filter(|(_, g)| g.is_alive()) {
            for t in g.triangle_ids() {
                if self.tri.group[t as usize] != gi as u32 {
                    return Err(format!("triangle {t} of group {gi} names another group"));
                }
            }
            if g.source != NONE {
                let Some(owner) = self.groups.get(g.source as usize).filter(|o| o.is_alive())
                else {
                    return Err(format!("group {gi} shares the triangles of a dead group"));
                };
                if owner.source != NONE || !g.triangle_ids().is_empty() || g.instance == NONE {
                    return Err(format!(
                        "group {gi} shares triangles but is not an instance"
                    ));
                }
                users[g.source as usize] += 1;
            }
            if g.retired && g.instance != NONE {
                return Err(format!("removed group {gi} is still in the tree"));
            }
        }
        for (gi, g) in self.groups.iter().enumerate().filter(|(_, g)| g.is_alive()) {
            if g.users != users[gi] || (g.retired && g.users == 0) {
                return Err(format!(
                    "group {gi} counts {} users, {} share its triangles",
                    g.users, users[gi]
                ));
            }
        }
        Ok(())
    }

    fn validate_subtree(
        &self,
        root: NodeRef,
        seen_tri: &mut [u8],
        seen_inner: &mut [bool],
        seen_inst: &mut [bool],
        in_instance: bool,
    ) -> Result<(), String> {
        let mut stack = vec![root];
        while let Some(n) = stack.pop() {
            let i = n.index() as usize;
            match n.kind() {
                NodeKind::Inner => {
                    let node = self
                        .inner
                        .get(i)
                        .ok_or(format!("inner node {i} out of range"))?;
                    if node.parent == FREE {
                        return Err(format!("freed inner node {i} is in the tree"));
                    }
                    if std::mem::replace(&mut seen_inner[i], true) {
                        return Err(format!("inner node {i} is reached twice"));
                    }
                    check_box(&node.aabb, &format!("inner node {i}"))?;
                    for c in node.children {
                        if c.is_none() {
                            return Err(format!("inner node {i} lacks a child"));
                        }
                        if self.parent(c) != i as u32 {
                            return Err(format!(
                                "child {c:?} of {i} names parent {}",
                                self.parent(c)
                            ));
                        }
                        if !node.aabb.contains_box(&self.aabb(c), 1e-6) {
                            return Err(format!("inner node {i} does not contain child {c:?}"));
                        }
                        stack.push(c);
                    }
                }
                NodeKind::Leaf => {
                    if i >= self.tri.parent.len() || self.tri.parent[i] == FREE {
                        return Err(format!("leaf of dead triangle {i}"));
                    }
                    seen_tri[i] = seen_tri[i].saturating_add(1);
                    check_box(&self.tri(i as u32).aabb(), &format!("triangle {i}"))?;
                }
                NodeKind::Instance => {
                    if in_instance {
                        return Err("instance inside an instance".into());
                    }
                    let inst = self
                        .instances
                        .get(i)
                        .ok_or(format!("instance {i} out of range"))?;
                    if inst.group == FREE {
                        return Err(format!("freed instance {i} is in the tree"));
                    }
                    if std::mem::replace(&mut seen_inst[i], true) {
                        return Err(format!("instance {i} is reached twice"));
                    }
                    check_box(&inst.aabb, &format!("instance {i}"))?;
                    if self.parent(inst.root) != NONE {
                        return Err(format!("object root of instance {i} has a parent"));
                    }
                    let world = self.aabb(inst.root).transformed(&inst.transform);
                    if !inst.aabb.contains_box(&world, 1e-5) {
                        return Err(format!("instance {i} box does not contain its subtree"));
                    }
                    // Groups that share triangles share one subtree: it is checked once.
                    let r = inst.root.index() as usize;
                    let seen = match inst.root.kind() {
                        NodeKind::Inner => seen_inner.get(r).copied().unwrap_or(false),
                        NodeKind::Leaf => seen_tri.get(r).is_some_and(|&c| c > 0),
                        _ => false,
                    };
                    if !seen {
                        self.validate_subtree(inst.root, seen_tri, seen_inner, seen_inst, true)?;
                    }
                }
                NodeKind::None => return Err("null reference in the tree".into()),
            }
        }
        Ok(())
    }
}

fn check_box(b: &Aabb, what: &str) -> Result<(), String> {
    if !b.is_finite() || b.is_empty() {
        return Err(format!("{what} has a bad box {b:?}"));
    }
    Ok(())
}
