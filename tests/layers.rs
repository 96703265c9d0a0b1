//! The shell's modules form no circle: no two of them name each other, even through others.

#[test]
fn no_shell_modules_form_a_circle() {
    treelight_fence::assert_no_circles(
        std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/src/editor")),
        "editor",
    );
}
