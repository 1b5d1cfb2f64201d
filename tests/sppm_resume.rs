//! Stochastic progressive photon mapping renders in iterations a viewer sees and a
//! checkpoint saves: the film shown after k iterations is exactly a k-iteration render's
//! image; a render stopped between iterations, saved to a checkpoint file and read back,
//! resumes (on another thread count) to the same bits as the uninterrupted render, through
//! the library and through the command line (SIGINT, then `--resume`); a film that is not
//! SPPM's is refused.

use raylink::{
    checkpoint, Control, Film, Image, Job, RenderStats, Renderer, Scene, Settings, Shown,
    Technique, TechniqueKind, Watch,
};
use std::path::Path;
use std::sync::Arc;

mod common;
use common::process::{finish, signal, spawn, wait_for};

fn scene(name: &str) -> Arc<Scene> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes")
        .join(name);
    Arc::new(Scene::load(&path).unwrap())
}

fn sppm(iterations: u32) -> Settings {
    Settings {
        integrator: Some(TechniqueKind::Sppm),
        spp: Some(iterations),
        max_depth: Some(5),
        photons_per_iteration: Some(3000),
        sppm_radius: Some(0.08),
        ..Settings::default()
    }
}

fn job(scene: &Arc<Scene>, iterations: u32, threads: usize) -> Job {
    Job {
        width: 24,
        height: 24,
        seed: 7,
        threads: Some(threads),
        ..Job::new(scene, Technique::create(&sppm(iterations)).unwrap())
    }
}

fn render(scene: &Arc<Scene>, iterations: u32, threads: usize) -> Image {
    let control = Control::default();
    let rendered = Renderer::new(scene.clone(), job(scene, iterations, threads), &control)
        .unwrap()
        .render(&control)
        .unwrap();
    assert!(!rendered.is_partial());
    rendered.image
}

/// The glass and mirror spheres' box: caustics, so that photons matter.
#[test]
fn a_stopped_render_shows_each_iteration_and_resumes_to_the_same_image() {
    let s = scene("cornell-spheres.toml");
    let full = render(&s, 6, 2);
    let two = render(&s, 2, 2);
    let control = Control::default();
    let cancel = control.cancel.clone();
    let mut shown: Vec<(u32, Image)> = Vec::new();
    let mut show = |film: &Film, when: Shown, _: &RenderStats| {
        assert_eq!(when, Shown::AfterPass, "SPPM shows whole iterations only");
        shown.push((film.spp, film.image()?));
        if film.spp == 3 {
            cancel.cancel();
        }
        Ok(())
    };
    let watch = Watch {
        film: &mut show,
        mid_pass: Some(std::time::Duration::ZERO),
    };
    let stopped = Renderer::new(s.clone(), job(&s, 6, 2), &control)
        .unwrap()
        .render_progressive(&control, None, watch)
        .unwrap();
    assert!(stopped.is_partial());
    let counts: Vec<u32> = shown.iter().map(|(k, _)| *k).collect();
    assert_eq!(counts, [1, 2, 3]);
    assert!(
        shown[1].1.pixels == two.pixels,
        "the film after two iterations is not a two-iteration render's image"
    );
    assert!(
        shown[2].1.pixels != two.pixels,
        "the third iteration added nothing"
    );
    let film = stopped.film.expect("an SPPM render keeps its film");
    assert_eq!(film.spp, 3);
    assert!(stopped.image.pixels == shown[2].1.pixels);

    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("sppm.checkpoint");
    checkpoint::save(&file, &film, "sppm test", 0).unwrap();
    // Resumed on one thread: the image depends on neither.
    let resumed_job = job(&s, 6, 1);
    let blank = resumed_job.blank_film().unwrap().unwrap();
    let resumed = checkpoint::load(&file, "sppm test", blank, 6).unwrap().film;
    let control = Control::default();
    let finished = Renderer::new(s.clone(), resumed_job, &control)
        .unwrap()
        .render_progressive(&control, Some(resumed), Watch::nobody())
        .unwrap();
    assert!(!finished.is_partial());
    assert!(
        finished.image.pixels == full.pixels,
        "the resumed render differs from the uninterrupted one"
    );

    // A checkpoint of six iterations has nothing left to resume; a path tracer's film is
    // not SPPM's.
    let blank = job(&s, 6, 1).blank_film().unwrap().unwrap();
    let done = finished.film.unwrap();
    checkpoint::save(&file, &done, "sppm test", 0).unwrap();
    let e = checkpoint::load(&file, "sppm test", blank, 6)
        .err()
        .expect("a finished render's film is refused")
        .to_string();
    assert!(e.contains("nothing to resume"), "{e}");
    let path_job = Job::new(
        &s,
        Technique::create(&Settings {
            integrator: Some(TechniqueKind::Path),
            spp: Some(4),
            ..Settings::default()
        })
        .unwrap(),
    );
    let other = Job {
        width: 24,
        height: 24,
        ..path_job
    }
    .blank_film()
    .unwrap()
    .unwrap();
    let control = Control::default();
    let e = Renderer::new(s.clone(), job(&s, 6, 1), &control)
        .unwrap()
        .render_progressive(&control, Some(other), Watch::nobody())
        .unwrap_err()
        .to_string();
    assert!(e.contains("another technique"), "{e}");
}

/// The command line: a render interrupted by SIGINT after a checkpoint exits 130 keeping
/// it, and `--resume` finishes the same image as an uninterrupted run, removing it.
#[test]
fn an_interrupted_command_line_render_resumes_from_its_checkpoint() {
    let dir = tempfile::tempdir().unwrap();
    let full = dir.path().join("full.exr");
    let part = dir.path().join("part.exr");
    let command = |out: &Path| -> Vec<String> {
        [
            "render",
            "scenes/cornell-box.toml",
            "--integrator",
            "sppm",
            "--width",
            "16",
            "--height",
            "16",
            "--spp",
            "3000",
            "--photons-per-iteration",
            "500",
            "--max-depth",
            "3",
            "-q",
            "-o",
            out.to_str().unwrap(),
        ]
        .map(String::from)
        .to_vec()
    };
    let args = command(&full);
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let run = common::raylink(&args);
    assert!(run.status.success(), "{}", common::stderr(&run));

    let mut interrupted = command(&part);
    interrupted.extend(["--checkpoint-interval", "0"].map(String::from));
    let interrupted: Vec<&str> = interrupted.iter().map(String::as_str).collect();
    let checkpoint = dir.path().join("part.exr.checkpoint");
    let mut child = spawn(&interrupted);
    wait_for(&mut child, &checkpoint);
    signal(&child, nix::sys::signal::Signal::SIGINT);
    let out = finish(child);
    assert_eq!(out.status.code(), Some(130), "{}", common::stderr(&out));
    assert!(
        checkpoint.exists(),
        "the interrupted render kept no checkpoint"
    );
    let note = common::stderr(&out);
    assert!(note.contains("iterations"), "{note}");

    let mut resume = command(&part);
    resume.push("--resume".into());
    let resume: Vec<&str> = resume.iter().map(String::as_str).collect();
    let run = common::raylink(&resume);
    assert!(run.status.success(), "{}", common::stderr(&run));
    assert!(
        !checkpoint.exists(),
        "the finished render left its checkpoint"
    );
    let read = |p: &Path| raylink::read_image(p).unwrap().0.pixels;
    assert!(
        read(&part) == read(&full),
        "the resumed render differs from the uninterrupted one"
    );
}
