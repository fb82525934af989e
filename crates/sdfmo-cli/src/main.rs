//! `sdfmo`: the command-line tool of sdf-multioctree.
//!
//! Every command prints a short human summary, or with `--json` exactly one JSON object on
//! stdout. Errors are one line on stderr (the whole cause chain, `{:#}`, each cause once) and
//! exit code 2, out of memory included; a dataset sweep that recorded failed models exits with
//! 3 after writing everything; a
//! closed stdout (broken pipe, e.g. `sdfmo distance … | head`) counts as success. Long work shows
//! a progress bar on stderr only when stderr is a terminal.
//!
//! The library work lives in the layers (re-exported by the `sdf-multioctree` facade); this
//! binary parses arguments, reads and writes files and formats the results.

mod alloc;
mod args;
mod commands;
mod output;

// The harness's bars, as `crate::progress` for the commands.
use sdfmo_harness::progress;

use std::io::Write;
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};

use clap::Parser;

use crate::args::{Cli, Command};

#[global_allocator]
static ALLOCATOR: alloc::ExitOnOom = alloc::ExitOnOom;

/// Exit code of a failed command (bad input, I/O error, …).
const EXIT_ERROR: u8 = 2;
/// Exit code after SIGINT, SIGTERM or SIGHUP (128 + SIGINT, as shells report it).
const EXIT_INTERRUPTED: i32 = 130;

/// Set by the interrupt handler before it removes the temporaries and exits.
static INTERRUPTED: AtomicBool = AtomicBool::new(false);

/// Exit code of an internal bug (a panic in a layer): `EX_SOFTWARE` of sysexits.h.
const EXIT_BUG: u8 = 70;

/// Without `XDG_RUNTIME_DIR` no Wayland display can be reached, yet the Vulkan loader's
/// window-system probe under `--device gpu` asks libwayland for one, which prints "error:
/// XDG_RUNTIME_DIR is invalid or not set in the environment." twice and breaks the CLI's
/// one-line errors. An absolute `WAYLAND_DISPLAY` that cannot exist makes the probe fail
/// silently; it changes nothing else (no Wayland connection was possible). Runs first in `main`,
/// before any thread exists, so setting the variable races with nothing.
fn quiet_wayland_probe() {
    if std::env::var_os("XDG_RUNTIME_DIR").is_none()
        && std::env::var_os("WAYLAND_DISPLAY").is_none()
    {
        std::env::set_var("WAYLAND_DISPLAY", "/nonexistent/sdfmo-no-wayland-display");
    }
}

fn main() -> ExitCode {
    quiet_wayland_probe();
    // A panic is a bug in sdfmo, never the user's fault: report it on one line without a
    // backtrace, and exit with a distinct code.
    std::panic::set_hook(Box::new(|info| {
        let payload = info.payload();
        let msg = payload
            .downcast_ref::<&str>()
            .copied()
            .or_else(|| payload.downcast_ref::<String>().map(String::as_str))
            .unwrap_or("unknown cause");
        let at = info
            .location()
            .map(|l| format!(" ({}:{})", l.file(), l.line()))
            .unwrap_or_default();
        let _ = writeln!(
            std::io::stderr(),
            "sdfmo: internal error, please report it: {msg}{at}"
        );
    }));

    // Interrupted (Ctrl-C, kill, a closed terminal): remove the temporaries of a write in
    // progress, so nothing is left beside the outputs, then exit. The handler runs on a thread
    // of its own, not in signal context.
    let _ = ctrlc::set_handler(|| {
        INTERRUPTED.store(true, Ordering::SeqCst);
        sdf_multioctree::io::remove_pending_temporaries();
        let _ = writeln!(std::io::stderr(), "sdfmo: interrupted");
        std::process::exit(EXIT_INTERRUPTED);
    });

    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            // --help and --version are not errors; clap prints them itself.
            let code = if e.use_stderr() { EXIT_ERROR } else { 0 };
            let _ = e.print();
            return ExitCode::from(code);
        }
    };

    let result = std::panic::catch_unwind(move || run(cli));
    if INTERRUPTED.load(Ordering::SeqCst) {
        // The handler is removing the temporaries and will exit with 130: a command that
        // failed because its temporaries vanished must not report that failure instead.
        loop {
            std::thread::park();
        }
    }
    match result {
        Ok(Ok(())) => ExitCode::SUCCESS,
        Ok(Err(err)) if is_broken_pipe(&err) => ExitCode::SUCCESS,
        Ok(Err(err)) if err.is::<sdfmo_harness::ModelsFailed>() => {
            // A shard that ran every model but recorded failures: not an error of the command.
            let _ = writeln!(std::io::stderr(), "sdfmo: {err}");
            ExitCode::from(sdfmo_harness::EXIT_MODELS_FAILED)
        }
        Ok(Err(err)) => {
            let _ = writeln!(std::io::stderr(), "sdfmo: error: {err:#}");
            ExitCode::from(EXIT_ERROR)
        }
        Err(_) => ExitCode::from(EXIT_BUG),
    }
}

/// Runs one command.
fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Info(a) => commands::info::run(&a),
        Command::Distance(a) => commands::distance::run(&a),
        Command::Build(a) => commands::build::run(&a),
        Command::Render(a) => commands::render::run_octree(&a),
        Command::RenderMesh(a) => commands::render::run_mesh(&a),
        Command::Compare(a) => commands::compare::run(&a),
        Command::Sweep(a) => commands::sweep::run(&a),
        Command::GenerateParts(a) => commands::generate::run(&a),
    }
}

/// True when the error comes from writing to a closed pipe (the reader went away: success).
fn is_broken_pipe(err: &anyhow::Error) -> bool {
    err.chain().any(|cause| {
        cause
            .downcast_ref::<std::io::Error>()
            .is_some_and(|e| e.kind() == std::io::ErrorKind::BrokenPipe)
    })
}
