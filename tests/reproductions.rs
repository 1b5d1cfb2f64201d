//! docs/reproductions.md against a fresh run of the commands its scripts run: the numbers a
//! run determines (counts of rays, values, patches and links, Monte Carlo estimates of a
//! fixed seed; times vary and are not compared). Ward's section-4 table is checked by the
//! library's test `ward_section_4_in_the_papers_setting`.

mod common;

use common::{raylink, stderr};
use raylink::flux::{estimate, Estimator, Flux, FluxJob};
use raylink::{Backend, Control, Scene};
use std::path::{Path, PathBuf};

const PAGE: &str = "docs/reproductions.md";

/// Set (to anything) by the scripts of reproduce/: print the tables a test makes without
/// comparing them with the page, which the script then rewrites.
const PRINT_ONLY: &str = "RAYLINK_REPRODUCE_PRINT_ONLY";

fn manifest(path: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(path)
}

/// The block of the page between `<!-- BEGIN name -->` and `<!-- END name -->`.
fn page_block(name: &str) -> String {
    let page = std::fs::read_to_string(manifest(PAGE)).unwrap();
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

/// The cells of a table row, without the outer bars.
fn cells(row: &str) -> Vec<String> {
    row.trim()
        .trim_matches('|')
        .split('|')
        .map(|c| c.trim().to_owned())
        .collect()
}

/// The cell of the block's table in the row that starts with `label` and the column headed
/// `column` (its first row names the columns).
fn table_cell(block: &str, label: &str, column: &str) -> String {
    let header = cells(block.lines().find(|l| l.starts_with('|')).unwrap_or(""));
    let at = header
        .iter()
        .position(|h| h == column)
        .unwrap_or_else(|| panic!("{PAGE}: no column {column:?} in:\n{block}"));
    let row = block
        .lines()
        .find(|l| l.starts_with(&format!("| {label} |")))
        .unwrap_or_else(|| panic!("{PAGE}: no row {label:?} in:\n{block}"));
    cells(row)[at].clone()
}

/// What `--network-stats` says of an illumination network, as the Buckalew & Fussell script
/// formats it.
#[derive(Debug)]
struct NetworkStats {
    patches: String,
    nodes: String,
    slots: String,
    links: String,
    linked_per_node: String,
    intersections: String,
    memory: String,
    sweeps: String,
}

/// The text after `key` up to the next `until` in `text`.
fn after<'a>(text: &'a str, key: &str, until: &str) -> &'a str {
    let rest = &text[text
        .find(key)
        .unwrap_or_else(|| panic!("no {key:?} in:\n{text}"))
        + key.len()..];
    &rest[..rest.find(until).unwrap_or(rest.len())]
}

/// Renders `scene` with the network integrator and returns its statistics. The network is
/// a function of the scene and the network's options, not of the image: a 40x40 image
/// keeps the test short (the script renders 500x500).
fn network_stats(scene: &Path, extra: &[&str]) -> NetworkStats {
    let dir = tempfile::tempdir().unwrap();
    let image = dir.path().join("network.png");
    let mut args = vec![
        "render",
        scene.to_str().unwrap(),
        "--integrator",
        "network",
        "--network-stats",
        "--width",
        "40",
        "--height",
        "40",
        "-o",
        image.to_str().unwrap(),
    ];
    args.extend(extra);
    let out = raylink(&args);
    let err = stderr(&out);
    assert!(out.status.success(), "{err}");
    let mb = |key: &str| after(&err, key, " MB").parse::<f64>().unwrap();
    let count = |suffix: &str| number_before(&err, suffix).to_string();
    let per_node: f64 = after(&err, " links (", " per node)").parse().unwrap();
    NetworkStats {
        patches: count(" patches, "),
        nodes: count(" nodes, "),
        slots: count(" slots per node"),
        links: count(" links ("),
        linked_per_node: format!("{per_node:.0}"),
        intersections: format!(
            "{:.2} M",
            number_before(&err, " line-patch intersections") as f64 / 1e6
        ),
        memory: format!("{:.1} MB", mb("memory ") + mb(" MB network + ")),
        sweeps: count(" sweeps, unshot"),
    }
}

/// Buckalew & Fussell's figures 7-10 (`python3 reproduce/buckalew_fussell.py`): the counts
/// of the networks the script builds (patches, nodes, links, slots, line-patch
/// intersections, memory, sweeps of the distribution) are the page's, in both tables.
#[test]
fn buckalew_fussell_networks_are_the_pages() {
    let office = ["--slopes", "20", "--intercept-step", "0.043"];
    // The script's figure 10: the office with its carpet waxed.
    let text = std::fs::read_to_string(manifest("scenes/network-office.toml")).unwrap();
    let (dull, waxed) = (
        "[materials.carpet]\ndiffuse = [0.15, 0.45, 0.15]\n",
        "[materials.carpet]\ndiffuse = [0.1, 0.32, 0.1]\nspecular = 0.3\nroughness = 0.08\n",
    );
    assert!(
        text.contains(dull),
        "the office's carpet is not the one the script waxes"
    );
    let dir = tempfile::tempdir().unwrap();
    let waxed_office = dir.path().join("network-office-waxed.toml");
    std::fs::write(&waxed_office, text.replace(dull, waxed)).unwrap();
    let figures = [
        (
            "7",
            network_stats(&manifest("scenes/network-room.toml"), &[]),
        ),
        (
            "8",
            network_stats(&manifest("scenes/network-mirror.toml"), &[]),
        ),
        (
            "9",
            network_stats(&manifest("scenes/network-office.toml"), &office),
        ),
        ("10", network_stats(&waxed_office, &office)),
    ];
    let hint = "(`python3 reproduce/buckalew_fussell.py` rewrites the page)";
    let block = page_block("buckalew-fussell:figures");
    for (figure, s) in &figures {
        for (column, fresh) in [
            ("patches", &s.patches),
            ("nodes", &s.nodes),
            ("links", &s.links),
            ("sweeps", &s.sweeps),
        ] {
            assert_eq!(
                &table_cell(&block, figure, column),
                fresh,
                "figure {figure}, {column} {hint}"
            );
        }
    }
    let block = page_block("buckalew-fussell:office");
    for (figure, s) in &figures[2..] {
        let column = format!("raylink, figure {figure}");
        for (row, fresh) in [
            ("patches", s.patches.clone()),
            (
                "links a patch",
                format!("{} slots, {} linked", s.slots, s.linked_per_node),
            ),
            ("line-patch intersections", s.intersections.clone()),
            ("network memory", s.memory.clone()),
        ] {
            assert_eq!(
                table_cell(&block, row, &column),
                fresh,
                "office, figure {figure}, {row} {hint}"
            );
        }
        let distribution = table_cell(&block, "distribution", &column);
        assert!(
            distribution.ends_with(&format!("({} sweeps)", s.sweeps)),
            "office, figure {figure}: {distribution:?} against {} sweeps {hint}",
            s.sweeps
        );
    }
}

/// Paths of each flux estimate of the Dutré, Lafortune & Willems table.
const FLUX_PATHS: u64 = 1_000_000;

/// "0.7257 ± 0.0021, 0.3881 ± 0.0012, 0.1126 ± 0.0004": a flux, red green blue, with its
/// standard errors.
fn flux_cell(f: &Flux) -> String {
    let (v, e) = (f.flux.to_array(), f.standard_error.to_array());
    (0..3)
        .map(|c| format!("{:.4} ± {:.4}", v[c], e[c]))
        .collect::<Vec<_>>()
        .join(", ")
}

/// The (value, standard error) pairs of a [`flux_cell`].
fn parse_flux_cell(cell: &str) -> Vec<(f64, f64)> {
    cell.split(", ")
        .map(|pair| {
            let (v, e) = pair
                .split_once(" ± ")
                .unwrap_or_else(|| panic!("{PAGE}: {cell:?} is not a flux"));
            (v.parse().unwrap(), e.parse().unwrap())
        })
        .collect()
}

/// The table without its last column (the seconds each estimate took, which vary).
fn without_seconds(block: &str) -> String {
    block
        .lines()
        .map(|l| match l.trim_end().strip_suffix('|') {
            Some(row) => &row[..row.rfind('|').unwrap_or(0)],
            None => l,
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// Dutré, Lafortune & Willems (`python3 reproduce/dutre_lafortune_willems.py` writes the
/// table this test prints): the flux arriving at three sets of surfaces of the Cornell box
/// with spheres, by gathering and by shooting. Asserted: the two estimates agree within 4
/// combined standard errors on every set and channel (the framework's ⟨L, W_e⟩ = ⟨L_e, W⟩);
/// on the Embree version the page names, the page's table is this run's, digit for digit
/// (a fixed seed makes the estimates a function of the build); on another (Embree's
/// traversal parts the paths in their last digits) every flux of the page is within 4
/// combined standard errors of this run's.
#[test]
fn dutre_lafortune_willems_fluxes_are_the_pages() {
    let scene = Scene::load(&manifest("scenes/cornell-spheres.toml")).unwrap();
    let embree = raylink::accel::embree_version().unwrap();
    let sets: [(&str, &[usize]); 3] = [
        ("rough gold sphere", &[0]),
        ("mirror and glass spheres", &[1, 2]),
        ("floor (caustics through the glass)", &[3]),
    ];
    let mut table = String::from(
        "| set of surfaces (flux arriving, W, red green blue) | gathering | shooting | largest \
         difference / σ | seconds, gathering and shooting |\n|---|---|---|---|---|\n",
    );
    for (name, surfaces) in sets {
        let run = |estimator| {
            let job = FluxJob {
                surfaces: surfaces.to_vec(),
                estimator,
                max_depth: 8,
                paths: FLUX_PATHS,
                seed: 7,
                threads: None,
                accel: Backend::Embree,
            };
            let start = std::time::Instant::now();
            let flux = estimate(&scene, &job, &Control::default()).unwrap();
            (flux, start.elapsed().as_secs_f64())
        };
        let ((gathered, tg), (shot, ts)) = (run(Estimator::Gathering), run(Estimator::Shooting));
        let sigmas = (0..3)
            .map(|c| {
                let s = gathered.standard_error[c].hypot(shot.standard_error[c]);
                (gathered.flux[c] - shot.flux[c]).abs() / s.max(1e-30)
            })
            .fold(0.0f32, f32::max);
        assert!(
            sigmas < 4.0,
            "{name}: gathering {gathered:?} against shooting {shot:?}"
        );
        table += &format!(
            "| {name} | {} | {} | {sigmas:.2} | {tg:.1}, {ts:.1} |\n",
            flux_cell(&gathered),
            flux_cell(&shot)
        );
    }
    table += &format!(
        "\n{FLUX_PATHS} paths for each estimate, 8 bounces, seed 7, Embree {embree}; σ combines \
         both standard errors. The paper states the identity and derives its algorithms from \
         it but measures no flux: the scene and the sets are raylink's, and so is the check.\n"
    );
    let name = "dutre-lafortune-willems:flux";
    eprintln!(
        "<!-- BEGIN {name} -->\n{}\n<!-- END {name} -->",
        table.trim()
    );
    if std::env::var_os(PRINT_ONLY).is_some() {
        return;
    }
    let page = page_block(name);
    let hint = "(`python3 reproduce/dutre_lafortune_willems.py` rewrites the page)";
    if page.contains(&format!(", Embree {embree};")) {
        assert_eq!(
            without_seconds(page.trim()),
            without_seconds(table.trim()),
            "{PAGE}, block {name}, differs from a fresh run {hint}"
        );
        return;
    }
    assert!(
        page.contains(", Embree "),
        "{PAGE}, block {name}, names no Embree version {hint}"
    );
    for (label, _) in sets {
        for column in ["gathering", "shooting"] {
            let fresh = parse_flux_cell(&table_cell(&table, label, column));
            let paged = parse_flux_cell(&table_cell(&page, label, column));
            assert_eq!(paged.len(), 3, "{label}, {column} {hint}");
            for ((v, e), (pv, pe)) in fresh.into_iter().zip(paged) {
                assert!(
                    (v - pv).abs() <= 4.0 * e.hypot(pe),
                    "{label}, {column}: page {pv} ± {pe}, this run (Embree {embree}) {v} ± {e} \
                     {hint}"
                );
            }
        }
    }
}

/// The cells of the row of `block`'s table whose first two cells are `mode` and `frame`.
fn row_cells(block: &str, mode: &str, frame: &str) -> Vec<String> {
    let row = block
        .lines()
        .find(|l| l.starts_with(&format!("| {mode} | {frame} |")))
        .unwrap_or_else(|| panic!("{PAGE}: no row {mode:?} {frame:?} in:\n{block}"));
    row.trim_matches('|')
        .split('|')
        .map(|c| c.trim().to_string())
        .collect()
}

/// Jevans's Table 2 (`python3 reproduce/jevans.py`): the pixels retraced in the frames the
/// page shows and in the whole sequence, and the rays the coherent frames traced, online and
/// with look-ahead, are the page's. (The full renders' rays are not compared: they would
/// take 351 more frames a mode.)
#[test]
fn jevans_retraced_pixels_are_the_pages() {
    let block = page_block("jevans:table");
    let hint = "(`python3 reproduce/jevans.py` rewrites the page)";
    for (mode, flags) in [("online", &[][..]), ("look-ahead", &["--lookahead"][..])] {
        let dir = std::env::temp_dir().join(format!(
            "raylink-repro-jevans-{}-{mode}",
            std::process::id()
        ));
        std::fs::create_dir_all(&dir).unwrap();
        let (frames, csv) = (dir.join("f_%03d.jpg"), dir.join("frames.csv"));
        let mut args = vec![
            "animate",
            "scenes/anim-audition.toml",
            "--spp",
            "1",
            "--width",
            "640",
            "--height",
            "480",
            "--quiet",
            "-o",
            frames.to_str().unwrap(),
            "--csv",
            csv.to_str().unwrap(),
        ];
        args.extend_from_slice(flags);
        let out = raylink(&args);
        let text = std::fs::read_to_string(&csv).unwrap_or_default();
        std::fs::remove_dir_all(&dir).unwrap();
        assert!(out.status.success(), "{}", stderr(&out));
        let mut lines = text.lines();
        let head: Vec<&str> = lines.next().expect("a CSV header").split(',').collect();
        let col = |name: &str| head.iter().position(|h| *h == name).unwrap();
        let (frame, pixels, rays) = (col("frame"), col("pixels_retraced"), col("rays"));
        let rows: Vec<Vec<u64>> = lines
            .map(|l| l.split(',').map(|c| c.parse().unwrap_or(0)).collect())
            .collect();
        assert_eq!(rows.len(), 351);
        for r in &rows {
            let f = r[frame].to_string();
            if [0, 1, 75, 150, 200, 350].contains(&r[frame]) {
                let cells = row_cells(&block, mode, &f);
                assert_eq!(
                    integers(&cells[2]),
                    [r[pixels]],
                    "{mode} frame {f}: pixels retraced {hint}"
                );
            }
        }
        let total: u64 = rows.iter().map(|r| r[pixels]).sum();
        let cells = row_cells(&block, mode, "**entire sequence**");
        assert_eq!(
            integers(&cells[2]),
            [total],
            "{mode}: pixels retraced {hint}"
        );
        let traced: u64 = rows.iter().map(|r| r[rays]).sum();
        let note = format!("{mode}: all rays (with reflection, refraction and shadow rays) ");
        let line = block
            .lines()
            .find_map(|l| l.strip_prefix("- ")?.strip_prefix(note.as_str()))
            .unwrap_or_else(|| panic!("{PAGE}: no line {note:?}"));
        assert_eq!(integers(line)[0], traced, "{mode}: rays {hint}");
    }
}
