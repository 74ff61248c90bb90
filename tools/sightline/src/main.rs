//! The `sightline` binary: a thin layer over [`sightline::cli`].

fn main() {
    std::process::exit(sightline::cli::main());
}
