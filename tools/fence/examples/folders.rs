//! Prints which top folders name which: `folders SRC PREFIX`.
fn main() {
    let a: Vec<String> = std::env::args().skip(1).collect();
    let g = treelight_fence::ModuleGraph::read(std::path::Path::new(&a[0]), &a[1]);
    let depth = if a[1].is_empty() { 0 } else { 1 };
    let top = |m: &str| m.split("::").nth(depth).unwrap_or("").to_string();
    let mut pairs = std::collections::BTreeMap::<(String, String), Vec<String>>::new();
    for (m, named) in &g.names {
        for n in named {
            if top(m) != top(n) {
                pairs
                    .entry((top(m), top(n)))
                    .or_default()
                    .push(format!("{m} -> {n}"));
            }
        }
    }
    for ((a, b), v) in pairs {
        println!("{a} -> {b}: {}", v.join(", "));
    }
}
