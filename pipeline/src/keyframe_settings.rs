//! `--set keyframes.KEY=VALUE` and `--set inbetween.KEY=VALUE` of `qean keyframes`, `qean edit` and
//! `qean eval --task inbetween`, as typed settings.

use qean_io::error::{Error, Result};
use qean_keyframes::bezier::{BezierAverage, BezierParam, BezierSettings};
use qean_keyframes::mse::MseSpace;
use qean_keyframes::KeyframeOptions;
use serde::Deserialize;

/// The settings of `--set` overrides: [keyframes] and [inbetween] tables.
#[derive(Debug, Clone, Default)]
pub struct Settings {
    pub keyframes: KeyframeOptions,
    pub bezier: BezierSettings,
    pub mse_space: MseSpace,
    pub fid_reference: crate::inbetween_benchmark::FidReference,
}

fn first_line(e: impl std::fmt::Display) -> String {
    e.to_string()
        .lines()
        .next()
        .unwrap_or("")
        .trim()
        .to_string()
}

/// Parse `--set` values; any table but `keyframes` and `inbetween` is an error.
pub fn parse(sets: &[String]) -> Result<Settings> {
    let mut table = toml::Table::new();
    let mut s = Settings::default();
    for spec in sets {
        let (parts, value) = qean_config::run::parse_override(spec).map_err(Error::msg)?;
        let [t, key] = parts.as_slice() else {
            return Err(Error::msg(format!(
                "--set {spec}: only keyframes.* and inbetween.* settings apply here"
            )));
        };
        match t.as_str() {
            "keyframes" => {
                // Each setting alone first, so that an error names the one at fault.
                let single = toml::Table::from_iter([(key.clone(), value.clone())]);
                if let Err(e) = KeyframeOptions::deserialize(toml::Value::Table(single)) {
                    return Err(Error::msg(format!("--set {spec}: {}", first_line(e))));
                }
                table.insert(key.clone(), value);
            }
            "inbetween" => {
                let bad =
                    |e: toml::de::Error| Error::msg(format!("--set {spec}: {}", first_line(e)));
                match key.as_str() {
                    "bezier_param" => s.bezier.param = BezierParam::deserialize(value).map_err(bad)?,
                    "bezier_average" => s.bezier.average = BezierAverage::deserialize(value).map_err(bad)?,
                    "mse_space" => s.mse_space = MseSpace::deserialize(value).map_err(bad)?,
                    "fid_reference" => {
                        s.fid_reference =
                            crate::inbetween_benchmark::FidReference::deserialize(value).map_err(bad)?
                    }
                    other => return Err(Error::msg(format!(
                        "--set {spec}: unknown [inbetween] setting {other:?} (bezier_param, bezier_average, mse_space, fid_reference)"
                    ))),
                }
            }
            _ => {
                return Err(Error::msg(format!(
                    "--set {spec}: only keyframes.* and inbetween.* settings apply here"
                )))
            }
        }
    }
    s.keyframes = KeyframeOptions::deserialize(toml::Value::Table(table))
        .map_err(|e| Error::msg(format!("--set keyframes: {}", first_line(e))))?;
    s.bezier.order = s.keyframes.euler_order;
    s.bezier.unwrap = s.keyframes.euler_unwrap;
    Ok(s)
}
