//! `qean-eval`: the metrics binary; all logic lives in `qean_eval::cli`.

use clap::Parser;

#[derive(Parser)]
#[command(
    name = "qean-eval",
    version,
    about = "AIST++ dance metrics: FID_k, FID_g, Dist_k, Dist_g, BeatAlign"
)]
struct Cli {
    #[command(flatten)]
    args: qean_eval::cli::Args,
    /// More logging (-v info, -vv debug).
    #[arg(short, long, action = clap::ArgAction::Count)]
    verbose: u8,
}

fn main() {
    qean_models::backend::prefer_cpu_default_device();
    let cli = Cli::parse();
    qean_eval::cli::init_logging(cli.verbose);
    match qean_eval::cli::run(&cli.args) {
        Ok((_, table)) => print!("{table}"),
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::exit(1);
        }
    }
}
