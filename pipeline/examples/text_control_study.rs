//! Does text control steer? (docs/control.md, "Text control"): a GPT trained with synthetic text dances to a
//! song from each test sequence's seed, once with music alone and once per genre with that genre's text
//! embedding over an interval; the genre classifier judges the interval's frames. Prints, per requested
//! genre, how often the verdict is that genre, beside how often the music-only dances get it.
//!
//!   cargo run --release -p qean-pipeline --example text_control_study -- \
//!       GPT_RUN CLASSIFIER_RUN DATA SONG FROM_S TO_S

use std::path::PathBuf;

use qean_aistpp::dataset::{Dataset, Split};
use qean_aistpp::names::GENRES;
use qean_checkpoint::checkpoint::resolve_in_run;
use qean_eval::run_report::SeedStart;
use qean_motion::motion::Motion;
use qean_pipeline::generate::{load_song, seed_clip, SeedSource};
use qean_pipeline::genre_clf::TrainedClf;
use qean_pipeline::gpt::{Controls, GptRun, Picking, PickingOverrides, TextEmbedding, TextRequest};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [gpt, clf, data, song, from, to] = args.as_slice() else {
        return Err("usage: GPT_RUN CLASSIFIER_RUN DATA SONG FROM_S TO_S".into());
    };
    let (from_s, to_s): (f64, f64) = (from.parse()?, to.parse()?);
    let ck = resolve_in_run(&PathBuf::from(gpt), None)?;
    let g = ck.config.gpt_table().clone();
    let run = GptRun::load(&ck)?;
    let clf = TrainedClf::load(&PathBuf::from(clf), None)?;
    let ds = Dataset::open(&PathBuf::from(data))?;
    let song = load_song(&PathBuf::from(song), None, ck.config.min_music_frames())?;
    let features = ck
        .config
        .recipe
        .model_audio(song.features.data.clone(), qean_aistpp::windows::AUDIO_DIM);
    let music = (features.as_slice(), song.features.frames);
    let picking = Picking::of(&g, &PickingOverrides::default(), 0);
    let frames = ((to_s + 2.0) * 60.0) as usize;
    let (a, b) = ((from_s * 60.0) as usize, (to_s * 60.0) as usize);
    // verdicts[requested + 1][verdict]; row 0: music only.
    let mut verdicts = vec![vec![0usize; GENRES.len()]; GENRES.len() + 1];
    let seeds = ds.split(Split::Test);
    for name in &seeds {
        let source = SeedSource::Sequence {
            data: PathBuf::from(data),
            name: name.clone(),
        };
        let seed: Motion = seed_clip(&source, SeedStart::Zero, ck.config.seed_frames())?;
        for requested in 0..=GENRES.len() {
            let text: Vec<TextRequest> = (requested > 0)
                .then(|| TextRequest {
                    embedding: TextEmbedding::Named(format!("genre:{}", GENRES[requested - 1])),
                    from_s,
                    to_s,
                })
                .into_iter()
                .collect();
            let dance = run
                .dance(
                    &g,
                    &seed,
                    music,
                    frames,
                    &picking,
                    Controls {
                        texts: &text,
                        ..Default::default()
                    },
                    &mut |_, _| {},
                )?
                .ok_or("the song is too short")?;
            let verdict = clf.classify(&dance.slice(a, b.min(dance.frames)));
            verdicts[requested][verdict] += 1;
        }
    }
    let n = seeds.len();
    println!("{n} seeds; the interval {from_s}..{to_s} s judged by the classifier");
    println!("| text | classified as the requested genre | music-only dances classified as it |");
    println!("|---|---|---|");
    let mut hits = 0;
    for (k, genre) in GENRES.iter().enumerate() {
        hits += verdicts[k + 1][k];
        println!(
            "| {genre} | {} of {n} | {} of {n} |",
            verdicts[k + 1][k],
            verdicts[0][k]
        );
    }
    println!(
        "steering: {hits} of {} ({:.2}; chance 0.10)",
        n * GENRES.len(),
        hits as f64 / (n * GENRES.len()) as f64
    );
    Ok(())
}
