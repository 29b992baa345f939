//! `qean demo`: the whole system end to end on embedded data.

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;
use qean_checkpoint::ProgressMode;
use qean_pipeline::demo::{self, Budget, DemoOptions};

/// Run everything on embedded data, with nothing to download: a synthetic AIST++-format dataset whose
/// music includes two real recordings; tiny FACT and full-QEAN, a small TSMT (Li et al.), a tiny VQ-VAE +
/// GPT with its genre- and keyframe-control stages trained on CPU, side by side; a 1200-frame dance for a
/// held-out real song (Kevin MacLeod's "Vibe Ace", CC BY 3.0) from each (genre control: in two genres;
/// keyframe control: through two poses of a test dance), with a preview
/// and a verdict (does it keep dancing?); every model scored (FID_k, FID_g, Dist_k, Dist_g, BeatAlign,
/// Li et al.'s metrics) next to chance baselines; the genre classifier and genre control's accuracy with
/// their confusion matrices; keyframe control's joint error at the keyframes with and without them; then a
/// test dance cut to 5 keys per measure and rebuilt by SLERP and by a
/// tiny in-betweener. About 16–20 minutes on 2 CPU cores (`--quick`: about 1). Run it again to reuse
/// finished stages; Ctrl-C stops training with a checkpoint and the next run continues.
///
/// Example: qean demo --quick
#[derive(Args, Debug)]
#[command(about = "Run the whole system on embedded data (start here: qean demo --quick)")]
pub struct DemoArgs {
    /// Output directory (default: qean-demo, or qean-demo-quick with --quick).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// A smaller, shorter demo (about 1 minute): a smoke test, too short for the dances to be trusted.
    #[arg(long)]
    pub quick: bool,
    /// Train on data whose genres show: each genre holds its posture and its music plays its own riff
    /// (`qean synth --genre-postures --genre-music`). The genre judge then reaches 0.95, but the other
    /// models stop dancing on real songs, which carry no riff (measured in docs/control.md).
    #[arg(long)]
    pub genre_data: bool,
    /// Plain progress lines instead of bars.
    #[arg(long)]
    pub plain: bool,
}

pub fn demo(a: DemoArgs) -> anyhow::Result<i32> {
    let out = a.out.clone().unwrap_or_else(|| {
        PathBuf::from(if a.quick {
            "qean-demo-quick"
        } else {
            "qean-demo"
        })
    });
    let opts = DemoOptions {
        out,
        budget: Budget {
            genre_data: a.genre_data,
            ..Budget::new(a.quick)
        },
        stop: super::train_cmds::stop_flag(),
        progress: if a.plain {
            ProgressMode::Lines
        } else {
            ProgressMode::Auto
        },
        exe: std::env::current_exe().context("cannot find the qean executable")?,
    };
    let r = demo::run(&opts)?;
    if !r.finished {
        return Ok(130);
    }
    println!("{}", r.table);
    println!("artefacts:");
    println!("  dataset: {}", r.dataset.display());
    for m in &r.models {
        println!("  {}:", m.label);
        println!("    checkpoint: {}", m.checkpoint.display());
        println!("    report: {}", m.report_md.display());
        for p in m.dances.iter().flat_map(|d| &d.files) {
            println!("    dance: {}", p.display());
        }
    }
    if let Some(ib) = &r.inbetween {
        println!("  in-betweening ({}):", ib.sequence);
        println!("    checkpoint: {}", ib.checkpoint.display());
        for row in &ib.rows {
            for p in &row.files {
                println!("    {}: {}", row.label, p.display());
            }
        }
    }
    println!("  summary: {}", r.summary.display());
    Ok(0)
}
