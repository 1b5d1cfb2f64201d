//! A `raylink serve` child for the studio's tests: started on a free port (it prints its
//! URL), spoken to in plain HTTP/1.1 over `TcpStream`, stopped by SIGINT.

#![allow(dead_code)] // Each test crate uses part of it.

use serde_json::Value;
use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::process::{Child, Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};

/// What a browser sends for another site's page: a fetch or an event stream (Origin), an
/// image or a frame (Sec-Fetch-Site only), a sandboxed frame, another port of this host.
pub const CROSS_SITE: [&str; 5] = [
    "Origin: http://attacker.example\r\nSec-Fetch-Site: cross-site\r\n",
    "Sec-Fetch-Site: cross-site\r\nSec-Fetch-Mode: no-cors\r\n",
    "Origin: null\r\n",
    "Origin: http://attacker.example\r\n",
    "Sec-Fetch-Site: same-site\r\n",
];

/// The path tracer's options of the served renders: a small Cornell box.
pub const PATH: [&str; 11] = [
    "scenes/cornell-box.toml",
    "--integrator",
    "path",
    "--width",
    "32",
    "--height",
    "24",
    "--spp",
    "16",
    "--seed",
    "5",
];

pub struct Server {
    child: Option<Child>,
    /// "127.0.0.1:PORT"
    pub addr: String,
    pub token: Option<String>,
    /// The URL as printed.
    pub url: String,
}

/// A response: status, headers (names in lower case), body.
pub struct Reply {
    pub status: u16,
    pub headers: Vec<(String, String)>,
    pub body: Vec<u8>,
}

impl Reply {
    pub fn header(&self, name: &str) -> Option<&str> {
        self.headers
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.as_str())
    }

    pub fn text(&self) -> String {
        String::from_utf8_lossy(&self.body).into_owned()
    }

    pub fn json(&self) -> Value {
        serde_json::from_slice(&self.body).unwrap_or_else(|e| panic!("{e}: {}", self.text()))
    }

    /// The body as the API's little-endian floats.
    pub fn floats(&self) -> Vec<f32> {
        assert_eq!(self.status, 200, "{}", self.text());
        self.body
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect()
    }
}

impl Server {
    /// `raylink serve ARGS --port 0 --quiet` from the repository root.
    pub fn start(args: &[&str]) -> Server {
        let mut child = Command::new(env!("CARGO_BIN_EXE_raylink"))
            .arg("serve")
            .args(args)
            .args(["--port", "0", "--quiet"])
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .expect("the raylink binary starts");
        let mut line = String::new();
        BufReader::new(child.stdout.take().unwrap())
            .read_line(&mut line)
            .unwrap();
        let url = line
            .split_whitespace()
            .find(|w| w.starts_with("http://"))
            .unwrap_or_else(|| panic!("no URL in {line:?}"))
            .to_string();
        let rest = url.trim_start_matches("http://");
        let (authority, query) = rest.split_once('/').unwrap();
        let port = authority.rsplit(':').next().unwrap();
        let token = query.strip_prefix("?token=").map(str::to_string);
        // A server on every address is reached through loopback.
        let addr = match authority.strip_prefix("0.0.0.0:") {
            Some(_) => format!("127.0.0.1:{port}"),
            None => authority.to_string(),
        };
        Server {
            child: Some(child),
            addr,
            token,
            url,
        }
    }

    /// Sends `raw` (a whole request) and reads the response to its end.
    pub fn raw(&self, raw: &[u8]) -> Reply {
        let mut s = TcpStream::connect(&self.addr).expect("the server accepts");
        s.set_read_timeout(Some(Duration::from_secs(60))).unwrap();
        s.write_all(raw).unwrap();
        let mut bytes = Vec::new();
        let _ = s.read_to_end(&mut bytes);
        parse_reply(&bytes)
    }

    /// A request with the token (if any) in the query, and `headers` lines.
    pub fn request(&self, method: &str, path: &str, headers: &str, body: &[u8]) -> Reply {
        let path = match &self.token {
            Some(t) if path.contains('?') => format!("{path}&token={t}"),
            Some(t) => format!("{path}?token={t}"),
            None => path.to_string(),
        };
        let mut raw = format!(
            "{method} {path} HTTP/1.1\r\nHost: {}\r\nContent-Length: {}\r\n{headers}\r\n",
            self.addr,
            body.len()
        )
        .into_bytes();
        raw.extend_from_slice(body);
        self.raw(&raw)
    }

    pub fn get(&self, path: &str) -> Reply {
        self.request("GET", path, "", b"")
    }

    pub fn post(&self, path: &str, json: &str) -> Reply {
        self.request(
            "POST",
            path,
            "Content-Type: application/json\r\n",
            json.as_bytes(),
        )
    }

    /// What the studio's own page sends, what a typed URL sends, and what curl sends.
    pub fn own_headers(&self) -> [String; 3] {
        [
            format!(
                "Origin: http://{}\r\nSec-Fetch-Site: same-origin\r\n",
                self.addr
            ),
            "Sec-Fetch-Site: none\r\n".into(),
            String::new(),
        ]
    }

    /// Opens an event stream with `headers`: the response (its head only if it is a
    /// stream), and the connection (a stream stays open while it is held).
    pub fn open_events(&self, headers: &str) -> (Reply, TcpStream) {
        let mut s = TcpStream::connect(&self.addr).unwrap();
        s.set_read_timeout(Some(Duration::from_secs(30))).unwrap();
        let query = self.token.as_ref().map(|t| format!("?token={t}"));
        let head = format!(
            "GET /api/events{} HTTP/1.1\r\nHost: {}\r\n{headers}\r\n",
            query.unwrap_or_default(),
            self.addr
        );
        s.write_all(head.as_bytes()).unwrap();
        let mut bytes = Vec::new();
        let mut byte = [0u8; 1];
        while !bytes.ends_with(b"\r\n\r\n") {
            assert_eq!(s.read(&mut byte).unwrap(), 1, "{bytes:?}");
            bytes.push(byte[0]);
        }
        let mut reply = parse_reply(&bytes);
        if reply.status != 200 {
            s.read_to_end(&mut reply.body).unwrap();
        }
        (reply, s)
    }

    pub fn state(&self) -> Value {
        let r = self.get("/api/state");
        assert_eq!(r.status, 200, "{}", r.text());
        r.json()
    }

    /// Waits until the state satisfies `ready`, failing after two minutes or if the server
    /// reports a failure.
    pub fn wait(&self, what: &str, ready: impl Fn(&Value) -> bool) -> Value {
        let start = Instant::now();
        loop {
            let s = self.state();
            assert_ne!(s["status"], "failed", "{s}");
            if ready(&s) {
                return s;
            }
            assert!(
                start.elapsed() < Duration::from_secs(120),
                "{what}: never reached; {s}"
            );
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    /// Waits until view `view` is rendered completely.
    pub fn wait_done(&self, view: u64) -> Value {
        self.wait(&format!("view {view} done"), |s| {
            s["status"] == "done" && s["view"].as_u64() == Some(view)
        })
    }

    pub fn pid(&self) -> u32 {
        self.child.as_ref().unwrap().id()
    }

    /// SIGINT, then the exit status.
    pub fn stop(mut self) -> ExitStatus {
        let mut child = self.child.take().unwrap();
        let pid = nix::unistd::Pid::from_raw(child.id() as i32);
        nix::sys::signal::kill(pid, nix::sys::signal::Signal::SIGINT).unwrap();
        let start = Instant::now();
        loop {
            if let Some(status) = child.try_wait().unwrap() {
                return status;
            }
            if start.elapsed() > Duration::from_secs(30) {
                let _ = child.kill();
                panic!("the server did not stop within 30 s of SIGINT");
            }
            std::thread::sleep(Duration::from_millis(10));
        }
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        if let Some(mut child) = self.child.take() {
            let _ = child.kill();
            let _ = child.wait();
        }
    }
}

pub fn parse_reply(bytes: &[u8]) -> Reply {
    let end = bytes
        .windows(4)
        .position(|w| w == b"\r\n\r\n")
        .unwrap_or_else(|| panic!("no response head in {:?}", String::from_utf8_lossy(bytes)));
    let head = String::from_utf8_lossy(&bytes[..end]);
    let mut lines = head.split("\r\n");
    let status = lines
        .next()
        .and_then(|l| l.split(' ').nth(1))
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| panic!("no status in {head:?}"));
    let headers = lines
        .filter_map(|l| l.split_once(':'))
        .map(|(n, v)| (n.trim().to_ascii_lowercase(), v.trim().to_string()))
        .collect();
    Reply {
        status,
        headers,
        body: bytes[end + 4..].to_vec(),
    }
}

/// Both headers that forbid framing, on `r`, in one policy.
pub fn assert_no_framing(what: &str, r: &Reply) {
    assert_eq!(r.header("x-frame-options"), Some("DENY"), "{what}");
    let policies: Vec<&str> = (r.headers.iter())
        .filter(|(n, _)| n == "content-security-policy")
        .map(|(_, v)| v.as_str())
        .collect();
    assert!(
        policies.len() == 1 && policies[0].contains("frame-ancestors 'none'"),
        "{what}: {policies:?}"
    );
}

/// Mean of the values.
pub fn mean(v: &[f32]) -> f64 {
    v.iter().map(|&x| x as f64).sum::<f64>() / v.len() as f64
}

/// A refusal's body is one line saying why.
pub fn assert_one_line(what: &str, r: &Reply) {
    let text = r.text();
    assert!(
        text.ends_with('\n') && text.trim().lines().count() == 1,
        "{what}: {text:?}"
    );
}
