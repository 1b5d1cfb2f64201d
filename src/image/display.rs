//! Streaming an image to a display server while it renders: the protocol of the tev viewer
//! that pbrt-v4's `--display-server` speaks. Each message is its length (u32, itself
//! included), a type byte and its fields, little-endian, strings ending in a zero byte:
//! "create image" (title, width, height, channel names) once a connection, then "update
//! image" for one channel of one tile (its corner, size and floats, row by row), sent only
//! for tiles that changed since they were last sent.
//!
//! Sending runs on its own thread with the latest image waiting for it, so a render never
//! waits for the viewer: images the thread has no time for are skipped. A viewer that is
//! not there, or goes away, costs the render nothing but a retry at the next image.

use super::Image;
use crate::error::{Error, Result};
use std::io::Write;
use std::net::{SocketAddr, TcpStream, ToSocketAddrs};
use std::sync::{Arc, Condvar, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// The message types this client sends (tev's numbering).
const CREATE_IMAGE: u8 = 4;
const UPDATE_IMAGE: u8 = 3;
/// Tiles of the updates, as pbrt-v4 sends them: a tile channel is a 64 KiB message.
const TILE: u32 = 128;
/// How long a connection or a write may take before the viewer is taken to be gone.
const TIMEOUT: Duration = Duration::from_secs(3);
/// After a failed connection, images are not sent before this long has passed.
const RETRY: Duration = Duration::from_secs(1);
const CHANNELS: [&str; 3] = ["R", "G", "B"];

/// A viewer's address: `HOST:PORT` (`[::1]:14158` for an IPv6 literal).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct DisplayAddress {
    pub host: String,
    pub port: u16,
}

impl std::str::FromStr for DisplayAddress {
    type Err = Error;

    fn from_str(s: &str) -> Result<Self> {
        let bad = || {
            Error::Invalid(format!(
                "--display-server: expected HOST:PORT (as localhost:14158), got \"{s}\""
            ))
        };
        let (host, port) = s.rsplit_once(':').ok_or_else(bad)?;
        let host = host
            .strip_prefix('[')
            .and_then(|h| h.strip_suffix(']'))
            .unwrap_or(host);
        let port: u16 = port.parse().map_err(|_| bad())?;
        if host.is_empty() || port == 0 || host.contains(char::is_whitespace) {
            return Err(bad());
        }
        Ok(DisplayAddress {
            host: host.to_string(),
            port,
        })
    }
}

impl std::fmt::Display for DisplayAddress {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.host.contains(':') {
            write!(f, "[{}]:{}", self.host, self.port)
        } else {
            write!(f, "{}:{}", self.host, self.port)
        }
    }
}

/// What the sending thread is given: the newest image not yet sent, and whether it is the
/// last.
#[derive(Default)]
struct Mailbox {
    image: Option<Image>,
    last: bool,
}

#[derive(Default)]
struct Shared {
    mailbox: Mutex<Mailbox>,
    posted: Condvar,
}

/// A connection to a viewer, made and kept by its own thread.
pub struct DisplayServer {
    shared: Arc<Shared>,
    thread: Option<JoinHandle<Option<String>>>,
}

impl DisplayServer {
    /// Starts the thread that sends images titled `title` to `address`; it connects when it
    /// has the first image.
    pub fn start(address: DisplayAddress, title: &str) -> DisplayServer {
        let shared = Arc::new(Shared::default());
        let title: String = title.chars().filter(|&c| c != '\0').collect();
        let thread = {
            let shared = shared.clone();
            std::thread::Builder::new()
                .name("display-server".into())
                .spawn(move || Sender::new(address, title).run(&shared))
                .ok()
        };
        DisplayServer { shared, thread }
    }

    /// Hands `image` to the sending thread, replacing one it has not taken yet.
    pub fn show(&self, image: &Image) {
        let mut mailbox = lock(&self.shared.mailbox);
        mailbox.image = Some(image.clone());
        self.shared.posted.notify_one();
    }

    /// Sends the final image and ends the connection. Returns why the viewer did not get the
    /// final image, if it did not.
    pub fn finish(mut self, image: &Image) -> Option<String> {
        {
            let mut mailbox = lock(&self.shared.mailbox);
            mailbox.image = Some(image.clone());
            mailbox.last = true;
            self.shared.posted.notify_one();
        }
        let thread = self.thread.take()?;
        thread
            .join()
            .unwrap_or_else(|_| Some("the sending thread failed".into()))
    }
}

impl Drop for DisplayServer {
    fn drop(&mut self) {
        // Dropped without `finish` (an error ended the render): let the thread end.
        lock(&self.shared.mailbox).last = true;
        self.shared.posted.notify_one();
    }
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

/// The sending thread's state: the connection, and what the viewer holds of the image.
struct Sender {
    address: DisplayAddress,
    title: String,
    stream: Option<TcpStream>,
    /// The image as the viewer has it, per tile (None: to be sent whole).
    sent: Option<Image>,
    /// Why the last attempt failed, and when.
    failure: Option<(String, Instant)>,
}

impl Sender {
    fn new(address: DisplayAddress, title: String) -> Sender {
        Sender {
            address,
            title,
            stream: None,
            sent: None,
            failure: None,
        }
    }

    /// Sends what is posted until the last image; returns why the last one was not sent.
    fn run(mut self, shared: &Shared) -> Option<String> {
        loop {
            let (image, last) = {
                let mut mailbox = lock(&shared.mailbox);
                while mailbox.image.is_none() && !mailbox.last {
                    mailbox = shared
                        .posted
                        .wait(mailbox)
                        .unwrap_or_else(|e| e.into_inner());
                }
                (mailbox.image.take(), mailbox.last)
            };
            let retry_due = self
                .failure
                .as_ref()
                .is_none_or(|(_, at)| at.elapsed() >= RETRY);
            if let Some(image) = image.filter(|_| last || retry_due) {
                match self.send(&image) {
                    Ok(()) => self.failure = None,
                    Err(e) => {
                        self.stream = None;
                        self.sent = None;
                        self.failure = Some((e, Instant::now()));
                    }
                }
            }
            if last {
                return self.failure.map(|(e, _)| e);
            }
        }
    }

    fn send(&mut self, image: &Image) -> std::result::Result<(), String> {
        if self.stream.is_none() {
            let stream = connect(&self.address)?;
            self.stream = Some(stream);
            self.sent = None;
        }
        let stream = self.stream.as_mut().expect("connected");
        let fresh = self
            .sent
            .as_ref()
            .is_none_or(|s| (s.width, s.height) != (image.width, image.height));
        if fresh {
            let packet = create_image(&self.title, image.width, image.height, &CHANNELS);
            stream.write_all(&packet).map_err(|e| e.to_string())?;
        }
        for (x0, y0, w, h) in tiles(image.width, image.height) {
            let unchanged = !fresh
                && self
                    .sent
                    .as_ref()
                    .is_some_and(|s| same_tile(s, image, (x0, y0, w, h)));
            if unchanged {
                continue;
            }
            for (c, name) in CHANNELS.iter().enumerate() {
                let values = (y0..y0 + h)
                    .flat_map(|y| (x0..x0 + w).map(move |x| (x, y)))
                    .map(|(x, y)| image.get(x, y)[c]);
                let packet = update_image(&self.title, name, (x0, y0, w, h), values);
                stream.write_all(&packet).map_err(|e| e.to_string())?;
            }
        }
        stream.flush().map_err(|e| e.to_string())?;
        self.sent = Some(image.clone());
        Ok(())
    }
}

fn connect(address: &DisplayAddress) -> std::result::Result<TcpStream, String> {
    let addrs: Vec<SocketAddr> = (address.host.as_str(), address.port)
        .to_socket_addrs()
        .map_err(|e| e.to_string())?
        .collect();
    let mut last = format!("{} resolves to no address", address.host);
    for addr in addrs {
        match TcpStream::connect_timeout(&addr, TIMEOUT) {
            Ok(stream) => {
                stream
                    .set_write_timeout(Some(TIMEOUT))
                    .map_err(|e| e.to_string())?;
                let _ = stream.set_nodelay(true);
                return Ok(stream);
            }
            Err(e) => last = e.to_string(),
        }
    }
    Err(last)
}

/// The tiles of a `width`×`height` image, row by row: (x, y, width, height).
fn tiles(width: u32, height: u32) -> impl Iterator<Item = (u32, u32, u32, u32)> {
    (0..height.div_ceil(TILE)).flat_map(move |ty| {
        (0..width.div_ceil(TILE)).map(move |tx| {
            let (x, y) = (tx * TILE, ty * TILE);
            (x, y, TILE.min(width - x), TILE.min(height - y))
        })
    })
}

/// Whether a tile holds the same bits in both images.
fn same_tile(a: &Image, b: &Image, (x0, y0, w, h): (u32, u32, u32, u32)) -> bool {
    (y0..y0 + h).all(|y| {
        let row = (y * a.width + x0) as usize..(y * a.width + x0 + w) as usize;
        a.pixels[row.clone()]
            .iter()
            .zip(&b.pixels[row])
            .all(|(p, q)| p.to_array().map(f32::to_bits) == q.to_array().map(f32::to_bits))
    })
}

/// A message: its length first (patched in when it is complete), then `body`'s bytes.
struct Packet(Vec<u8>);

impl Packet {
    fn new(kind: u8) -> Packet {
        let mut bytes = vec![0; 4];
        bytes.push(kind);
        Packet(bytes)
    }
    fn u8(mut self, v: u8) -> Packet {
        self.0.push(v);
        self
    }
    fn i32(mut self, v: u32) -> Packet {
        self.0.extend_from_slice(&(v as i32).to_le_bytes());
        self
    }
    fn string(mut self, s: &str) -> Packet {
        self.0.extend_from_slice(s.as_bytes());
        self.0.push(0);
        self
    }
    fn done(mut self) -> Vec<u8> {
        let len = self.0.len() as u32;
        self.0[..4].copy_from_slice(&len.to_le_bytes());
        self.0
    }
}

/// "Create image": a blank image of `channels` named `title`, brought to the front.
fn create_image(title: &str, width: u32, height: u32, channels: &[&str]) -> Vec<u8> {
    let mut p = Packet::new(CREATE_IMAGE)
        .u8(1)
        .string(title)
        .i32(width)
        .i32(height)
        .i32(channels.len() as u32);
    for c in channels {
        p = p.string(c);
    }
    p.done()
}

/// "Update image": one channel's values over the tile at (x, y) of size w×h, row by row.
fn update_image(
    title: &str,
    channel: &str,
    (x, y, w, h): (u32, u32, u32, u32),
    values: impl Iterator<Item = f32>,
) -> Vec<u8> {
    let mut p = Packet::new(UPDATE_IMAGE)
        .u8(0)
        .string(title)
        .string(channel)
        .i32(x)
        .i32(y)
        .i32(w)
        .i32(h);
    for v in values {
        p.0.extend_from_slice(&v.to_le_bytes());
    }
    p.done()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn addresses_are_host_and_port() {
        let a: DisplayAddress = "localhost:14158".parse().unwrap();
        assert_eq!((a.host.as_str(), a.port), ("localhost", 14158));
        let b: DisplayAddress = "[::1]:9".parse().unwrap();
        assert_eq!((b.host.as_str(), b.port), ("::1", 9));
        assert_eq!(b.to_string(), "[::1]:9");
        for bad in [
            "localhost",
            ":14158",
            "host:",
            "host:0",
            "host:70000",
            "a b:1",
            "",
        ] {
            let e = bad.parse::<DisplayAddress>().unwrap_err().to_string();
            assert!(
                e.starts_with("--display-server: expected HOST:PORT"),
                "{bad}: {e}"
            );
        }
    }

    #[test]
    fn messages_carry_their_length_and_fields() {
        let m = create_image("a", 3, 2, &["R", "G"]);
        assert_eq!(
            u32::from_le_bytes(m[..4].try_into().unwrap()) as usize,
            m.len()
        );
        assert_eq!(&m[4..8], &[CREATE_IMAGE, 1, b'a', 0]);
        assert_eq!(i32::from_le_bytes(m[8..12].try_into().unwrap()), 3);
        assert_eq!(i32::from_le_bytes(m[16..20].try_into().unwrap()), 2);
        assert_eq!(&m[20..], b"R\0G\0");
        let u = update_image("a", "B", (128, 0, 2, 1), [1.5f32, -2.0].into_iter());
        assert_eq!(u.len(), 4 + 1 + 1 + 2 + 2 + 16 + 8);
        assert_eq!(
            u32::from_le_bytes(u[..4].try_into().unwrap()) as usize,
            u.len()
        );
        assert_eq!(i32::from_le_bytes(u[10..14].try_into().unwrap()), 128);
        assert_eq!(f32::from_le_bytes(u[26..30].try_into().unwrap()), 1.5);
        assert_eq!(f32::from_le_bytes(u[30..34].try_into().unwrap()), -2.0);
    }

    #[test]
    fn tiles_cover_the_image_once() {
        let mut covered = vec![0u8; 300 * 130];
        for (x0, y0, w, h) in tiles(300, 130) {
            for y in y0..y0 + h {
                for x in x0..x0 + w {
                    covered[(y * 300 + x) as usize] += 1;
                }
            }
        }
        assert!(covered.iter().all(|&c| c == 1));
        assert_eq!(tiles(300, 130).count(), 6);
    }
}
