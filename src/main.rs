//! `treelight [SCENE_FILE] [--screenshot PATH --frames N] [--commands EDITS.ron] ...`,
//! `treelight info FILE`, `treelight render [SCENE] --out IMAGE.png --spp N` or
//! `treelight compare REFERENCE IMAGE...`.

use clap::Parser;

fn main() -> std::process::ExitCode {
    treelight::heap_trim::tune_malloc();
    let cli = treelight::cli::Cli::parse();
    if let Some(treelight::cli::Command::Info { file }) = &cli.command {
        return match treelight_document::project::info::describe(file) {
            Ok(text) => {
                print!("{text}");
                std::process::ExitCode::SUCCESS
            }
            Err(e) => {
                eprintln!("treelight: {e}");
                std::process::ExitCode::from(1)
            }
        };
    }
    if let Some(treelight::cli::Command::Compare {
        reference,
        images,
        residuals,
    }) = &cli.command
    {
        return treelight::compare::print_comparisons(reference, images, residuals.as_deref());
    }
    if let Some(treelight::cli::Command::Render(args)) = &cli.command {
        if let Err(e) = treelight::render_file::check_output(args) {
            eprintln!("treelight: {e}");
            return std::process::ExitCode::from(2);
        }
        return match treelight::render_file::render_app(args).run() {
            bevy::app::AppExit::Success => std::process::ExitCode::SUCCESS,
            bevy::app::AppExit::Error(code) => std::process::ExitCode::from(code.get()),
        };
    }
    let script = match &cli.commands {
        None => None,
        Some(path) => match treelight_document::project::script::read_commands(path) {
            Ok(commands) => Some(treelight_document::project::script::ScriptedEdits::new(
                path.clone(),
                commands,
            )),
            Err(e) => {
                eprintln!("treelight: {e}");
                return std::process::ExitCode::from(2);
            }
        },
    };
    // Saving without screenshots or a report needs no window: it runs where there is no display.
    let headless = cli.save.is_some()
        && cli.screenshot.is_none()
        && cli.frames.is_none()
        && cli.state.is_none();
    // A crash of the editor leaves its report for the next start.
    treelight::editor::files::crash_report::install_hook();
    let mut app = if headless {
        treelight_document::app::save_app(cli.scene.as_deref(), cli.save.clone(), script)
    } else {
        treelight::build_app_with(&cli, script)
    };
    match app.run() {
        bevy::app::AppExit::Success => std::process::ExitCode::SUCCESS,
        bevy::app::AppExit::Error(code) => std::process::ExitCode::from(code.get()),
    }
}
