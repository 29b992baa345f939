//! `R/loss.png`: training and validation loss against step on a log scale, drawn with the project's own raster
//! (no font or plotting dependencies).

use qean_render::canvas::*;

use crate::metrics_log::Row;

/// Plot losses (log10 y axis). Rows without losses are skipped.
pub fn loss_plot(rows: &[Row], title: &str) -> Canvas {
    let (w, h) = (900usize, 500usize);
    let (left, right, top, bottom) = (70.0, 20.0, 40.0, 50.0);
    let mut c = Canvas::new(w, h, WHITE);
    // The title wrapped beside the legend (a run's summary is long).
    let per_line = ((w as i64 - 290) / Canvas::text_width("M", 1)).max(10) as usize;
    for (k, line) in wrap(title, per_line).iter().take(3).enumerate() {
        c.text(10, 6 + 10 * k as i64, line, 1, INK);
    }
    let pts = |f: fn(&Row) -> Option<f64>| -> Vec<(f64, f64)> {
        rows.iter()
            .filter_map(|r| {
                f(r).filter(|v| v.is_finite() && *v > 0.0)
                    .map(|v| (r.step as f64, v.log10()))
            })
            .collect()
    };
    let train = pts(|r| r.loss);
    let val = pts(|r| r.val_loss);
    let all: Vec<&(f64, f64)> = train.iter().chain(&val).collect();
    if all.is_empty() {
        c.text(left as i64, h as i64 / 2, "NO LOSSES LOGGED YET", 2, GREY);
        return c;
    }
    let xmax = all.iter().map(|p| p.0).fold(1.0, f64::max);
    let ymin = all.iter().map(|p| p.1).fold(f64::MAX, f64::min).floor();
    let ymax = all
        .iter()
        .map(|p| p.1)
        .fold(f64::MIN, f64::max)
        .ceil()
        .max(ymin + 1.0);
    let (pw, ph) = (w as f64 - left - right, h as f64 - top - bottom);
    let to = |p: (f64, f64)| {
        (
            left + pw * p.0 / xmax,
            top + ph * (1.0 - (p.1 - ymin) / (ymax - ymin)),
        )
    };
    // Decade grid and labels.
    let mut e = ymin;
    while e <= ymax + 1e-9 {
        let (_, y) = to((0.0, e));
        c.line((left, y), (left + pw, y), 1.0, LIGHT);
        c.text(6, y as i64 - 3, &format!("1E{}", e as i64), 1, GREY);
        e += 1.0;
    }
    for k in 0..=4 {
        let x = xmax * k as f64 / 4.0;
        let (px, _) = to((x, ymin));
        c.line((px, top + ph), (px, top + ph + 5.0), 1.0, GREY);
        let label = format!("{}", x.round() as u64);
        c.text(
            px as i64 - Canvas::text_width(&label, 1) / 2,
            (top + ph + 10.0) as i64,
            &label,
            1,
            GREY,
        );
    }
    c.line((left, top + ph), (left + pw, top + ph), 1.0, GREY);
    c.line((left, top), (left, top + ph), 1.0, GREY);
    c.text(
        (left + pw / 2.0) as i64 - 15,
        (h as f64 - 16.0) as i64,
        "STEP",
        1,
        GREY,
    );
    for seg in train.windows(2) {
        c.line(to(seg[0]), to(seg[1]), 1.5, LEFT);
    }
    for seg in val.windows(2) {
        c.line(to(seg[0]), to(seg[1]), 1.5, ORANGE);
    }
    for &p in &val {
        c.disc(to(p), 3.0, ORANGE);
    }
    c.text(w as i64 - 260, 14, "BLUE TRAIN   ORANGE VALIDATION", 1, INK);
    c
}

/// Splits `text` at spaces into lines of at most `width` characters (a longer word stands alone).
fn wrap(text: &str, width: usize) -> Vec<String> {
    let mut lines: Vec<String> = Vec::new();
    let mut cur = String::new();
    for word in text.split_whitespace() {
        if !cur.is_empty() && cur.chars().count() + 1 + word.chars().count() > width {
            lines.push(std::mem::take(&mut cur));
        }
        if !cur.is_empty() {
            cur.push(' ');
        }
        cur.push_str(word);
    }
    if !cur.is_empty() {
        lines.push(cur);
    }
    lines
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plot_draws_both_curves() {
        let rows: Vec<Row> = (1..=50)
            .map(|s| Row {
                step: s * 10,
                lr: 1e-4,
                loss: Some(1.0 / s as f64),
                val_loss: (s % 10 == 0).then(|| 2.0 / s as f64),
                seconds: 0.0,
            })
            .collect();
        let c = loss_plot(&rows, "TEST");
        assert!(c.pixels.contains(&LEFT));
        assert!(c.pixels.contains(&ORANGE));
        assert_eq!(&c.to_png()[1..4], b"PNG");
        let empty = loss_plot(&[], "EMPTY");
        assert!(!empty.pixels.contains(&LEFT));
        assert_eq!(wrap("AB CD EF", 5), ["AB CD", "EF"]);
        assert_eq!(wrap("ABCDEFG H", 3), ["ABCDEFG", "H"]);
    }
}
