//! Prints a crate folder's upward paths and circles: `look SRC PREFIX LAYER...`.
fn main() {
    let a: Vec<String> = std::env::args().skip(1).collect();
    let g = treelight_fence::ModuleGraph::read(std::path::Path::new(&a[0]), &a[1]);
    let layers: Vec<&str> = a[2..].iter().map(String::as_str).collect();
    for (m, n) in g.upward(&layers) {
        println!("upward: {m} -> {n}");
    }
    for c in g.circles() {
        println!("circle: {c:?}");
    }
}
