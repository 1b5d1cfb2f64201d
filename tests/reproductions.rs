//! docs/reproductions.md against a fresh run of the commands its scripts run: the numbers a
//! render determines (counts of rays and values; times vary and are not compared). Ward's
//! section-4 table is checked by the library's test `ward_section_4_in_the_papers_setting`.

mod common;

use common::{raylink, stderr};

const PAGE: &str = "docs/reproductions.md";

/// The block of the page between `<!-- BEGIN name -->` and `<!-- END name -->`.
fn page_block(name: &str) -> String {
    let page = std::fs::read_to_string(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(PAGE))
        .unwrap();
    let (begin, end) = (
        format!("<!-- BEGIN {name} -->"),
        format!("<!-- END {name} -->"),
    );
    let start = page
        .find(&begin)
        .unwrap_or_else(|| panic!("{PAGE} has no {begin}"));
    let stop = page
        .find(&end)
        .unwrap_or_else(|| panic!("{PAGE} has no {end}"));
    page[start + begin.len()..stop].to_owned()
}

/// The last cell of the block's table row that starts with `label`.
fn raylink_cell(block: &str, label: &str) -> String {
    let row = block
        .lines()
        .find(|l| l.starts_with(&format!("| {label} |")))
        .unwrap_or_else(|| panic!("{PAGE}: no row {label:?} in:\n{block}"));
    let cells: Vec<&str> = row.trim_matches('|').split('|').map(str::trim).collect();
    cells.last().unwrap().to_string()
}

/// The integers of a cell, in order (digits only: "7352113 (11.3 Mrays/s)" gives 7352113
/// and 11 and 3; callers take the ones they know).
fn integers(cell: &str) -> Vec<u64> {
    cell.split(|c: char| !c.is_ascii_digit())
        .filter(|s| !s.is_empty())
        .map(|s| s.parse().unwrap())
        .collect()
}

/// The number just before the first `suffix` in `text`.
fn number_before(text: &str, suffix: &str) -> u64 {
    let at = text
        .find(suffix)
        .unwrap_or_else(|| panic!("no {suffix:?} in:\n{text}"));
    let digits: String = text[..at]
        .trim_end()
        .chars()
        .rev()
        .take_while(char::is_ascii_digit)
        .collect();
    digits.chars().rev().collect::<String>().parse().unwrap()
}

/// Whitted's figure 7 (`python3 reproduce/whitted.py`): the rays and camera rays of the
/// command the script runs are the page's.
#[test]
fn whitted_rays_are_the_pages() {
    let dir = std::env::temp_dir().join(format!("raylink-repro-whitted-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let image = dir.join("fig7.png");
    let out = raylink(&[
        "render",
        "scenes/whitted.toml",
        "--integrator",
        "whitted",
        "--width",
        "640",
        "--height",
        "480",
        "-o",
        image.to_str().unwrap(),
    ]);
    std::fs::remove_dir_all(&dir).unwrap();
    let err = stderr(&out);
    assert!(out.status.success(), "{err}");
    let (rays, camera) = (
        number_before(&err, " rays ("),
        number_before(&err, " camera samples"),
    );
    let block = page_block("whitted:table");
    let hint = "(`python3 reproduce/whitted.py` rewrites the page)";
    assert_eq!(
        integers(&raylink_cell(&block, "rays"))[0],
        rays,
        "rays {hint}"
    );
    assert_eq!(
        integers(&raylink_cell(
            &block,
            "camera rays (adaptive anti-aliasing)"
        ))[0],
        camera,
        "camera rays {hint}"
    );
}

/// Ward's figure 5 in the room (`python3 reproduce/ward.py`): the values the overture of the
/// command the script runs computes, in all and per bounce, are the page's. (The count of
/// values the camera sees needs a second render, with --show-cache-points; it is left out.)
#[test]
fn ward_room_values_are_the_pages() {
    let dir = std::env::temp_dir().join(format!("raylink-repro-room-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let image = dir.join("room.png");
    let out = raylink(&[
        "render",
        "scenes/indirect-room.toml",
        "--ic-samples",
        "2048",
        "--ar",
        "8",
        "-o",
        image.to_str().unwrap(),
    ]);
    std::fs::remove_dir_all(&dir).unwrap();
    let err = stderr(&out);
    assert!(out.status.success(), "{err}");
    let values = number_before(&err, " values (");
    let levels = err
        .split("per bounce level: [")
        .nth(1)
        .and_then(|rest| rest.split(']').next())
        .unwrap_or_else(|| panic!("no values per bounce level in:\n{err}"));
    let block = page_block("ward:room");
    let hint = "(`python3 reproduce/ward.py` rewrites the page)";
    assert_eq!(
        integers(&raylink_cell(&block, "values computed")),
        [values],
        "{hint}"
    );
    assert_eq!(
        integers(&raylink_cell(&block, "per bounce, first to last")),
        integers(levels),
        "{hint}"
    );
}
