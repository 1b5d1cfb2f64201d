//! `raylink serve`: raylink studio, a live view of a render in the browser. The server
//! (`http.rs`) answers the page and its API (`api.rs`); the render session (`session.rs`)
//! runs the library's jobs on a thread of its own. SIGINT or SIGTERM stops it (exit 128 +
//! the signal, as a render).

mod api;
mod frames;
mod http;
mod session;

use crate::options::{self, RenderArgs};
use crate::{render, Cli, Failure};
use raylink::scene::Texture;
use raylink::{Error, Renderer, Settings, TechniqueKind};
use std::io::Read;
use std::net::{IpAddr, SocketAddr};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

const STUDIO: &str = "Studio";

#[derive(clap::Args)]
pub struct ServeArgs {
    #[command(flatten)]
    pub render: RenderArgs,
    /// TCP port to listen on (0: any free port; the URL printed names it).
    #[arg(long, default_value_t = 8765, help_heading = STUDIO)]
    port: u16,
    /// Address to listen on. Any address but a loopback one (127.0.0.1, ::1) needs --token,
    /// or gets a random token, printed with the URL.
    #[arg(long, default_value = "127.0.0.1", value_name = "ADDRESS", help_heading = STUDIO)]
    bind: String,
    /// Every request must carry this token (?token=T, or the header Authorization: Bearer
    /// T): letters, digits and - . _ ~ only.
    #[arg(long, help_heading = STUDIO)]
    token: Option<String>,
    /// An image of the same size to compare against: a split view, and its RMSE.
    #[arg(long, value_name = "IMAGE", help_heading = STUDIO)]
    reference: Option<PathBuf>,
    /// Where "save" writes its images (studio-NNNN.exr, .png); the page never names a file.
    #[arg(long, value_name = "DIR", default_value = ".", help_heading = STUDIO)]
    save_dir: PathBuf,
}

/// The render options that mean nothing to a live view.
fn refuse_render_only(a: &RenderArgs) -> Result<(), Error> {
    let given = [
        ("-o/--output", !a.outputs.is_empty()),
        ("--write-interval", a.write_interval.is_some()),
        ("--checkpoint-interval", a.checkpoint_interval.is_some()),
        ("--resume", a.resume),
        ("--tile/--crop", a.part.part().is_some()),
        ("--aov", a.aov),
        ("--exposure", a.exposure.is_some()),
        ("--half", a.half),
        ("--color-space", a.color_space.is_some()),
    ];
    match given.iter().find(|(_, g)| *g) {
        Some((name, _)) => Err(Error::Invalid(format!(
            "{name} does not apply to serve (the page shows, saves and sets the exposure)"
        ))),
        None => Ok(()),
    }
}

/// `n` random bytes as hex, from the kernel.
fn random_hex(n: usize) -> Result<String, Error> {
    let mut bytes = vec![0u8; n];
    std::fs::File::open("/dev/urandom")
        .and_then(|mut f| f.read_exact(&mut bytes))
        .map_err(|e| Error::io(std::path::Path::new("/dev/urandom"), e))?;
    Ok(bytes.iter().map(|b| format!("{b:02x}")).collect())
}

pub fn run(cli: &Cli, args: ServeArgs) -> Result<(), Failure> {
    let ServeArgs {
        render: mut args,
        port,
        bind,
        token,
        reference,
        save_dir,
    } = args;
    refuse_render_only(&args)?;
    options::check(&args)?;
    let ip: IpAddr = bind.parse().map_err(|_| {
        Error::Invalid(format!(
            "--bind takes an IP address (127.0.0.1, ::1, 0.0.0.0), got {bind:?}"
        ))
    })?;
    if let Some(t) = &token {
        let ok = !t.is_empty()
            && t.len() <= 256
            && t.bytes()
                .all(|b| b.is_ascii_alphanumeric() || b"-._~".contains(&b));
        if !ok {
            return Err(Error::Invalid(
                "--token takes 1 to 256 letters, digits, '-', '.', '_' or '~'".into(),
            )
            .into());
        }
    }
    let token = match token {
        None if !ip.is_loopback() => {
            let t = random_hex(16)?;
            eprintln!("raylink serve: {ip} is not a loopback address: every request needs the token printed with the URL");
            Some(t)
        }
        t => t,
    };
    if !save_dir.is_dir() {
        return Err(Error::Invalid(format!(
            "--save-dir {}: no such directory",
            save_dir.display()
        ))
        .into());
    }
    let control = cli.control(true, args.max_memory.as_deref())?;
    let (scene, animation) = render::load_scene_and_animation(&args.scene, &control)?;
    let mut job = options::job(&args, &scene, Settings::default())?;
    // The network's relights read its file: without --network-file, one for this run.
    let mut temporary = None;
    if job.technique.kind() == TechniqueKind::Network && args.network.network_file.is_none() {
        let path = std::env::temp_dir().join(format!(
            "raylink-studio-{}-{}.rlnet",
            std::process::id(),
            random_hex(8)?
        ));
        args.network.network_file = Some(path.clone());
        temporary = Some(path);
        job = options::job(&args, &scene, Settings::default())?;
    }
    // The images the page saves take names that are free (`studio-NNNN`).
    let mut plan = raylink::output_paths::FilePlan::new();
    plan.reads("an input of the scene", &scene.inputs)
        .reads("--reference", &reference);
    render::technique_files(&mut plan, &args);
    plan.check()?;
    let reference = match &reference {
        None => None,
        Some(path) => {
            let (image, _) = raylink::read_image(path)?;
            if (image.width, image.height) != (job.width, job.height) {
                return Err(Error::input(
                    path,
                    format!(
                        "the reference is {}x{}, the render {}x{}",
                        image.width, image.height, job.width, job.height
                    ),
                )
                .into());
            }
            Some(image)
        }
    };
    let named = |m: &&raylink::scene::Material| !m.name.is_empty();
    let lights: Vec<String> = (scene.materials.iter().filter(named))
        .filter(|m| m.emission.max_element() > 0.0)
        .map(|m| m.name.clone())
        .collect();
    let materials: Vec<String> = (scene.materials.iter().filter(named))
        .filter(|m| m.emission.max_element() <= 0.0)
        .filter(
            |m| matches!(m.approximation().diffuse, Texture::Constant(c) if c.max_element() > 0.0),
        )
        .map(|m| m.name.clone())
        .collect();
    let listener = http::bind(SocketAddr::new(ip, port)).map_err(Error::Invalid)?;
    let addr = listener
        .local_addr()
        .map_err(|e| Error::Invalid(format!("the listening socket: {e}")))?;
    // A keyframed scene gets a frame slider.
    let frames = animation
        .filter(|a| a.is_animated())
        .map(|a| frames::Frames::new(a, &job));
    let scene = Arc::new(scene);
    let renderer = Renderer::new(scene.clone(), job.clone(), &control)?;
    let scene_name = args.scene.display().to_string();
    let session = Arc::new(session::Session::new(session::Base {
        scene,
        job: job.clone(),
        budget: control.budget,
        reference,
        lights,
        materials,
        frames: frames.as_ref().map(|f| {
            let numbers = f.animation.frame_numbers();
            (numbers.start, numbers.end - 1)
        }),
    }));
    let api = Arc::new(api::Api::new(
        session.clone(),
        token.clone(),
        addr,
        save_dir,
        scene_name.clone(),
    ));
    let query = token.map(|t| format!("?token={t}")).unwrap_or_default();
    println!("raylink studio: http://{addr}/{query}");
    let _ = std::io::Write::flush(&mut std::io::stdout());
    if !args.quiet {
        eprintln!(
            "serving {scene_name} ({} integrator, {}x{}); Ctrl-C stops",
            job.technique.kind(),
            job.width,
            job.height
        );
    }
    let worker = {
        let session = session.clone();
        std::thread::Builder::new()
            .name("raylink-studio".into())
            .spawn(move || session::work(&session, renderer, frames))
            .map_err(|e| Error::Invalid(format!("cannot start the render thread: {e}")))?
    };
    let stop = Arc::new(AtomicBool::new(false));
    let server = {
        let stop = stop.clone();
        let handler: Arc<dyn Fn(&http::Request) -> http::Reply + Send + Sync> =
            Arc::new(move |r| api.handle(r));
        std::thread::Builder::new()
            .name("raylink-http-accept".into())
            .spawn(move || http::serve(listener, stop, handler))
            .map_err(|e| Error::Invalid(format!("cannot start the server thread: {e}")))?
    };
    while cli.signals.received().is_none() && !server.is_finished() {
        std::thread::sleep(Duration::from_millis(20));
    }
    stop.store(true, Ordering::Relaxed);
    session.quit();
    let _ = worker.join();
    let served = server.join();
    if let Some(path) = temporary {
        let _ = std::fs::remove_file(path);
    }
    if let Ok(Err(e)) = served {
        return Err(Error::Invalid(format!("the server stopped: {e}")).into());
    }
    Err(Failure::Interrupted {
        signal: cli.signals.received().unwrap_or(2),
        detail: format!("{}: the studio stopped", cli.stopped_by()),
    })
}
