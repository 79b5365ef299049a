//! The `beeswarm` binary: all logic lives in the library; this only runs the CLI.
fn main() {
    std::process::exit(beeswarm::cli::main());
}
