//! Progress on stderr in one style for every long job (training, features, sampling, evaluation).

use indicatif::{ProgressBar, ProgressStyle};

/// How progress is shown.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ProgressMode {
    /// A bar on a terminal, plain lines otherwise.
    Auto,
    /// Plain periodic lines on stderr.
    Lines,
    /// Nothing (logs still go to train.log).
    Quiet,
}

/// A progress bar in the style every command shares: `PREFIX [bar] done/total MSG rate [elapsed eta]`.
/// `prefix` names the work (may be empty), `msg` the unit or the current item.
pub fn bar(len: u64, prefix: &str, msg: &str) -> ProgressBar {
    let pb = ProgressBar::new(len);
    pb.set_style(
        ProgressStyle::with_template(
            "{prefix}{bar:30} {pos}/{len} {msg} {per_sec} [{elapsed_precise} eta {eta}]",
        )
        .expect("valid template"),
    );
    if !prefix.is_empty() {
        pb.set_prefix(format!("{prefix} "));
    }
    pb.set_message(msg.to_string());
    pb
}
