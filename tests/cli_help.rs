//! `--help` that reads well: one short line per command at the top level (as cargo's), and lists in a
//! command's own help kept one item per line.

mod common;

use common::qean;

fn help(args: &[&str]) -> String {
    let out = qean().args(args).arg("--help").output().unwrap();
    assert!(out.status.success(), "{args:?} --help failed");
    String::from_utf8(out.stdout).unwrap()
}

#[test]
fn the_top_level_lists_one_short_line_per_command() {
    let text = help(&[]);
    let commands: Vec<&str> = text
        .lines()
        .skip_while(|l| !l.starts_with("Commands:"))
        .skip(1)
        .take_while(|l| !l.is_empty())
        .collect();
    assert!(commands.len() >= 14, "{text}");
    for line in &commands {
        assert!(
            line.starts_with("  ") && line.as_bytes()[2] != b' ',
            "a command's summary runs onto a second line: {line:?}\n{text}"
        );
        assert!(line.chars().count() <= 90, "summary too long: {line:?}");
    }
}

#[test]
fn lists_in_a_command_help_keep_one_item_per_line() {
    let sample = help(&["sample"]);
    for item in ["NAME.pkl", "NAME.joints.npy", "NAME.bvh", "NAME.png/.gif"] {
        assert!(
            sample.lines().any(|l| l.trim_start().starts_with(item)),
            "qean sample --help: {item} does not start a line\n{sample}"
        );
    }
    let train = help(&["train"]);
    assert!(
        train
            .lines()
            .any(|l| l.trim_start().starts_with("qean train --resume runs/full")),
        "{train}"
    );
}
