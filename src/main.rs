//! `treelight [SCENE_FILE] [--screenshot PATH --frames N]`

use clap::Parser;

fn main() -> std::process::ExitCode {
    let cli = treelight::cli::Cli::parse();
    match treelight::build_app(&cli).run() {
        bevy::app::AppExit::Success => std::process::ExitCode::SUCCESS,
        bevy::app::AppExit::Error(code) => std::process::ExitCode::from(code.get()),
    }
}
