//! `magswarm`: the command-line face of the library. The arguments of every command and the
//! dispatch live in `magswarm::cli`; this file only parses and exits with its code.

use clap::Parser;

fn main() {
    let cli = magswarm::cli::Cli::parse();
    std::process::exit(magswarm::cli::main(&cli));
}
