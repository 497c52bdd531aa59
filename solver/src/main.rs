//! `dea-mpi`: the digital-element ballistic impact solver's command line (`cli/`).

mod cli;

use std::process::ExitCode;

use clap::Parser;

fn main() -> ExitCode {
    // a closed pipe (`dea-mpi check case.json | head`) ends the process quietly, as it does
    // any Unix tool, rather than with a panic at the next print
    // SAFETY: the action only calls emulate_default_handler, which is async-signal-safe
    let _ = unsafe {
        signal_hook::low_level::register(signal_hook::consts::SIGPIPE, || {
            let _ = signal_hook::low_level::emulate_default_handler(signal_hook::consts::SIGPIPE);
        })
    };
    let cli = cli::Cli::parse();
    // a RUST_LOG that cannot be read is a usage error, found before any rank starts work
    if let Err(e) = dea_mpi::progress::log_filter() {
        eprintln!("error: {e}");
        return ExitCode::from(2);
    }
    dea_mpi::progress::set_verbosity(i32::from(cli.verbose) - i32::from(cli.quiet));
    cli.command.main()
}
