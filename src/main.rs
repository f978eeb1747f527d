//! `magswarm`: the command-line face of the library crates. The arguments of every command and
//! the dispatch live in [`cli`] (binary-only: no library sees a clap type); this file installs
//! the logger, parses and exits with its code.

mod cli;
mod outputs;

use std::io::Write;

use clap::Parser;

fn main() {
    // The library crates report through `log` (warnings about skipped rows, what packaging
    // builds, ...); print them on stderr as the program's own messages. Level from
    // $MAGSWARM_LOG (error, warn, info (default), debug, trace).
    env_logger::Builder::new()
        .filter_level(log::LevelFilter::Info)
        .parse_env(env_logger::Env::new().filter("MAGSWARM_LOG"))
        .format(|buf, r| {
            let level = match r.level() {
                log::Level::Warn => "warning".to_string(),
                l => l.as_str().to_ascii_lowercase(),
            };
            writeln!(buf, "magswarm: {level}: {}", r.args())
        })
        .init();
    let cli = cli::Cli::parse();
    std::process::exit(cli::main(&cli));
}
