//! The studio's routes: the page, the state as JSON, the events stream, the images as raw
//! floats, and the commands (camera, view, relight, frame, auxiliary images, save). Every
//! request is checked first: the token when one is set, else that it names this machine as
//! its host (a page elsewhere cannot reach the server through a name that resolves here).
//! The API answers no other site's page ([`cross_site`]), reads change nothing, and
//! commands must be JSON (which a page of another origin cannot send without the server's
//! consent). The paths are matched as whole strings: none reaches the file system.

use super::http::{self, Reply, Request, Response};
use super::session::{lock, Move, RelightRequest, Session, State, Status};
use raylink::math::{Rgb, Vec3};
use raylink::{write_image, Image, MetaValue, OutputOptions};
use serde::Deserialize;
use serde_json::{json, Value};
use std::collections::BTreeMap;
use std::io::Write;
use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

/// Event streams open at once (each holds a connection).
const MAX_STREAMS: usize = 8;

/// What the routes need.
pub struct Api {
    pub session: Arc<Session>,
    pub token: Option<String>,
    /// The address listened on, for the host check.
    pub addr: std::net::SocketAddr,
    pub page: String,
    pub save_dir: PathBuf,
    pub scene_name: String,
    streams: Arc<AtomicUsize>,
    saves: Mutex<u32>,
}

impl Api {
    pub fn new(
        session: Arc<Session>,
        token: Option<String>,
        addr: std::net::SocketAddr,
        save_dir: PathBuf,
        scene_name: String,
    ) -> Api {
        let page = include_str!("page.html")
            .replace("/*STYLE*/", include_str!("page.css"))
            .replace("/*SCRIPT*/", include_str!("page.js"));
        Api {
            session,
            token,
            addr,
            page,
            save_dir,
            scene_name,
            streams: Arc::new(AtomicUsize::new(0)),
            saves: Mutex::new(0),
        }
    }

    pub fn handle(&self, r: &Request) -> Reply {
        if let Err(refused) = self.admit(r) {
            return Reply::Full(refused);
        }
        // Before any route: a refused event stream takes none of the slots.
        if r.path.starts_with("/api/") {
            if let Some(why) = cross_site(r) {
                return Reply::Full(Response::text(403, why));
            }
        }
        let get = r.method == "GET";
        let response = match (r.path.as_str(), get) {
            // The page's script and style are inline, in the page.
            ("/", true) => Response::new(200, "text/html; charset=utf-8", self.page.clone())
                .with_policy(
                    "default-src 'none'; script-src 'unsafe-inline'; style-src \
                     'unsafe-inline'; connect-src 'self'; img-src 'self' blob: data:",
                ),
            ("/api/state", true) => Response::json(&self.state()),
            ("/api/events", true) => return self.events(),
            ("/api/image", true) => self.image(r),
            ("/api/camera.toml", true) => {
                let camera = lock(&self.session.state).camera.clone();
                Response::new(
                    200,
                    "text/plain; charset=utf-8",
                    raylink::scene::convert::camera_toml(&camera),
                )
            }
            ("/api/camera", false) => self.command(r, |api, body| api.camera(body)),
            ("/api/view", false) => self.command(r, |api, body| api.view(body)),
            ("/api/aovs", false) => self.command(r, |api, body| api.aovs(body)),
            ("/api/relight", false) => self.command(r, |api, body| api.relight(body)),
            ("/api/frame", false) => self.command(r, |api, body| api.frame(body)),
            ("/api/save", false) => self.command(r, |api, body| api.save(body)),
            (
                "/" | "/api/state" | "/api/events" | "/api/image" | "/api/camera.toml"
                | "/api/camera" | "/api/view" | "/api/aovs" | "/api/relight" | "/api/frame"
                | "/api/save",
                _,
            ) => Response::text(405, "method not allowed"),
            _ => Response::text(404, "not found"),
        };
        Reply::Full(response)
    }

    /// The token, or (without one) the host check.
    fn admit(&self, r: &Request) -> Result<(), Response> {
        match &self.token {
            Some(token) => {
                let given = r
                    .param("token")
                    .or_else(|| r.header("authorization").and_then(bearer_token));
                match given {
                    None => Err(Response::text(401, "a token is needed: ?token=T")
                        .with_header("WWW-Authenticate", "Bearer".into())),
                    Some(g) if !same(g.trim().as_bytes(), token.as_bytes()) => {
                        Err(Response::text(403, "wrong token"))
                    }
                    Some(_) => Ok(()),
                }
            }
            None => {
                let host = r.header("host").unwrap_or_default();
                let p = self.addr.port();
                let local = [
                    format!("127.0.0.1:{p}"),
                    format!("localhost:{p}"),
                    format!("[::1]:{p}"),
                    self.addr.to_string(),
                ];
                if local.iter().any(|l| l.eq_ignore_ascii_case(host)) {
                    Ok(())
                } else {
                    Err(Response::text(
                        403,
                        "this server answers only to its own address, 127.0.0.1, localhost or \
                         [::1] as its host",
                    ))
                }
            }
        }
    }

    /// A JSON command: refused unless JSON (the origin was checked with every API
    /// request's); a body that is not what `run` expects is a 400.
    fn command(
        &self,
        r: &Request,
        run: impl FnOnce(&Api, &[u8]) -> Result<Value, (u16, String)>,
    ) -> Response {
        let json = r.header("content-type").is_some_and(is_json);
        if !json {
            return Response::text(415, "commands are JSON: Content-Type: application/json");
        }
        match run(self, &r.body) {
            Ok(v) => Response::json(&v),
            Err((status, why)) => Response::text(status, &why),
        }
    }

    fn camera(&self, body: &[u8]) -> Result<Value, (u16, String)> {
        #[derive(Deserialize)]
        #[serde(deny_unknown_fields)]
        struct Body {
            position: [f32; 3],
            look_at: [f32; 3],
            up: Option<[f32; 3]>,
            fov: Option<f32>,
            /// The move continues the one before it (a drag's): one step back undoes both.
            #[serde(default)]
            continues: bool,
        }
        let b: Body = parse(body)?;
        let mut camera = lock(&self.session.state).camera.clone();
        camera.position = Vec3::from(b.position);
        camera.look_at = Vec3::from(b.look_at);
        if let Some(up) = b.up {
            camera.up = Vec3::from(up);
        }
        if let Some(fov) = b.fov {
            camera.fov_deg = fov;
        }
        // Every quantity the rays are made of, as a scene file's camera is checked.
        if let Err(p) = camera.check() {
            return Err((400, format!("camera {} {}", p.field, p.message)));
        }
        self.session.move_camera(Move::To(camera, b.continues));
        Ok(json!({"ok": true}))
    }

    /// Back to the camera before the last move, or to the scene file's: a way back from
    /// a view that left the scene.
    fn view(&self, body: &[u8]) -> Result<Value, (u16, String)> {
        #[derive(Deserialize)]
        #[serde(deny_unknown_fields)]
        struct Body {
            to: String,
        }
        let b: Body = parse(body)?;
        let to = match b.to.as_str() {
            "previous" => Move::Back,
            "scene" => Move::Reset,
            _ => return Err((400, "to: previous or scene".into())),
        };
        if !self.session.move_camera(to) {
            return Err((409, "no earlier view to go back to".into()));
        }
        Ok(json!({"ok": true}))
    }

    /// Whether the auxiliary images are computed for every view: asked for here, never as
    /// a side effect of reading one.
    fn aovs(&self, body: &[u8]) -> Result<Value, (u16, String)> {
        #[derive(Deserialize)]
        #[serde(deny_unknown_fields)]
        struct Body {
            wanted: bool,
        }
        let b: Body = parse(body)?;
        self.session.want_aovs(b.wanted);
        Ok(json!({"ok": true}))
    }

    fn relight(&self, body: &[u8]) -> Result<Value, (u16, String)> {
        #[derive(Deserialize)]
        #[serde(deny_unknown_fields)]
        struct Body {
            #[serde(default)]
            lights: BTreeMap<String, Factor>,
            #[serde(default)]
            materials: BTreeMap<String, Factor>,
        }
        /// One factor for every channel, or one a channel (a colour).
        #[derive(Deserialize)]
        #[serde(untagged)]
        enum Factor {
            All(f32),
            Channels([f32; 3]),
        }
        let b: Body = parse(body)?;
        let base = &self.session.base;
        let mut request = lock(&self.session.state).relight.clone();
        for (given, known, what, max) in [
            (&b.lights, &mut request.lights, "light", 1e4f32),
            (&b.materials, &mut request.materials, "material", 2.0),
        ] {
            for (name, k) in given {
                let Some(entry) = known.iter_mut().find(|(n, _)| n == name) else {
                    return Err((400, format!("no {what} named {name:?}")));
                };
                let k = match *k {
                    Factor::All(k) => Rgb::splat(k),
                    Factor::Channels(k) => Rgb::from(k),
                };
                if !(k.is_finite() && k.min_element() >= 0.0 && k.max_element() <= max) {
                    return Err((
                        400,
                        format!("{what} {name:?}: a factor (or one a channel) from 0 to {max}"),
                    ));
                }
                entry.1 = k;
            }
        }
        // A diffuse colour must reflect less than all the light it gets.
        for (name, k) in &request.materials {
            let m = base.scene.materials.iter().find(|m| &m.name == name);
            if let Some(raylink::scene::Texture::Constant(c)) =
                m.map(|m| &m.approximation().diffuse)
            {
                if (*c * *k).max_element() >= 1.0 {
                    let k = k.to_array();
                    return Err((
                        400,
                        format!("material {name:?}: {k:?} times its colour reflects 1 or more"),
                    ));
                }
            }
        }
        self.session.relight(RelightRequest {
            lights: request.lights,
            materials: request.materials,
        });
        Ok(json!({"ok": true}))
    }

    fn frame(&self, body: &[u8]) -> Result<Value, (u16, String)> {
        #[derive(Deserialize)]
        #[serde(deny_unknown_fields)]
        struct Body {
            frame: i64,
        }
        let b: Body = parse(body)?;
        let Some((first, last)) = self.session.base.frames else {
            return Err((409, "the scene has no keyframes".into()));
        };
        if !(first..=last).contains(&b.frame) {
            return Err((400, format!("frame: {first} to {last}")));
        }
        self.session.set_frame(b.frame);
        Ok(json!({"ok": true}))
    }

    fn save(&self, body: &[u8]) -> Result<Value, (u16, String)> {
        #[derive(Deserialize)]
        #[serde(deny_unknown_fields)]
        struct Body {
            format: String,
            exposure: Option<f32>,
        }
        let b: Body = parse(body)?;
        let ext = match b.format.as_str() {
            "exr" | "png" => b.format.as_str(),
            _ => return Err((400, "format: exr or png".into())),
        };
        let exposure = b.exposure.unwrap_or(0.0);
        if !(exposure.is_finite() && exposure.abs() <= 20.0) {
            return Err((400, "exposure: -20 to 20 stops".into()));
        }
        let (image, spp, partial) = {
            let s = lock(&self.session.state);
            let Some(image) = s.image.clone() else {
                return Err((409, "no image yet".into()));
            };
            (image, s.spp, s.status != Status::Done)
        };
        // One save at a time, so that two never pick the same name.
        let mut count = lock(&self.saves);
        let path = loop {
            *count += 1;
            let p = self.save_dir.join(format!("studio-{:04}.{ext}", *count));
            if !p.exists() {
                break p;
            }
            if *count > 9999 {
                return Err((
                    409,
                    "the save directory has studio-0001 to 9999 already".into(),
                ));
            }
        };
        let job = &self.session.base.job;
        let mut meta = vec![
            (
                "Software".to_string(),
                MetaValue::Str(format!("raylink {} studio", raylink::VERSION)),
            ),
            (
                "raylink:scene".into(),
                MetaValue::Str(self.scene_name.clone()),
            ),
            (
                "raylink:integrator".into(),
                MetaValue::Str(job.technique.kind().to_string()),
            ),
            ("raylink:seed".into(), MetaValue::Str(job.seed.to_string())),
            (
                "raylink:samples_per_pixel".into(),
                MetaValue::Float(spp as f32),
            ),
        ];
        if job.technique.monte_carlo().is_some_and(|m| m.spectral) {
            meta.push((
                "raylink:spectral".into(),
                MetaValue::Str("true (three sampled wavelengths, output linear sRGB)".into()),
            ));
        }
        if partial {
            meta.push(("raylink:partial".into(), MetaValue::Int(1)));
        }
        let options = OutputOptions::new(if ext == "png" { exposure } else { 0.0 }, false);
        write_image(&path, &image, &meta, &options)
            .map_err(|e| (500, raylink::error::one_line(&e.to_string())))?;
        let name = path.file_name().unwrap_or_default().to_string_lossy();
        Ok(json!({"file": name, "path": path.display().to_string()}))
    }

    /// The image of `?kind=` (beauty, albedo, normal, depth, reference) as little-endian
    /// 32-bit floats, RGB, rows top to bottom.
    fn image(&self, r: &Request) -> Response {
        let kind = r.param("kind").unwrap_or("beauty");
        let (image, version, spp, view): (Arc<Image>, u64, f64, u64) = {
            let s = lock(&self.session.state);
            let aov = || {
                s.aovs
                    .as_ref()
                    .filter(|a| a.0 == s.view)
                    .map(|a| a.1.clone())
            };
            match kind {
                "beauty" => match &s.image {
                    Some(i) => (i.clone(), s.image_version, s.spp, s.image_view),
                    None => return Response::text(409, "no image yet"),
                },
                "albedo" | "normal" | "depth" => {
                    let i = ["albedo", "normal", "depth"]
                        .iter()
                        .position(|k| *k == kind)
                        .unwrap_or(0);
                    match aov() {
                        Some(a) => (Arc::new(a[i].clone()), s.view, 1.0, s.view),
                        None if s.aovs_wanted => {
                            return Response::text(409, "computing the auxiliary images")
                        }
                        None => {
                            return Response::text(
                                409,
                                "auxiliary images are not computed: POST /api/aovs first",
                            )
                        }
                    }
                }
                "reference" => match &self.session.base.reference {
                    Some(i) => (Arc::new(i.clone()), 0, 0.0, 0),
                    None => return Response::text(404, "no --reference image"),
                },
                "retrace" => match &s.retrace_map {
                    Some(i) => (i.clone(), s.image_version, s.spp, s.image_view),
                    None => return Response::text(409, "no frame rendered coherently yet"),
                },
                _ => {
                    return Response::text(
                        400,
                        "kind: beauty, albedo, normal, depth, reference or retrace",
                    )
                }
            }
        };
        let mut body = Vec::with_capacity(image.pixels.len() * 12);
        for p in &image.pixels {
            for c in [p.x, p.y, p.z] {
                body.extend_from_slice(&c.to_le_bytes());
            }
        }
        Response::new(200, "application/octet-stream", body)
            .with_header("X-Width", image.width.to_string())
            .with_header("X-Height", image.height.to_string())
            .with_header("X-Version", version.to_string())
            .with_header("X-Spp", spp.to_string())
            .with_header("X-View", view.to_string())
    }

    pub fn state(&self) -> Value {
        let s = lock(&self.session.state);
        state_json(&self.session, &s)
    }

    /// Server-sent events: the state as one `data:` line whenever it changes (at most
    /// every 30 ms), a comment every 15 s so that a closed page is noticed.
    fn events(&self) -> Reply {
        if self.streams.fetch_add(1, Ordering::SeqCst) >= MAX_STREAMS {
            self.streams.fetch_sub(1, Ordering::SeqCst);
            return Reply::Full(Response::text(503, "too many event streams"));
        }
        let (session, streams) = (self.session.clone(), self.streams.clone());
        Reply::Stream(Box::new(move |stream| {
            let _ = stream_events(&session, stream);
            streams.fetch_sub(1, Ordering::SeqCst);
        }))
    }
}

fn stream_events(session: &Session, stream: &mut std::net::TcpStream) -> std::io::Result<()> {
    stream.write_all(format!("{}\r\n", http::head(200, "text/event-stream", None)).as_bytes())?;
    let mut seen = 0;
    loop {
        let text = {
            let mut s = lock(&session.state);
            let deadline = std::time::Instant::now() + Duration::from_secs(15);
            while s.version == seen && !session.quitting() {
                let left = deadline.saturating_duration_since(std::time::Instant::now());
                if left.is_zero() {
                    break;
                }
                s = session
                    .changed
                    .wait_timeout(s, left)
                    .unwrap_or_else(|e| e.into_inner())
                    .0;
            }
            if session.quitting() {
                return Ok(());
            }
            if s.version == seen {
                ": keep-alive\n\n".to_string()
            } else {
                seen = s.version;
                format!("data: {}\n\n", state_json(session, &s))
            }
        };
        stream.write_all(text.as_bytes())?;
        stream.flush()?;
        std::thread::sleep(Duration::from_millis(30));
    }
}

fn state_json(session: &Session, s: &State) -> Value {
    let base = &session.base;
    let (status, error) = match &s.status {
        Status::Preparing => ("preparing", None),
        Status::Rendering => ("rendering", None),
        Status::Done => ("done", None),
        Status::Failed(e) => ("failed", Some(e.clone())),
    };
    let c = &s.camera;
    let v = |v: Vec3| [v.x, v.y, v.z];
    let p = &session.progress;
    let elapsed = if s.status == Status::Done {
        s.elapsed
    } else {
        s.started.elapsed().as_secs_f64()
    };
    let colour = |name: &str| {
        base.scene
            .materials
            .iter()
            .find(|m| m.name == name)
            .and_then(|m| match m.approximation().diffuse {
                raylink::scene::Texture::Constant(c) => Some([c.x, c.y, c.z]),
                _ => None,
            })
    };
    json!({
        "version": s.version,
        "image_version": s.image_version,
        "width": base.job.width,
        "height": base.job.height,
        "integrator": base.job.technique.kind().to_string(),
        "progressive": base.job.technique.passes().is_some(),
        "spectral": base.job.technique.monte_carlo().is_some_and(|m| m.spectral),
        "spp": s.spp,
        "target_spp": base.job.technique.passes(),
        "status": status,
        "error": error,
        "elapsed": elapsed,
        "eta": if s.status == Status::Done { None } else { p.eta() },
        "phase": *lock(&p.phase),
        "rays": s.rays,
        "mrays": s.mrays,
        "frames": base.frames,
        "frame": s.frame,
        "retraced": s.retraced,
        "view": s.view,
        "view_ms": s.view_ms,
        "relight_ms": s.relight_ms,
        "relight_prepare_ms": s.relight_prepare_ms,
        "camera": {"position": v(c.position), "look_at": v(c.look_at), "up": v(c.up),
                   "fov": c.fov_deg},
        "lights": s.relight.lights.iter()
            .map(|(n, k)| json!({"name": n, "factor": k.to_array()}))
            .collect::<Vec<_>>(),
        "materials": s.relight.materials.iter()
            .map(|(n, k)| json!({"name": n, "factor": k.to_array(), "colour": colour(n)}))
            .collect::<Vec<_>>(),
        "aovs": s.aovs.as_ref().is_some_and(|a| a.0 == s.view),
        "aovs_wanted": s.aovs_wanted,
        "back_steps": s.back_steps,
        "reference": base.reference.is_some(),
        "rmse": s.rmse,
        "notes": s.notes,
    })
}

/// Why an API request is refused as another site's, if it is. A browser names the page
/// that made a request in `Origin` (for all but plain reads and navigations) and in
/// `Sec-Fetch-Site`; a page elsewhere may not read the images or take an event stream's
/// slot. A request with neither header (curl, a script) comes from no page.
fn cross_site(r: &Request) -> Option<&'static str> {
    if let Some(origin) = r.header("origin") {
        let own = r.header("host").map(|h| format!("http://{h}"));
        if !own.is_some_and(|o| o.eq_ignore_ascii_case(origin)) {
            return Some("refused: a request from a page of another origin");
        }
    }
    match r.header("sec-fetch-site") {
        Some(site)
            if !(site.eq_ignore_ascii_case("same-origin") || site.eq_ignore_ascii_case("none")) =>
        {
            Some("refused: a request made by another site's page (Sec-Fetch-Site)")
        }
        _ => None,
    }
}

/// A JSON body as `T`; a 400 naming what is wrong.
fn parse<T: for<'de> Deserialize<'de>>(body: &[u8]) -> Result<T, (u16, String)> {
    serde_json::from_slice(body).map_err(|e| (400, format!("malformed JSON: {e}")))
}

/// Equality in a time that does not depend on where the strings differ.
fn same(a: &[u8], b: &[u8]) -> bool {
    a.len() == b.len() && a.iter().zip(b).fold(0u8, |acc, (x, y)| acc | (x ^ y)) == 0
}

/// The token of an `Authorization` header's Bearer credentials: the scheme's name is
/// case-insensitive (RFC 7235), and any spaces may follow it.
fn bearer_token(value: &str) -> Option<&str> {
    let (scheme, token) = value.trim_start().split_once(' ')?;
    scheme
        .eq_ignore_ascii_case("bearer")
        .then(|| token.trim_start())
}

/// Whether a `Content-Type` is JSON: the media type `application/json` exactly (any case),
/// with or without parameters (`; charset=utf-8`), not one that only starts with it.
fn is_json(value: &str) -> bool {
    let media = value.split(';').next().unwrap_or_default().trim();
    media.eq_ignore_ascii_case("application/json")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn request(headers: &[(&str, &str)]) -> Request {
        Request {
            method: "GET".into(),
            path: "/api/state".into(),
            query: Vec::new(),
            headers: (headers.iter())
                .map(|(n, v)| (n.to_string(), v.to_string()))
                .collect(),
            body: Vec::new(),
        }
    }

    #[test]
    fn cross_site_requests_are_told_apart() {
        let host = ("host", "127.0.0.1:8765");
        for ok in [
            vec![host],
            vec![host, ("origin", "http://127.0.0.1:8765")],
            vec![host, ("sec-fetch-site", "same-origin")],
            vec![host, ("sec-fetch-site", "none")],
        ] {
            assert_eq!(cross_site(&request(&ok)), None, "{ok:?}");
        }
        for refused in [
            vec![host, ("origin", "http://attacker.example")],
            vec![host, ("origin", "null")],
            vec![host, ("origin", "https://127.0.0.1:8765")],
            vec![host, ("origin", "http://127.0.0.1:9999")],
            vec![("origin", "http://127.0.0.1:8765")],
            vec![host, ("sec-fetch-site", "cross-site")],
            vec![host, ("sec-fetch-site", "same-site")],
            vec![
                host,
                ("origin", "http://127.0.0.1:8765"),
                ("sec-fetch-site", "cross-site"),
            ],
        ] {
            assert!(cross_site(&request(&refused)).is_some(), "{refused:?}");
        }
    }
}
