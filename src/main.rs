//! The `nerf` command: train, evaluate, render, export and inspect NeRF
//! models, and run the whole path on the built-in scene (`nerf demo`).

/// `println!` for results on standard output that ends quietly if the
/// reader has gone (a closed pipe: `nerf eval … | head -1`) instead of
/// panicking; what a command writes to files is written before it prints.
macro_rules! out {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stdout(), $($t)*);
    }};
}

mod cmd;

use clap::{Parser, Subcommand};
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "nerf",
    version,
    about = "Small-footprint NeRF: train on the CPU, render in f32 or integer fixed point"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Train a model on a dataset (Blender, LLFF, instant-ngp or COLMAP layout; PNG or JPEG photos, and TIFF, WebP, BMP or TGA outside LLFF).
    Train(cmd::train::Args),
    /// Render a split and print PSNR, SSIM and cost as one JSON object.
    Eval(cmd::eval::Args),
    /// Render a split's views, an orbit, the capture's trajectory or a camera path to PNG (and GIF for paths).
    Render(cmd::render::Args),
    /// Write the model with 32-, 16- or 8-bit weights.
    Export(cmd::export::Args),
    /// Train and score every scene of a suite at its published protocol (the NeRF paper's table): one table
    /// and plot; one scene per --task for job arrays, --gather for the table.
    Bench(cmd::bench::Args),
    /// Try model sizes and samples per ray cheapest first; keep the fastest that reaches a target PSNR.
    Fit(cmd::fit::Args),
    /// Sweep weight bits, samples and early termination: PSNR against µs/ray.
    Tradeoff(cmd::tradeoff::Args),
    /// Describe a model file.
    Info(cmd::info::Args),
    /// Extract the density surface as a coloured triangle mesh (PLY or OBJ); print its area, volume and closure.
    Mesh(cmd::mesh::Args),
    /// Write a static web page that renders the model in the browser (WebAssembly), with orbit, zoom and timing.
    Web(cmd::web::Args),
    /// Generate the built-in scene as Blender, LLFF and COLMAP datasets (and a 360° capture with a background).
    Scene(cmd::scene::Args),
    /// From a folder of photos (or a video) to a capture `nerf train` reads: COLMAP run on the CPU, headless.
    Capture(cmd::capture::Args),
    /// The whole path on the built-in scene in a few minutes.
    Demo(cmd::demo::Args),
}

/// `nerf info M | head -1`: end like other Unix tools when the reader
/// closes the pipe (the default action of SIGPIPE, which Rust programs
/// ignore), instead of panicking in `println!`. Only for `info`, which
/// writes no files that a kill could leave half-written.
fn exit_quietly_on_closed_pipe() {
    #[cfg(unix)]
    // SAFETY: restores a signal's default action; no handler is installed
    // and nothing else in this process depends on SIGPIPE being ignored.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
}

/// Runs one subcommand.
fn dispatch(command: Command) -> cmd::CmdResult {
    cmd::interrupt::install();
    match command {
        Command::Train(a) => cmd::train::run(a),
        Command::Eval(a) => cmd::eval::run(a),
        Command::Render(a) => cmd::render::run(a),
        Command::Export(a) => cmd::export::run(a),
        Command::Info(a) => {
            exit_quietly_on_closed_pipe();
            cmd::info::run(a)
        }
        Command::Tradeoff(a) => cmd::tradeoff::run(a),
        Command::Mesh(a) => cmd::mesh::run(a),
        Command::Web(a) => cmd::web::run(a),
        Command::Fit(a) => cmd::fit::run(a),
        Command::Bench(a) => cmd::bench::run(a),
        Command::Scene(a) => cmd::scene::run(a),
        Command::Capture(a) => cmd::capture::run(a),
        Command::Demo(a) => cmd::demo::run(a),
    }
}

/// Parses the command line; a mistake in it ends the program with one line
/// on standard error naming the flag and the cause (clap's message without
/// its usage block; `--help` shows that) and exit status 2.
fn parse() -> Cli {
    match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) if e.use_stderr() => {
            let text = e.render().to_string();
            let line: Vec<&str> = text
                .lines()
                .take_while(|l| !l.starts_with("Usage:") && !l.starts_with("For more information"))
                .map(str::trim)
                .filter(|l| !l.is_empty())
                .collect();
            eprintln!("{}", line.join(" "));
            std::process::exit(2)
        }
        Err(e) => e.exit(),
    }
}

fn main() -> ExitCode {
    let cli = parse();
    match dispatch(cli.command) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
