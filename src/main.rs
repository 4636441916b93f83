//! The `trussmesh` command line (see docs/cli.md).

mod cli;

fn main() {
    std::process::exit(cli::main());
}
