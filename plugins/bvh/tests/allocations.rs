//! The engine's hot loops allocate nothing: a counting global allocator watches insertion (search,
//! linking, refit, the node update cache and its update batches, with and without treelets), removal, traversal, the sliced
//! post-pass and box queries on a warmed-up tree. A call may allocate a constant number of times (the
//! ids it returns, an array doubling); what must not happen is an allocation per triangle, per node
//! or per ray. One test per binary, so no other test's allocations are counted.

mod support;
use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};
use support::*;
use treelight_bvh::glam::Vec3;
use treelight_bvh::{Aabb, Bvh, BvhConfig, OptimizeCursor, SearchScratch};

struct Counting;

static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);
static BYTES: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        BYTES.fetch_add(layout.size(), Ordering::Relaxed);
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        BYTES.fetch_add(new_size, Ordering::Relaxed);
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// Bytes allocated (or reallocated to) while `f` runs.
fn bytes(f: impl FnOnce()) -> usize {
    let before = BYTES.load(Ordering::Relaxed);
    f();
    BYTES.load(Ordering::Relaxed) - before
}

fn allocations(f: impl FnOnce()) -> usize {
    let before = ALLOCATIONS.load(Ordering::Relaxed);
    f();
    ALLOCATIONS.load(Ordering::Relaxed) - before
}

#[test]
fn hot_loops_allocate_nothing_per_item() {
    // A small update cache so that update batches run during the measured insertions.
    let mut bvh = Bvh::new(BvhConfig {
        update_cache_size: 200,
        ..BvhConfig::default()
    });
    bvh.insert_triangles(&soup(20_000, 1)).unwrap();
    let extra = soup(2_000, 2);
    let rays = rays(2_000, 3, 10.0);
    // Warm up every path once, and make room: array growth is amortised, not per item.
    let ids = bvh.insert_triangles(&extra).unwrap();
    bvh.remove_triangles(&ids).unwrap();
    for r in &rays {
        bvh.closest_hit(r);
        bvh.any_hit(r);
    }
    let mut cursor = OptimizeCursor::default();
    bvh.optimize_step(&mut cursor, 4096, 0.05);
    let mut scratch = SearchScratch::default();
    let mut found = Vec::with_capacity(30_000);
    let query = Aabb::new(Vec3::splat(-2.0), Vec3::splat(2.0));
    bvh.overlapping_triangles(&query, &mut found);

    // Each measured call handles 2000 items; "a few" allocations per call is the bound.
    const FEW: usize = 16;
    let mut ids = Vec::new();
    let n = allocations(|| ids = bvh.insert_triangles(&extra).unwrap());
    assert!(n <= FEW, "inserting 2000 triangles allocated {n} times");
    let n = allocations(|| bvh.remove_triangles(&ids).unwrap());
    assert!(n <= FEW, "removing 2000 triangles allocated {n} times");
    let n = allocations(|| {
        for r in &rays {
            std::hint::black_box(bvh.closest_hit(r));
        }
    });
    assert!(n <= FEW, "2000 closest-hit rays allocated {n} times");
    let n = allocations(|| {
        for r in &rays {
            std::hint::black_box(bvh.any_hit(r));
        }
    });
    assert!(n <= FEW, "2000 any-hit rays allocated {n} times");
    let n = allocations(|| {
        for t in &extra {
            std::hint::black_box(bvh.find_best_sibling(&t.aabb(), &mut scratch));
        }
    });
    assert!(n <= FEW, "2000 searches allocated {n} times");
    let n = allocations(|| {
        for _ in 0..20 {
            bvh.optimize_step(&mut cursor, 4096, 0.05);
        }
    });
    assert!(n <= FEW, "20 optimize steps allocated {n} times");
    let n = allocations(|| {
        found.clear();
        bvh.overlapping_triangles(&query, &mut found);
    });
    assert!(n <= FEW, "a box query allocated {n} times");
    bvh.validate().unwrap();

    let mut ids = Vec::new();

    // A small edit right after a large build: with room reserved it copies none of the tree's
    // arrays (growing them would move megabytes: 50k triangles are ~3.4 MB of triangle data).
    let mut bvh = Bvh::new(BvhConfig::default());
    bvh.insert_triangles(&soup(50_000, 4)).unwrap();
    let edit = soup(200, 5);
    bvh.reserve(edit.len());
    let b = bytes(|| ids = bvh.insert_triangles(&edit).unwrap());
    assert!(
        b < 64 << 10,
        "a reserved 200-triangle insertion allocated {b} bytes"
    );
    bvh.validate().unwrap();
}
