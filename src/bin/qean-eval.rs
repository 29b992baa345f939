//! `qean-eval`: the metrics alone, the same as `qean eval`; all logic lives in `qean::eval_cli`.

use clap::Parser;

#[derive(Parser)]
#[command(
    name = "qean-eval",
    version,
    about = "AIST++ dance metrics: FID_k, FID_g, Dist_k, Dist_g, BeatAlign"
)]
struct Cli {
    #[command(flatten)]
    args: qean::eval_cli::Args,
    /// More logging (-v info, -vv debug).
    #[arg(short, long, action = clap::ArgAction::Count)]
    verbose: u8,
}

fn main() {
    qean_models::backend::prefer_cpu_default_device();
    let cli = Cli::parse();
    qean::logging::init(cli.verbose);
    match qean::eval_cli::run_eval(&cli.args) {
        Ok(table) => print!("{table}"),
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::exit(1);
        }
    }
}
