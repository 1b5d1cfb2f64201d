//! A small HTTP/1.1 server over `std::net`, enough for the studio's page and API: one request
//! per connection (`Connection: close`), bodies only with `Content-Length`. It is written
//! here rather than taken from a crate because what matters is what it refuses: at most
//! [`MAX_CONNECTIONS`] connections are handled at once (more get a 503 from the accepting
//! thread, which spawns nothing for them), request heads and bodies are bounded, and reads
//! and writes time out. Nothing in a request is ever used as a file name, and no answer may
//! be shown in another page's frame.

use std::io::{Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// Connections handled at once; the rest are answered 503 and closed.
pub const MAX_CONNECTIONS: usize = 32;
/// The request line and headers.
const MAX_HEAD: usize = 16 * 1024;
/// A request's body (the API's JSON is a few hundred bytes).
pub const MAX_BODY: usize = 64 * 1024;
/// How long a client may take to send its whole request, or to take a write's bytes.
const TIMEOUT: Duration = Duration::from_secs(10);

/// A parsed request.
pub struct Request {
    pub method: String,
    /// The path, percent-decoded, without the query.
    pub path: String,
    /// The query's pairs, percent-decoded.
    pub query: Vec<(String, String)>,
    /// Header names in lower case.
    pub headers: Vec<(String, String)>,
    pub body: Vec<u8>,
}

impl Request {
    pub fn header(&self, name: &str) -> Option<&str> {
        self.headers
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.as_str())
    }

    pub fn param(&self, name: &str) -> Option<&str> {
        self.query
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.as_str())
    }
}

/// A whole response.
pub struct Response {
    pub status: u16,
    pub content_type: &'static str,
    pub headers: Vec<(&'static str, String)>,
    /// A Content-Security-Policy beyond `frame-ancestors 'none'`.
    pub policy: Option<&'static str>,
    pub body: Vec<u8>,
}

/// The status line and the headers every response carries, the event stream's too: no
/// caching, no sniffing, and no framing by any page (a page that framed the studio could
/// overlay it and have its user click or drag in it unawares).
pub fn head(status: u16, content_type: &str, policy: Option<&str>) -> String {
    let policy = match policy {
        Some(p) => format!("{p}; frame-ancestors 'none'"),
        None => "frame-ancestors 'none'".into(),
    };
    format!(
        "HTTP/1.1 {status} {}\r\nContent-Type: {content_type}\r\nConnection: close\r\n\
         Cache-Control: no-store\r\nX-Content-Type-Options: nosniff\r\nX-Frame-Options: DENY\r\n\
         Content-Security-Policy: {policy}\r\n",
        reason(status)
    )
}

impl Response {
    pub fn new(status: u16, content_type: &'static str, body: impl Into<Vec<u8>>) -> Response {
        Response {
            status,
            content_type,
            headers: Vec::new(),
            policy: None,
            body: body.into(),
        }
    }

    /// A plain-text error (or any short text answer).
    pub fn text(status: u16, text: &str) -> Response {
        Response::new(status, "text/plain; charset=utf-8", format!("{text}\n"))
    }

    pub fn json(value: &serde_json::Value) -> Response {
        Response::new(200, "application/json", value.to_string())
    }

    pub fn with_header(mut self, name: &'static str, value: String) -> Response {
        self.headers.push((name, value));
        self
    }

    /// The page's own Content-Security-Policy (the one refusing framing is added to it).
    pub fn with_policy(mut self, policy: &'static str) -> Response {
        self.policy = Some(policy);
        self
    }

    /// Writes the response and its body.
    pub fn write_to(&self, stream: &mut impl Write) -> std::io::Result<()> {
        let mut head = head(self.status, self.content_type, self.policy);
        head += &format!("Content-Length: {}\r\n", self.body.len());
        for (name, value) in &self.headers {
            head += &format!("{name}: {value}\r\n");
        }
        head += "\r\n";
        stream.write_all(head.as_bytes())?;
        stream.write_all(&self.body)?;
        stream.flush()
    }
}

/// What a handler does with a request: answer it, or keep the connection for a stream of
/// server-sent events it writes itself.
pub enum Reply {
    Full(Response),
    Stream(Box<dyn FnOnce(&mut TcpStream) + Send>),
}

pub fn reason(status: u16) -> &'static str {
    match status {
        200 => "OK",
        400 => "Bad Request",
        401 => "Unauthorized",
        403 => "Forbidden",
        404 => "Not Found",
        405 => "Method Not Allowed",
        409 => "Conflict",
        411 => "Length Required",
        413 => "Payload Too Large",
        415 => "Unsupported Media Type",
        431 => "Request Header Fields Too Large",
        500 => "Internal Server Error",
        501 => "Not Implemented",
        503 => "Service Unavailable",
        _ => "",
    }
}

/// Why a request could not be read: the status to answer with, or nothing (the client left).
enum ReadError {
    Answer(u16, &'static str),
    Gone,
}

/// Accepts connections until `stop` is set, handing each request to `handle` on a thread of
/// its own, at most [`MAX_CONNECTIONS`] at a time.
pub fn serve(
    listener: TcpListener,
    stop: Arc<AtomicBool>,
    handle: Arc<dyn Fn(&Request) -> Reply + Send + Sync>,
) -> std::io::Result<()> {
    // Non-blocking, so that the loop sees `stop` within a few milliseconds.
    listener.set_nonblocking(true)?;
    let active = Arc::new(AtomicUsize::new(0));
    while !stop.load(Ordering::Relaxed) {
        let (stream, _) = match listener.accept() {
            Ok(c) => c,
            Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {
                std::thread::sleep(Duration::from_millis(5));
                continue;
            }
            // A connection that failed before it was accepted, or no file descriptors
            // left: wait a little rather than spin.
            Err(_) => {
                std::thread::sleep(Duration::from_millis(20));
                continue;
            }
        };
        if active.load(Ordering::SeqCst) >= MAX_CONNECTIONS {
            refuse_busy(stream);
            continue;
        }
        active.fetch_add(1, Ordering::SeqCst);
        let slot = Slot(active.clone());
        let handle = handle.clone();
        let spawned = std::thread::Builder::new()
            .name("raylink-http".into())
            .stack_size(256 * 1024)
            .spawn(move || {
                let _slot = slot;
                connection(stream, handle.as_ref());
            });
        if spawned.is_err() {
            // The slot was moved into the closure and is dropped with it.
            std::thread::sleep(Duration::from_millis(20));
        }
    }
    Ok(())
}

/// One of the [`MAX_CONNECTIONS`], given back when dropped.
struct Slot(Arc<AtomicUsize>);

impl Drop for Slot {
    fn drop(&mut self) {
        self.0.fetch_sub(1, Ordering::SeqCst);
    }
}

/// A 503 written from the accepting thread without waiting for anything: what the client
/// already sent is drained (so that closing does not reset the connection before it reads
/// the answer), the answer fits in the socket's buffer.
fn refuse_busy(mut stream: TcpStream) {
    let _ = stream.set_nonblocking(true);
    let mut scratch = [0u8; 4096];
    let _ = stream.read(&mut scratch);
    let _ = Response::text(503, "busy: too many connections")
        .with_header("Retry-After", "1".into())
        .write_to(&mut stream);
    let _ = stream.shutdown(std::net::Shutdown::Write);
}

fn connection(mut stream: TcpStream, handle: &(dyn Fn(&Request) -> Reply + Send + Sync)) {
    let _ = stream.set_nonblocking(false);
    let _ = stream.set_write_timeout(Some(TIMEOUT));
    let _ = stream.set_nodelay(true);
    let request = match read_request(&mut stream) {
        Ok(r) => r,
        Err(ReadError::Gone) => return,
        Err(ReadError::Answer(status, why)) => {
            let _ = Response::text(status, why).write_to(&mut stream);
            return;
        }
    };
    match handle(&request) {
        Reply::Full(response) => {
            let _ = response.write_to(&mut stream);
        }
        Reply::Stream(write) => write(&mut stream),
    }
}

/// Reads into `chunk` before the deadline: a client that trickles its request a byte at a
/// time still has [`TIMEOUT`] in all.
fn read_by(
    stream: &mut TcpStream,
    chunk: &mut [u8],
    deadline: Instant,
) -> Result<usize, ReadError> {
    let left = deadline.saturating_duration_since(Instant::now());
    if left.is_zero() || stream.set_read_timeout(Some(left)).is_err() {
        return Err(ReadError::Gone);
    }
    match stream.read(chunk) {
        Ok(0) | Err(_) => Err(ReadError::Gone),
        Ok(n) => Ok(n),
    }
}

fn read_request(stream: &mut TcpStream) -> Result<Request, ReadError> {
    let deadline = Instant::now() + TIMEOUT;
    let mut buf = Vec::with_capacity(1024);
    let mut chunk = [0u8; 2048];
    let head_end = loop {
        if let Some(i) = find(&buf, b"\r\n\r\n") {
            break i;
        }
        if buf.len() > MAX_HEAD {
            return Err(ReadError::Answer(431, "the request's head is too large"));
        }
        let n = read_by(stream, &mut chunk, deadline)?;
        buf.extend_from_slice(&chunk[..n]);
    };
    if head_end > MAX_HEAD {
        return Err(ReadError::Answer(431, "the request's head is too large"));
    }
    let head = std::str::from_utf8(&buf[..head_end])
        .map_err(|_| ReadError::Answer(400, "the request's head is not UTF-8"))?;
    let mut lines = head.split("\r\n");
    let line = lines.next().unwrap_or_default();
    let mut parts = line.split(' ');
    let (Some(method), Some(target), Some(version), None) =
        (parts.next(), parts.next(), parts.next(), parts.next())
    else {
        return Err(ReadError::Answer(400, "malformed request line"));
    };
    if !version.starts_with("HTTP/1.") {
        return Err(ReadError::Answer(400, "only HTTP/1.x is served"));
    }
    // Only the origin form ("/path?query"): no absolute URLs, no "*".
    if !target.starts_with('/') {
        return Err(ReadError::Answer(
            400,
            "the request target must start with /",
        ));
    }
    let mut headers = Vec::new();
    for l in lines {
        let Some((name, value)) = l.split_once(':') else {
            return Err(ReadError::Answer(400, "malformed header line"));
        };
        headers.push((name.trim().to_ascii_lowercase(), value.trim().to_string()));
    }
    let (raw_path, raw_query) = target.split_once('?').unwrap_or((target, ""));
    let path = percent_decode(raw_path).ok_or(ReadError::Answer(
        400,
        "malformed percent-encoding in the path",
    ))?;
    let mut query = Vec::new();
    for pair in raw_query.split('&').filter(|p| !p.is_empty()) {
        let (k, v) = pair.split_once('=').unwrap_or((pair, ""));
        let decode = |s: &str| percent_decode(&s.replace('+', " "));
        match (decode(k), decode(v)) {
            (Some(k), Some(v)) => query.push((k, v)),
            _ => return Err(ReadError::Answer(400, "malformed query")),
        }
    }
    let mut request = Request {
        method: method.to_string(),
        path,
        query,
        headers,
        body: Vec::new(),
    };
    if request.header("transfer-encoding").is_some() {
        return Err(ReadError::Answer(
            411,
            "chunked bodies are not accepted; send Content-Length",
        ));
    }
    let length = match request.header("content-length") {
        None => 0,
        Some(v) => v
            .parse::<usize>()
            .map_err(|_| ReadError::Answer(400, "malformed Content-Length"))?,
    };
    if length > MAX_BODY {
        return Err(ReadError::Answer(413, "the request's body is too large"));
    }
    let mut body = buf[head_end + 4..].to_vec();
    if body.len() > length {
        return Err(ReadError::Answer(400, "more body than Content-Length says"));
    }
    while body.len() < length {
        let want = (length - body.len()).min(chunk.len());
        let n = read_by(stream, &mut chunk[..want], deadline)?;
        body.extend_from_slice(&chunk[..n]);
    }
    request.body = body;
    Ok(request)
}

fn find(haystack: &[u8], needle: &[u8]) -> Option<usize> {
    haystack.windows(needle.len()).position(|w| w == needle)
}

/// `%XX` decoded; `None` for a bad escape or bytes that are not UTF-8.
pub fn percent_decode(s: &str) -> Option<String> {
    let bytes = s.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' {
            let hex = s.get(i + 1..i + 3)?;
            out.push(u8::from_str_radix(hex, 16).ok()?);
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    String::from_utf8(out).ok()
}

/// Binds `addr`; a clear message if it cannot.
pub fn bind(addr: SocketAddr) -> Result<TcpListener, String> {
    TcpListener::bind(addr).map_err(|e| format!("cannot listen on {addr}: {e}"))
}
