//! The settings reader, fuzzed under a counting allocator: mutations of a real settings file
//! (bytes flipped, brackets nested, tabs repeated, the text cut short) never panic, answer
//! within seconds and stay within a small memory bound; a file it cannot use is refused with
//! the reason, and a layout it reads is one egui_dock can draw.

use std::time::{Duration, Instant};
use treelight::editor::workspace::settings::read_settings;
use treelight_test_support::{Xorshift, counting};

#[global_allocator]
static ALLOCATOR: counting::Counting = counting::Counting;

#[test]
fn mutated_settings_never_panic_hang_or_take_much_memory() {
    let dir = std::env::temp_dir().join(format!("treelight-settings-fuzz-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("settings.ron");
    treelight::editor::workspace::settings::write_default_settings(&path).unwrap();
    let base = std::fs::read_to_string(&path).unwrap();
    let mut rng = Xorshift(0x2545_F491_4F6C_DD1D);
    let mut read = 0;
    for k in 0..600 {
        let mut bytes = base.clone().into_bytes();
        match rng.below(4) {
            0 => {
                for _ in 0..1 + rng.below(6) {
                    let at = rng.below(bytes.len());
                    bytes[at] = rng.next_u64() as u8;
                }
            }
            1 => {
                let at = rng.below(bytes.len());
                bytes.splice(at..at, "(".repeat(1 + rng.below(50_000)).into_bytes());
            }
            2 => {
                let at = bytes.len() / 2 + rng.below(bytes.len() / 2);
                let tabs = ["Viewport, ", "Outliner, ", "Leaf((tabs: [History])), "][rng.below(3)];
                bytes.splice(at..at, tabs.repeat(1 + rng.below(20_000)).into_bytes());
            }
            _ => bytes.truncate(rng.below(bytes.len())),
        }
        std::fs::write(&path, &bytes).unwrap();
        let start = Instant::now();
        let (result, peak) = counting::peak_during(|| {
            std::panic::catch_unwind(|| read_settings(&path)).expect("the reader panicked")
        });
        assert!(peak < 64 << 20, "case {k}: {peak} bytes at the peak");
        assert!(start.elapsed() < Duration::from_secs(5), "case {k}");
        if let Ok(Some(settings)) = result {
            read += 1;
            // What it read is a layout egui_dock draws: every panel once.
            let tabs: Vec<_> = settings.layout.iter_all_tabs().map(|(_, t)| *t).collect();
            assert_eq!(
                tabs.len(),
                treelight::editor::core::layout::EditorTab::ALL.len()
            );
        }
    }
    assert!(read > 0, "no mutation was still a settings file");
    std::fs::remove_dir_all(&dir).ok();
}
