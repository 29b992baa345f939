//! `qean`: music-conditioned 3D dance generation (FACT and QEAN). A thin CLI over the workspace crates.

use clap::Parser;

mod cli;

#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

fn main() {
    let args = cli::Cli::parse();
    cli::init_logging(args.verbose);
    match cli::run(args) {
        Ok(0) => {}
        Ok(code) => std::process::exit(code),
        Err(e) => {
            // One line, naming the file and the problem; details of the chain joined by ": ".
            eprintln!("error: {e:#}");
            std::process::exit(1);
        }
    }
}
