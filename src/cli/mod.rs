//! Command-line parsing and dispatch. Each subcommand lives in its own file and calls library code.

use clap::{Parser, Subcommand};

mod bench_cmd;
mod data_cmds;
mod demo_cmd;
mod edit_cmds;
mod features_cmd;
mod sample_cmd;
mod train_cmds;
mod view_cmd;

#[derive(Parser, Debug)]
#[command(
    name = "qean",
    version,
    about = "Music-conditioned 3D dance generation: FACT and QEAN, AIST++ data, librosa-exact features, metrics",
    long_about = "Music-conditioned 3D dance generation: FACT (Li et al., ICCV 2021) and QEAN (Zhou et al.), \
with AIST++ data handling, librosa-0.8.1-exact music features and the standard AIST++ metrics.\n\n\
Start with `qean demo --quick`: the whole system on embedded data in a few minutes."
)]
pub struct Cli {
    /// More log output (-v info, -vv debug). Logs go to stderr; QEAN_LOG=... (or RUST_LOG) overrides.
    #[arg(short, long, action = clap::ArgAction::Count, global = true)]
    pub verbose: u8,
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    Synth(data_cmds::SynthArgs),
    Features(features_cmd::FeaturesArgs),
    Inspect(data_cmds::InspectArgs),
    CheckData(data_cmds::CheckDataArgs),
    Joints(data_cmds::JointsArgs),
    Render(data_cmds::RenderArgs),
    Convert(data_cmds::ConvertArgs),
    View(view_cmd::ViewArgs),
    Keyframes(edit_cmds::KeyframesArgs),
    Edit(edit_cmds::EditArgs),
    Train(train_cmds::TrainArgs),
    Sweep(train_cmds::SweepArgs),
    Report(train_cmds::ReportArgs),
    Export(train_cmds::ExportArgs),
    Sample(Box<sample_cmd::SampleArgs>),
    Eval(Box<qean::eval_cli::Args>),
    Curves(qean::eval_cli::CurvesArgs),
    Demo(demo_cmd::DemoArgs),
    Bench(bench_cmd::BenchArgs),
}

pub fn init_logging(verbose: u8) {
    qean::logging::init(verbose);
}

/// Runs a command; the value is the process exit code (130 when a run was interrupted).
pub fn run(cli: Cli) -> anyhow::Result<i32> {
    match cli.command {
        Command::Train(a) => train_cmds::train(a),
        Command::Sweep(a) => train_cmds::sweep(a),
        Command::Report(a) => train_cmds::report(a),
        Command::Export(a) => train_cmds::export(a),
        Command::Sample(a) => sample_cmd::sample(*a),
        Command::Demo(a) => demo_cmd::demo(a),
        other => run_data(other).map(|()| 0),
    }
}

fn run_data(command: Command) -> anyhow::Result<()> {
    match command {
        Command::Synth(a) => data_cmds::synth(a),
        Command::Features(a) => features_cmd::features(a),
        Command::Inspect(a) => {
            let ext = qean_io::fsutil::extension_lower(&a.path);
            if matches!(ext.as_str(), "wav" | "ogg" | "mp3" | "flac") {
                features_cmd::inspect_audio(&a.path)
            } else if a
                .path
                .join(qean_checkpoint::checkpoint::STATE_FILE)
                .is_file()
            {
                train_cmds::inspect_checkpoint(&a.path)
            } else if a.path.join("config.toml").is_file() && a.path.join("metrics.csv").is_file() {
                train_cmds::inspect_run(&a.path)
            } else if ext == "toml" {
                let i = qean_models::inspect::inspect(&a.path)?;
                print!("{}", i.summary);
                println!(
                    "parameter count: {}",
                    qean_models::inspect::group_digits(i.params)
                );
                Ok(())
            } else {
                data_cmds::inspect(a)
            }
        }
        Command::Bench(a) => bench_cmd::bench(a),
        Command::CheckData(a) => data_cmds::check_data(a),
        Command::Joints(a) => data_cmds::joints(a),
        Command::Render(a) => data_cmds::render(a),
        Command::Convert(a) => data_cmds::convert(a),
        Command::View(a) => view_cmd::view(a),
        Command::Keyframes(a) => edit_cmds::keyframes(a),
        Command::Edit(a) => edit_cmds::edit(a),
        Command::Eval(a) => {
            print!("{}", qean::eval_cli::run_eval(&a)?);
            Ok(())
        }
        Command::Curves(a) => {
            print!("{}", qean::eval_cli::run_curves(&a)?);
            println!("figure: {}", a.out.join("curves.png").display());
            Ok(())
        }
        Command::Train(_)
        | Command::Sweep(_)
        | Command::Report(_)
        | Command::Export(_)
        | Command::Sample(_)
        | Command::Demo(_) => {
            unreachable!("dispatched in run")
        }
    }
}
