//! `qean-eval`: the metrics binary; all logic lives in `qean_eval::cli`.

use clap::Parser;

fn main() {
    let args = qean_eval::cli::Args::parse();
    qean_eval::cli::init_logging(args.verbose);
    match qean_eval::cli::run(&args) {
        Ok((_, table)) => print!("{table}"),
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::exit(1);
        }
    }
}
