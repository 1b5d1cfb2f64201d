//! What a render shows while it runs: progress bars on a terminal (here a pseudo-terminal
//! made by `script`), nothing but summary lines on a pipe, nothing at all with --quiet.

mod common;
use common::{raylink, stderr};
use std::process::Command;

const ROOM: [&str; 10] = [
    "render",
    "scenes/indirect-room.toml",
    "--width",
    "64",
    "--height",
    "48",
    "--ab",
    "2",
    "--ic-samples",
    "256",
];

/// Characters only a drawn progress bar writes.
fn has_bar(text: &str) -> bool {
    text.contains('\r') || text.contains('░') || text.contains('█') || text.contains("\u{1b}[")
}

#[test]
fn a_terminal_shows_the_overture_before_the_render_and_a_pipe_shows_no_bars() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("room.exr");
    let mut args: Vec<String> = ROOM.iter().map(|s| s.to_string()).collect();
    args.extend(["-o".into(), out.to_str().unwrap().into()]);
    let command = std::iter::once(env!("CARGO_BIN_EXE_raylink").to_string())
        .chain(args.iter().cloned())
        .collect::<Vec<_>>()
        .join(" ");
    // `script` runs the command under a pseudo-terminal and copies what it writes.
    let run = Command::new("script")
        .args(["-q", "-e", "-c", &command, "/dev/null"])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("script (util-linux) runs");
    let shown = String::from_utf8_lossy(&run.stdout);
    assert!(
        run.status.success(),
        "{shown}{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let overture = shown
        .find("overture [")
        .unwrap_or_else(|| panic!("no overture bar: {shown}"));
    let render = shown
        .find("render [")
        .unwrap_or_else(|| panic!("no render bar: {shown}"));
    assert!(overture < render, "{shown}");
    assert!(
        shown.contains("parts") && shown.contains("samples"),
        "{shown}"
    );
    assert!(has_bar(&shown), "{shown}");

    // The same on a pipe: summary lines only.
    let argv: Vec<&str> = args.iter().map(String::as_str).collect();
    let piped = raylink(&argv);
    let text = stderr(&piped);
    assert!(piped.status.success(), "{text}");
    assert!(!has_bar(&text), "bar characters on a pipe: {text:?}");
    assert!(
        text.contains("overture: ") && text.contains("rendered in"),
        "{text}"
    );
    // The summary counts the overture: its total is the overture's time and the image's.
    let number = |s: &str| {
        s.trim()
            .parse::<f64>()
            .unwrap_or_else(|_| panic!("{s:?}: {text}"))
    };
    let overture_line = text.lines().find(|l| l.starts_with("overture: ")).unwrap();
    let overture = number(
        overture_line
            .rsplit_once('(')
            .unwrap()
            .1
            .trim_end_matches(" s)"),
    );
    let summary = text
        .lines()
        .find(|l| l.starts_with("rendered in "))
        .unwrap();
    let times = summary
        .trim_start_matches("rendered in ")
        .split_once(':')
        .unwrap()
        .0;
    let (total, parts) = times
        .split_once(" s (")
        .unwrap_or_else(|| panic!("{summary}"));
    let (preparing, image) = parts.split_once(" s preparing, ").unwrap();
    let (total, preparing) = (number(total), number(preparing));
    let image = number(image.trim_end_matches(" s the image)"));
    assert!(preparing >= overture - 0.01, "{text}");
    assert!((total - preparing - image).abs() <= 0.011, "{text}");
    // And nothing with --quiet.
    let mut quiet = argv.clone();
    quiet.push("--quiet");
    let run = raylink(&quiet);
    assert!(
        run.status.success() && run.stderr.is_empty(),
        "{}",
        stderr(&run)
    );
}
