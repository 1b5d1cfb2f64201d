//! raylink studio in a real browser: headless Chromium driven by chromedriver over the
//! WebDriver protocol (plain HTTP and JSON here). The page must show the progressive image
//! as it converges, orbit on a mouse drag and undo the orbit, show the albedo, and relight
//! the network from a slider with the image scaling as the light. Chromium and chromedriver
//! are Debian packages that scripts/install-deps.sh --tests installs; without them this
//! test fails (it is not skipped).

mod studio;

use serde_json::{json, Value};
use std::io::{Read, Write};
use std::net::{TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};
use studio::{parse_reply, Server};

const CHROMEDRIVER: &str = "/usr/bin/chromedriver";
const CHROMIUM: &str = "/usr/bin/chromium";

/// A chromedriver child and one browser session in it.
struct Browser {
    driver: Child,
    port: u16,
    session: String,
    _profile: tempfile::TempDir,
}

fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

/// One WebDriver call: `method` on `path` with a JSON body; the answer's `value`.
fn call(port: u16, method: &str, path: &str, body: Option<&Value>) -> Result<Value, String> {
    let body = body.map(Value::to_string).unwrap_or_default();
    let mut s = TcpStream::connect(("127.0.0.1", port)).map_err(|e| e.to_string())?;
    s.set_read_timeout(Some(Duration::from_secs(120))).unwrap();
    let head = format!(
        "{method} {path} HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nContent-Type: application/json\r\n\
         Content-Length: {}\r\nConnection: close\r\n\r\n",
        body.len()
    );
    s.write_all(head.as_bytes()).map_err(|e| e.to_string())?;
    s.write_all(body.as_bytes()).map_err(|e| e.to_string())?;
    // chromedriver keeps the connection open: read the head, then Content-Length bytes.
    let mut bytes = Vec::new();
    let mut chunk = [0u8; 8192];
    let reply = loop {
        let n = s.read(&mut chunk).map_err(|e| e.to_string())?;
        if n == 0 {
            return Err(format!("{method} {path}: the connection closed"));
        }
        bytes.extend_from_slice(&chunk[..n]);
        let Some(end) = bytes.windows(4).position(|w| w == b"\r\n\r\n") else {
            continue;
        };
        let reply = parse_reply(&bytes);
        let length: usize = reply
            .header("content-length")
            .and_then(|v| v.parse().ok())
            .unwrap_or(0);
        if bytes.len() >= end + 4 + length {
            break reply;
        }
    };
    let v: Value = serde_json::from_slice(&reply.body).map_err(|e| e.to_string())?;
    if reply.status != 200 {
        return Err(format!("{method} {path}: {} {v}", reply.status));
    }
    Ok(v["value"].clone())
}

impl Browser {
    fn start() -> Browser {
        for tool in [CHROMEDRIVER, CHROMIUM] {
            assert!(
                Path::new(tool).exists(),
                "{tool} is missing: install the Debian packages chromium and chromium-driver \
                 (scripts/install-deps.sh --tests does)"
            );
        }
        let port = free_port();
        let driver = Command::new(CHROMEDRIVER)
            .arg(format!("--port={port}"))
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("chromedriver starts");
        let profile = tempfile::tempdir().unwrap();
        let mut browser = Browser {
            driver,
            port,
            session: String::new(),
            _profile: profile,
        };
        let start = Instant::now();
        while call(port, "GET", "/status", None).map_or(true, |v| v["ready"] != true) {
            assert!(
                start.elapsed() < Duration::from_secs(30),
                "chromedriver not ready"
            );
            std::thread::sleep(Duration::from_millis(50));
        }
        let args = [
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--disable-dev-shm-usage",
            "--window-size=1200,760",
            &format!("--user-data-dir={}", browser._profile.path().display()),
        ];
        let caps = json!({"capabilities": {"alwaysMatch": {
            "browserName": "chrome",
            "goog:chromeOptions": {"binary": CHROMIUM, "args": args},
        }}});
        let session = browser.call("POST", "/session", Some(&caps));
        browser.session = session["sessionId"].as_str().unwrap().to_string();
        browser
    }

    fn call(&self, method: &str, path: &str, body: Option<&Value>) -> Value {
        call(self.port, method, path, body).unwrap_or_else(|e| panic!("{e}"))
    }

    fn on_session(&self, method: &str, path: &str, body: Value) -> Value {
        let path = format!("/session/{}{path}", self.session);
        self.call(method, &path, Some(&body))
    }

    fn open(&self, url: &str) {
        self.on_session("POST", "/url", json!({ "url": url }));
    }

    /// Runs `script` (a function body) in the page.
    fn js(&self, script: &str) -> Value {
        self.on_session(
            "POST",
            "/execute/sync",
            json!({"script": script, "args": []}),
        )
    }

    /// Waits until `script` returns something truthy; returns it.
    fn wait(&self, what: &str, script: &str) -> Value {
        let start = Instant::now();
        loop {
            let v = self.js(script);
            if !(v.is_null() || v == false || v == 0) {
                return v;
            }
            assert!(
                start.elapsed() < Duration::from_secs(120),
                "{what}: never; page state {}",
                self.js("return JSON.stringify(window.studio && studio.state)")
            );
            std::thread::sleep(Duration::from_millis(50));
        }
    }

    /// Drags the mouse across the canvas from its centre by (dx, dy) pixels.
    fn drag_canvas(&self, dx: i64, dy: i64) {
        let found = self.on_session(
            "POST",
            "/element",
            json!({"using": "css selector", "value": "#canvas"}),
        );
        let element = found.as_object().unwrap().values().next().unwrap().clone();
        let origin = json!({ "element-6066-11e4-a52e-4f735466cecf": element });
        self.on_session(
            "POST",
            "/actions",
            json!({"actions": [{"type": "pointer", "id": "mouse",
                "parameters": {"pointerType": "mouse"},
                "actions": [
                    {"type": "pointerMove", "duration": 0, "origin": origin, "x": 0, "y": 0},
                    {"type": "pointerDown", "button": 0},
                    {"type": "pointerMove", "duration": 150, "origin": "pointer", "x": dx / 2, "y": dy / 2},
                    {"type": "pointerMove", "duration": 150, "origin": "pointer", "x": dx - dx / 2, "y": dy - dy / 2},
                    {"type": "pointerUp", "button": 0},
                ]}]}),
        );
    }

    fn screenshot(&self, path: &Path) {
        let b64 = self.call(
            "GET",
            &format!("/session/{}/screenshot", self.session),
            None,
        );
        let png = base64_decode(b64.as_str().unwrap());
        assert!(png.starts_with(b"\x89PNG"));
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(path, png).unwrap();
    }
}

impl Drop for Browser {
    fn drop(&mut self) {
        if !self.session.is_empty() {
            let _ = call(
                self.port,
                "DELETE",
                &format!("/session/{}", self.session),
                None,
            );
        }
        let _ = self.driver.kill();
        let _ = self.driver.wait();
    }
}

fn base64_decode(text: &str) -> Vec<u8> {
    const ALPHABET: &[u8] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = Vec::with_capacity(text.len() * 3 / 4);
    let (mut acc, mut bits) = (0u32, 0);
    for c in text
        .bytes()
        .filter(|&c| c != b'=' && !c.is_ascii_whitespace())
    {
        let v = ALPHABET.iter().position(|&a| a == c).expect("base64") as u32;
        acc = (acc << 6) | v;
        bits += 6;
        if bits >= 8 {
            bits -= 8;
            out.push((acc >> bits) as u8);
        }
    }
    out
}

/// target/test-artifacts, beside the tests' own temporary folder.
fn artifacts() -> PathBuf {
    Path::new(env!("CARGO_TARGET_TMPDIR"))
        .parent()
        .unwrap()
        .join("test-artifacts")
}

/// The newest image the page drew is the server's newest and the render is done.
const SETTLED: &str = "const s = window.studio; const h = s && s.history;
    return !!(h && h.length && s.state.status === 'done'
        && h[h.length - 1].version === s.state.image_version) && h[h.length - 1];";

#[test]
fn the_page_converges_orbits_and_relights_in_chromium() {
    let browser = Browser::start();

    // Progressive: the path tracer at 64x48, 256 samples per pixel in passes, on one
    // thread so that a view takes long enough for the page to see several passes.
    let path = Server::start(&[
        "scenes/cornell-box.toml",
        "--integrator",
        "path",
        "--width",
        "64",
        "--height",
        "48",
        "--spp",
        "256",
        "--threads",
        "1",
    ]);
    browser.open(&path.url);
    let first = browser.wait("the first view, finished", SETTLED);
    assert_eq!(first["spp"].as_f64(), Some(256.0), "{first}");
    let scene_camera = path.state()["camera"].clone();
    browser.drag_canvas(60, 10);
    let moved = browser.wait(
        "the orbited view, finished",
        &SETTLED.replace(
            "&& h[h.length - 1];",
            "&& h[h.length - 1].view >= 2 && h[h.length - 1];",
        ),
    );
    assert_ne!(
        moved["canvas"], first["canvas"],
        "the orbit changed nothing"
    );
    let camera = path.state()["camera"].clone();
    assert_ne!(camera["position"], json!([0.0, 1.0, 6.800000190734863]));
    // The orbit keeps the distance to the point looked at (within rounding).
    let p: Vec<f64> = serde_json::from_value(camera["position"].clone()).unwrap();
    let l: Vec<f64> = serde_json::from_value(camera["look_at"].clone()).unwrap();
    let d = ((p[0] - l[0]).powi(2) + (p[1] - l[1]).powi(2) + (p[2] - l[2]).powi(2)).sqrt();
    assert!((d - 6.8).abs() < 1e-3, "distance {d}");
    // The passes of the orbited view as the page drew them: fewer samples first, and the
    // canvas changing as they grow.
    let passes = browser
        .js("const v = studio.state.view; return studio.history.filter((h) => h.view === v);");
    let passes = passes.as_array().unwrap();
    let spp: Vec<f64> = passes.iter().map(|h| h["spp"].as_f64().unwrap()).collect();
    eprintln!("samples per pixel of the orbited view's images the page drew: {spp:?}");
    assert!(
        spp.len() >= 2 && spp[0] < 256.0 && spp.windows(2).all(|w| w[0] < w[1]),
        "{spp:?}"
    );
    assert_ne!(passes[0]["canvas"], passes[passes.len() - 1]["canvas"]);
    // "Undo move" takes the whole drag back: the scene's camera, and the image drawn first.
    browser.js("document.getElementById('undo-view').click(); return true;");
    let back = browser.wait(
        "the view before the orbit",
        &SETTLED.replace(
            "&& h[h.length - 1];",
            &format!(
                "&& h[h.length - 1].view > {} && h[h.length - 1];",
                moved["view"]
            ),
        ),
    );
    assert_eq!(back["canvas"], first["canvas"], "{back}");
    assert_eq!(path.state()["camera"], scene_camera);
    // The albedo: the page asks the server to compute it (reading it asks for nothing).
    browser.js(
        "const k = document.getElementById('kind'); k.value = 'albedo';
         k.dispatchEvent(new Event('change')); return true;",
    );
    browser.wait(
        "the albedo",
        "return studio.image && studio.image.kind === 'albedo' && studio.state.aovs_wanted",
    );
    drop(path);

    // The network: relight the lamp by its slider.
    let network = Server::start(&[
        "scenes/network-room.toml",
        "--width",
        "64",
        "--height",
        "48",
        "--slopes",
        "6",
        "--intercept-step",
        "0.0625",
    ]);
    browser.open(&network.url);
    let before = browser.wait("the network view", SETTLED);
    browser.js(
        "const i = document.querySelector('input[data-name=\"light lamp\"]');
         i.value = 2; i.dispatchEvent(new Event('input')); return true;",
    );
    let after = browser.wait(
        "the relit view",
        &SETTLED.replace(
            "&& h[h.length - 1];",
            "&& s.state.relight_ms != null && h[h.length - 1];",
        ),
    );
    let ratio = after["mean"].as_f64().unwrap() / before["mean"].as_f64().unwrap();
    // Superposition of the light basis: within the distribution's tolerance (0.1%).
    eprintln!("lamp x2: the page's mean x{ratio:.5}");
    assert!((ratio - 2.0).abs() < 0.02, "lamp x2 gave x{ratio}");
    let shown = browser.js("return document.getElementById('figures').textContent");
    assert!(
        shown.as_str().unwrap().contains("relight → image"),
        "{shown}"
    );
    browser.screenshot(&artifacts().join("studio.png"));
    // The lamp's colour picked red: no green or blue light is left in the room.
    browser.js(
        "const i = document.querySelector('input[data-name=\"light lamp colour\"]');
         i.value = '#ff0000'; i.dispatchEvent(new Event('input')); return true;",
    );
    browser.wait(
        "the red lamp",
        &SETTLED.replace(
            "&& h[h.length - 1];",
            "&& s.state.lights[0].factor[1] === 0 && h[h.length - 1];",
        ),
    );
    let rgb = browser.js("const d = studio.image.data, m = [0, 0, 0];
         for (let i = 0; i < d.length; i++) m[i % 3] += d[i];
         return m;");
    let rgb: Vec<f64> = serde_json::from_value(rgb).unwrap();
    assert!(rgb[0] > 0.0 && rgb[1] == 0.0 && rgb[2] == 0.0, "{rgb:?}");
    drop(network);

    // A keyframed scene: the frame slider, and the retraced pixels shown.
    let bounce = Server::start(&["scenes/anim-bounce.toml", "--width", "64", "--height", "48"]);
    browser.open(&bounce.url);
    let still = browser.wait("the bouncing ball's scene", SETTLED);
    let slider = "const i = document.getElementById('frame'); i.value = FRAME;
         i.dispatchEvent(new Event('input')); return !document.getElementById('animation').hidden;";
    let settled_at = |frame: u32| {
        SETTLED.replace(
            "&& h[h.length - 1];",
            &format!("&& s.state.frame === {frame} && h[h.length - 1];"),
        )
    };
    assert_eq!(browser.js(&slider.replace("FRAME", "4")), true, "no slider");
    let four = browser.wait("frame 4", &settled_at(4));
    browser.js(&slider.replace("FRAME", "5"));
    let five = browser.wait("frame 5", &settled_at(5));
    assert_ne!(four["canvas"], five["canvas"], "the ball did not move");
    assert_ne!(still["canvas"], five["canvas"]);
    let retraced = browser.js("return studio.state.retraced");
    assert!(
        retraced.as_f64().is_some_and(|r| r > 0.0 && r < 0.6),
        "{retraced}"
    );
    // The retraced pixels' view draws the map: another picture than the frame.
    browser.js(
        "const k = document.getElementById('kind'); k.value = 'retrace';
         k.dispatchEvent(new Event('change')); return true;",
    );
    let map = browser.wait(
        "the retrace map",
        "return studio.image && studio.image.kind === 'retrace' && studio.canvasStats().hash",
    );
    assert_ne!(map, five["canvas"]);
}
