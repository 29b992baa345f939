//! Previews a person can look at: an animated stick figure (GIF) and a PNG contact sheet of key frames with the
//! music's beats marked, drawn from joint positions (frames × 24, metres, +Y up) with no external tools; and
//! [`export`], which writes a generated dance as every file a person or another tool wants (pickle, joints,
//! BVH, previews) all or nothing.

pub mod canvas;
pub mod export;
pub mod font;
pub mod gltf;
pub mod view;

use std::path::{Path, PathBuf};

use canvas::*;

use qean_io::error::{Error, Result};
use qean_io::fsutil::atomic_write;
use qean_motion::skeleton::{JOINT_NAMES, NUM_JOINTS, PARENTS};

/// What to draw.
#[derive(Debug, Clone)]
pub struct Preview<'a> {
    pub title: String,
    /// frames × 24 joint positions.
    pub joints: &'a [[f64; 3]],
    pub fps: f64,
    /// Music beat frames (aligned with motion frames), if known.
    pub beats: Option<&'a [usize]>,
    /// Leading frames that were given rather than generated (drawn as "seed").
    pub seed_frames: usize,
}

impl Preview<'_> {
    pub fn frames(&self) -> usize {
        self.joints.len() / NUM_JOINTS
    }

    fn frame(&self, t: usize) -> &[[f64; 3]] {
        &self.joints[t * NUM_JOINTS..(t + 1) * NUM_JOINTS]
    }

    fn near_beat(&self, t: usize, tol: usize) -> bool {
        self.beats
            .is_some_and(|b| b.iter().any(|&x| x.abs_diff(t) <= tol))
    }
}

/// A fixed three-quarter camera fitted to the whole motion.
struct Camera {
    cos: f64,
    sin: f64,
    mid: (f64, f64),
    scale: f64,
    centre: (f64, f64),
}

impl Camera {
    fn fit(p: &Preview, width: f64, height: f64) -> Camera {
        let yaw = 25f64.to_radians();
        let (cos, sin) = (yaw.cos(), yaw.sin());
        let (mut umin, mut umax, mut vmin, mut vmax) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
        for q in p.joints {
            let u = cos * q[0] + sin * q[2];
            umin = umin.min(u);
            umax = umax.max(u);
            vmin = vmin.min(q[1]);
            vmax = vmax.max(q[1]);
        }
        let span_u = (umax - umin).max(0.5) + 0.3;
        let span_v = (vmax - vmin).max(0.5) + 0.3;
        Camera {
            cos,
            sin,
            mid: ((umin + umax) / 2.0, (vmin + vmax) / 2.0),
            scale: (width / span_u).min(height / span_v),
            centre: (width / 2.0, height / 2.0),
        }
    }

    fn project(&self, q: [f64; 3]) -> (f64, f64) {
        let u = self.cos * q[0] + self.sin * q[2];
        (
            self.centre.0 + self.scale * (u - self.mid.0),
            self.centre.1 - self.scale * (q[1] - self.mid.1),
        )
    }
}

fn bone_color(j: usize) -> Color {
    if JOINT_NAMES[j].starts_with("left") {
        LEFT
    } else if JOINT_NAMES[j].starts_with("right") {
        RIGHT
    } else {
        CENTRE
    }
}

/// Draw one pose into `c` inside the rectangle (x0, y0, w, h).
fn draw_pose(c: &mut Canvas, cam: &Camera, pose: &[[f64; 3]], x0: f64, y0: f64, floor_y: f64) {
    let w = (cam.scale * 0.035).clamp(1.5, 6.0);
    let pr = |q: [f64; 3]| {
        let (x, y) = cam.project(q);
        (x + x0, y + y0)
    };
    // Floor line under the figure.
    let root = pose[0];
    let fl = [root[0], floor_y, root[2]];
    let (fx, fy) = pr(fl);
    c.line(
        (fx - cam.scale * 0.5, fy),
        (fx + cam.scale * 0.5, fy),
        1.0,
        LIGHT,
    );
    for j in 1..NUM_JOINTS {
        let a = pr(pose[PARENTS[j] as usize]);
        let b = pr(pose[j]);
        c.line(a, b, w, bone_color(j));
    }
    c.disc(pr(pose[15]), cam.scale * 0.09, CENTRE);
}

fn floor_of(p: &Preview) -> f64 {
    p.joints.iter().map(|q| q[1]).fold(f64::MAX, f64::min)
}

/// One key frame of the contact sheet: the pose at frame `t` in a `size` panel at `origin`, outlined in
/// orange on a music beat, labelled with its frame and time (and SEED inside the seed).
fn key_frame_panel(
    c: &mut Canvas,
    p: &Preview,
    cam: &Camera,
    floor: f64,
    t: usize,
    (x0, y0): (usize, usize),
    (pw, ph): (usize, usize),
) {
    let on_beat = p.near_beat(t, 2);
    if on_beat {
        c.fill_rect(
            x0 as i64 + 2,
            y0 as i64 + 2,
            pw as i64 - 4,
            ph as i64 - 4,
            HIGHLIGHT,
        );
        c.rect(
            x0 as i64 + 2,
            y0 as i64 + 2,
            pw as i64 - 4,
            ph as i64 - 4,
            3,
            ORANGE,
        );
    } else {
        c.rect(
            x0 as i64 + 2,
            y0 as i64 + 2,
            pw as i64 - 4,
            ph as i64 - 4,
            1,
            LIGHT,
        );
    }
    draw_pose(
        c,
        cam,
        p.frame(t),
        x0 as f64 + 10.0,
        y0 as f64 + 30.0,
        floor,
    );
    let label = format!("F{t} {:.2}S", t as f64 / p.fps);
    c.text(x0 as i64 + 8, y0 as i64 + 8, &label, 1, INK);
    if t < p.seed_frames {
        c.text(x0 as i64 + pw as i64 - 40, y0 as i64 + 8, "SEED", 1, GREY);
    }
    if on_beat {
        c.text(
            x0 as i64 + pw as i64 - 40,
            y0 as i64 + ph as i64 - 18,
            "BEAT",
            1,
            ORANGE,
        );
    }
}

/// The contact sheet's timeline from height `top`: mean joint speed (m/s) over time, the seed shaded, music
/// beats as orange lines, the key frames ticked.
fn speed_timeline(c: &mut Canvas, p: &Preview, keys: &[usize], top: f64, width: f64, strip: f64) {
    let frames = p.frames();
    let y0 = top;
    let (x0, w, h) = (40.0, width - 60.0, strip - 50.0);
    let speed: Vec<f64> = (1..frames)
        .map(|t| {
            let (a, b) = (p.frame(t - 1), p.frame(t));
            a.iter()
                .zip(b)
                .map(|(u, v)| {
                    ((u[0] - v[0]).powi(2) + (u[1] - v[1]).powi(2) + (u[2] - v[2]).powi(2)).sqrt()
                })
                .sum::<f64>()
                / NUM_JOINTS as f64
                * p.fps
        })
        .collect();
    let vmax = speed.iter().cloned().fold(1e-6, f64::max);
    let xt = |t: f64| x0 + w * t / (frames.max(2) - 1) as f64;
    if p.seed_frames > 0 {
        let xs = xt(p.seed_frames.min(frames - 1) as f64);
        c.fill_rect(x0 as i64, y0 as i64, (xs - x0) as i64, h as i64, LIGHT);
        c.text(x0 as i64 + 4, y0 as i64 + 4, "SEED", 1, GREY);
    }
    if let Some(beats) = p.beats {
        for &b in beats.iter().filter(|&&b| b < frames) {
            let x = xt(b as f64);
            c.line((x, y0), (x, y0 + h), 1.0, ORANGE);
        }
    }
    for w2 in speed.windows(2).enumerate() {
        let (t, v) = w2;
        let a = (xt(t as f64 + 0.5), y0 + h - h * v[0] / vmax);
        let b = (xt(t as f64 + 1.5), y0 + h - h * v[1] / vmax);
        c.line(a, b, 1.5, INK);
    }
    for &t in keys {
        let x = xt(t as f64);
        c.line((x, y0 + h + 2.0), (x, y0 + h + 8.0), 2.0, GREY);
    }
    c.line((x0, y0 + h), (x0 + w, y0 + h), 1.0, GREY);
    c.text(
        x0 as i64,
        (y0 + h + 12.0) as i64,
        "MEAN JOINT SPEED OVER TIME; ORANGE LINES = MUSIC BEATS",
        1,
        GREY,
    );
    c.text(4, y0 as i64, &format!("{vmax:.1}"), 1, GREY);
    c.text(4, (y0 + h - 8.0) as i64, "M/S", 1, GREY);
}

/// A contact sheet: `cols × rows` key frames evenly spaced in time, those on a music beat outlined in orange,
/// and a timeline of mean joint speed with the beats and the key frames marked.
pub fn contact_sheet(p: &Preview, cols: usize, rows: usize) -> Canvas {
    let (pw, ph) = (200usize, 240usize);
    let header = 34usize;
    let strip = 150usize;
    let width = cols * pw;
    let height = header + rows * ph + strip;
    let mut c = Canvas::new(width, height, WHITE);
    let frames = p.frames();
    let secs = frames as f64 / p.fps;
    let title = format!("{}   {} FRAMES, {:.1} S", p.title, frames, secs);
    c.text(8, 8, &title, 2, INK);
    let legend = "BLUE LEFT  RED RIGHT  ORANGE = MUSIC BEAT";
    c.text(
        width as i64 - Canvas::text_width(legend, 1) - 8,
        24,
        legend,
        1,
        GREY,
    );
    if frames == 0 {
        return c;
    }
    let cam = Camera::fit(p, pw as f64 - 20.0, ph as f64 - 40.0);
    let floor = floor_of(p);
    let n = cols * rows;
    let keys: Vec<usize> = (0..n)
        .map(|k| ((k as f64 + 0.5) * frames as f64 / n as f64) as usize)
        .map(|t| t.min(frames - 1))
        .collect();
    for (k, &t) in keys.iter().enumerate() {
        let origin = ((k % cols) * pw, header + (k / cols) * ph);
        key_frame_panel(&mut c, p, &cam, floor, t, origin, (pw, ph));
    }
    let top = (header + rows * ph) as f64 + 20.0;
    speed_timeline(&mut c, p, &keys, top, width as f64, strip as f64);
    c
}

/// An animated GIF of the stick figure at `fps_out` frames per second (a divisor of the motion rate works
/// best), `size` pixels square, with a flash on music beats.
pub fn animation_gif(p: &Preview, size: usize, fps_out: f64) -> Vec<u8> {
    let frames = p.frames();
    let stride = (p.fps / fps_out).round().max(1.0) as usize;
    let delay = (100.0 * stride as f64 / p.fps).round() as u16;
    let cam = Camera::fit(p, size as f64 - 20.0, size as f64 - 50.0);
    let floor = floor_of(p);
    let palette: Vec<u8> = PALETTE.iter().flatten().copied().collect();
    let mut out = Vec::new();
    {
        let mut enc =
            gif::Encoder::new(&mut out, size as u16, size as u16, &palette).expect("in-memory GIF");
        enc.set_repeat(gif::Repeat::Infinite)
            .expect("in-memory GIF");
        for t in (0..frames).step_by(stride) {
            let mut c = Canvas::new(size, size, WHITE);
            draw_pose(&mut c, &cam, p.frame(t), 10.0, 35.0, floor);
            c.text(6, 6, &format!("{:.2}S", t as f64 / p.fps), 2, INK);
            if t < p.seed_frames {
                c.text(size as i64 - 60, 6, "SEED", 2, GREY);
            }
            if p.near_beat(t, stride / 2 + 1) {
                c.disc((size as f64 - 18.0, size as f64 - 18.0), 10.0, ORANGE);
            }
            let frame = gif::Frame {
                width: size as u16,
                height: size as u16,
                delay,
                buffer: std::borrow::Cow::Owned(c.pixels),
                ..gif::Frame::default()
            };
            enc.write_frame(&frame).expect("in-memory GIF");
        }
    }
    out
}

/// Beat frames from a 35-D music feature file (column 34 is the beat one-hot).
pub fn beats_from_features(path: &Path) -> Result<Vec<usize>> {
    let a = qean_io::npy::read(path)?;
    if a.shape.len() != 2 || a.shape[1] != 35 {
        return Err(Error::at(
            path,
            format!(
                "expected (frames, 35) music features, got shape {:?}",
                a.shape
            ),
        ));
    }
    Ok(a.data
        .chunks_exact(35)
        .enumerate()
        .filter(|(_, row)| row[34] > 0.5)
        .map(|(t, _)| t)
        .collect())
}

/// `x.png` → (x.png, x.gif); `x.gif` → (x.png, x.gif); `x` → (x.png, x.gif).
pub fn preview_paths(out: &Path) -> (PathBuf, PathBuf) {
    let ext = qean_io::fsutil::extension_lower(out);
    let stem = match ext.as_str() {
        "png" | "gif" => out.with_extension(""),
        _ => out.to_path_buf(),
    };
    let add = |e: &str| {
        let mut s = stem.clone().into_os_string();
        s.push(".");
        s.push(e);
        PathBuf::from(s)
    };
    (add("png"), add("gif"))
}

/// Write `<stem>.png` (contact sheet) and `<stem>.gif` (animation) atomically; returns both paths.
pub fn write_preview(p: &Preview, png_path: &Path, gif_path: &Path) -> Result<()> {
    if p.frames() == 0 {
        return Err(Error::msg("nothing to render: the motion has no frames"));
    }
    if let Some(bad) = p
        .joints
        .iter()
        .position(|q| !q.iter().all(|x| x.is_finite()))
    {
        return Err(Error::msg(format!(
            "cannot render: joint positions are not finite at frame {}",
            bad / NUM_JOINTS
        )));
    }
    let sheet = contact_sheet(p, 6, 2).to_png();
    let gif = animation_gif(p, 320, 20.0);
    atomic_write(png_path, &sheet)?;
    atomic_write(gif_path, &gif)
}

#[cfg(test)]
mod tests {
    use super::*;
    use qean_motion::fk::FkRoot;
    use qean_motion::motion::Motion;

    #[test]
    fn renders_real_motion() {
        let m = Motion::read_pkl(
            &qean_io::testdata::shared_dir()
                .join("aistpp/motions/softcat477_SMPL-to-FBX_sample.pkl"),
        )
        .unwrap();
        let j = m.joints(FkRoot::Smpl);
        let beats = [10usize, 40, 70, 100];
        let p = Preview {
            title: "softcat".into(),
            joints: &j,
            fps: 60.0,
            beats: Some(&beats),
            seed_frames: 20,
        };
        let sheet = contact_sheet(&p, 6, 2);
        // Some ink of every limb colour is drawn.
        for col in [LEFT, RIGHT, CENTRE, ORANGE] {
            assert!(sheet.pixels.contains(&col), "colour {col} missing");
        }
        let png = sheet.to_png();
        assert_eq!(&png[1..4], b"PNG");
        let gif = animation_gif(&p, 160, 20.0);
        assert_eq!(&gif[..6], b"GIF89a");
        let dir = tempfile::tempdir().unwrap();
        write_preview(&p, &dir.path().join("a.png"), &dir.path().join("a.gif")).unwrap();
        // NaN joints are refused and nothing is written.
        let mut bad = j.clone();
        bad[50][1] = f64::NAN;
        let p2 = Preview { joints: &bad, ..p };
        assert!(write_preview(&p2, &dir.path().join("b.png"), &dir.path().join("b.gif")).is_err());
        assert!(!dir.path().join("b.png").exists());
    }
}
