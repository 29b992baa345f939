//! `qean view` in a real headless browser (Debian's chromium, installed by .ci/run when missing; the test skips
//! without it unless QEAN_REQUIRE_CHROMIUM is set): the page loads with no console errors, the 3-D view is not
//! blank, a moving dance's pixels differ between t = 1 s and t = 5 s, the audio element's duration equals the
//! song's, a dance and a song of different lengths are said to be so, and the screenshot is kept as a test
//! artefact (target/test-artifacts/qean-view.png). Bad inputs end in one line with nothing written.

mod common;
use common::*;
use std::path::{Path, PathBuf};
use std::process::Command;

fn chromium() -> Option<&'static str> {
    let found = ["chromium", "chromium-browser"].into_iter().find(|c| {
        Command::new(c)
            .arg("--version")
            .output()
            .is_ok_and(|o| o.status.success())
    });
    if found.is_none() {
        assert!(
            std::env::var("QEAN_REQUIRE_CHROMIUM").is_err(),
            "QEAN_REQUIRE_CHROMIUM is set but chromium is not installed"
        );
        eprintln!("skipping: chromium is not installed");
    }
    found
}

/// Runs headless chromium on `page#t=T` with `extra` arguments; returns (stdout, stderr).
fn browse(chrome: &str, page: &Path, t: f64, extra: &[&str]) -> (String, String) {
    let out = Command::new(chrome)
        .args([
            "--headless=new",
            "--no-sandbox",
            "--use-angle=swiftshader",
            "--enable-unsafe-swiftshader",
            "--window-size=1000,700",
            "--virtual-time-budget=5000",
            "--enable-logging=stderr",
            "--v=0",
        ])
        .args(extra)
        .arg(format!("file://{}#t={t}", page.display()))
        .output()
        .unwrap();
    (
        String::from_utf8_lossy(&out.stdout).to_string(),
        String::from_utf8_lossy(&out.stderr).to_string(),
    )
}

/// RGB pixels of a PNG.
fn pixels(path: &Path) -> (usize, usize, Vec<[u8; 3]>) {
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(path).unwrap()));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    let step = info.color_type.samples();
    let px = buf[..info.buffer_size()]
        .chunks_exact(step)
        .map(|p| [p[0], p[1], p[2]])
        .collect();
    (info.width as usize, info.height as usize, px)
}

/// Every console message the page logged (a clean page logs none: errors, warnings and uncaught exceptions
/// all show up here).
fn console_errors(stderr: &str) -> Vec<&str> {
    stderr.lines().filter(|l| l.contains("CONSOLE")).collect()
}

#[test]
fn view_page_plays_in_a_headless_browser() {
    let dir = tempfile::tempdir().unwrap();
    let synth = dir.path().join("synth");
    run_ok(
        qean()
            .args(["synth", "--sequences", "4", "--seconds", "8", "--out"])
            .arg(&synth),
    );
    let mut motions: Vec<PathBuf> = std::fs::read_dir(synth.join("motions"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    motions.sort();
    let song = shared().join("music/Kevin_MacLeod_-_Vibe_Ace.ogg");
    let page = dir.path().join("page.html");
    let printed = run_ok(
        qean()
            .arg("view")
            .args(&motions[..2])
            .args([
                "--label",
                "first",
                "--label",
                "second",
                "--seed-frames",
                "120",
                "--music",
            ])
            .arg(&song)
            .arg("--out")
            .arg(&page),
    );
    assert!(printed.contains("2 dance(s)"), "{printed}");
    let html = std::fs::read_to_string(&page).unwrap();
    assert!(html.contains("data:audio/ogg;base64,"));
    assert!(
        html.contains("three.js"),
        "the vendored library and its licence"
    );

    // Bad inputs: an unreadable dance, an output in a missing directory.
    let bad = dir.path().join("bad.pkl");
    std::fs::write(&bad, b"not a pickle").unwrap();
    assert_clean_failure(
        qean()
            .arg("view")
            .arg(&bad)
            .arg("--out")
            .arg(dir.path().join("bad.html")),
        "bad.pkl",
    );
    assert!(!dir.path().join("bad.html").exists());
    assert_clean_failure(
        qean()
            .arg("view")
            .arg(&motions[0])
            .arg("--out")
            .arg(dir.path().join("no/such/page.html")),
        "output directory does not exist",
    );

    let Some(chrome) = chromium() else {
        return;
    };
    let (dom, stderr) = browse(chrome, &page, 1.0, &["--dump-dom"]);
    assert!(
        console_errors(&stderr).is_empty(),
        "{:?}",
        console_errors(&stderr)
    );
    let title = dom
        .split("<title>")
        .nth(1)
        .and_then(|t| t.split("</title>").next())
        .unwrap_or_default()
        .to_string();
    assert!(
        title.starts_with("qean view: ready t=1 frame=60"),
        "{title}"
    );
    let duration: f64 = title
        .split("audio=")
        .nth(1)
        .and_then(|d| d.parse().ok())
        .unwrap_or_else(|| panic!("{title}"));
    let decoded = qean_audio::decode::decode_file(&song, f64::INFINITY).unwrap();
    let seconds = decoded.samples.len() as f64 / decoded.channels as f64 / decoded.rate as f64;
    assert!(
        (duration - seconds).abs() < 0.05,
        "page {duration} s, song {seconds} s"
    );
    assert!(
        dom.contains("playing the shorter (the dance)"),
        "a 61-s song and 8-s dances"
    );

    let shots: Vec<PathBuf> = [1.0, 5.0]
        .iter()
        .map(|&t| {
            let shot = dir.path().join(format!("shot{t}.png"));
            let arg = format!("--screenshot={}", shot.display());
            let (_, stderr) = browse(chrome, &page, t, &[&arg]);
            assert!(
                console_errors(&stderr).is_empty(),
                "{:?}",
                console_errors(&stderr)
            );
            shot
        })
        .collect();
    let (w, h, a) = pixels(&shots[0]);
    let (_, _, b) = pixels(&shots[1]);
    // The 3-D view: between the header and the timeline.
    let view = |p: &[[u8; 3]]| -> Vec<[u8; 3]> {
        (h / 10..h * 8 / 10)
            .flat_map(|y| p[y * w..(y + 1) * w].to_vec())
            .collect()
    };
    let (va, vb) = (view(&a), view(&b));
    let background = [0xf4, 0xf4, 0xf0];
    let figure = va
        .iter()
        .filter(|p| p.iter().zip(&background).any(|(x, y)| x.abs_diff(*y) > 40))
        .count();
    assert!(
        figure > 2_000,
        "the 3-D view looks blank: {figure} non-background pixels"
    );
    let moved = va.iter().zip(&vb).filter(|(x, y)| x != y).count();
    assert!(
        moved > 500,
        "the figures did not move between 1 s and 5 s: {moved} pixels changed"
    );
    let artefacts = Path::new(env!("CARGO_MANIFEST_DIR")).join("target/test-artifacts");
    std::fs::create_dir_all(&artefacts).unwrap();
    std::fs::copy(&shots[1], artefacts.join("qean-view.png")).unwrap();
}
