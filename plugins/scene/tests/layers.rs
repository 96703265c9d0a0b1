//! No two of the crate's modules name each other, even through others: its topic folders stay a
//! tree of imports a reader can follow from the bottom up.

#[test]
fn no_modules_form_a_circle() {
    treelight_fence::assert_no_circles(
        std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/src")),
        "",
    );
}
