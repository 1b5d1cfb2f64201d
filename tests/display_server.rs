//! `--display-server`: a render streams its image to a viewer speaking tev's protocol. A
//! fake viewer here listens, decodes every message and rebuilds the image from the tiles;
//! the last image it holds must be the written image bit for bit.

mod common;
use common::{assert_clean_failure_of, raylink, stderr};
use std::io::Read;
use std::net::{TcpListener, TcpStream};
use std::path::Path;

/// What the fake viewer received on one connection.
#[derive(Debug, Default)]
struct Received {
    /// (title, width, height, channel names) of each "create image".
    created: Vec<(String, u32, u32, Vec<String>)>,
    /// The image as rebuilt from the updates, one plane a channel.
    planes: Vec<Vec<f32>>,
    updates: usize,
}

fn string(bytes: &[u8], at: &mut usize) -> String {
    let end = *at
        + bytes[*at..]
            .iter()
            .position(|&b| b == 0)
            .expect("a zero byte");
    let s = String::from_utf8(bytes[*at..end].to_vec()).expect("UTF-8");
    *at = end + 1;
    s
}

fn int(bytes: &[u8], at: &mut usize) -> u32 {
    let v = i32::from_le_bytes(bytes[*at..*at + 4].try_into().unwrap());
    *at += 4;
    u32::try_from(v).expect("a non-negative integer")
}

/// Reads messages until the client closes the connection.
fn receive(mut stream: TcpStream) -> Received {
    let mut got = Received::default();
    loop {
        let mut len = [0u8; 4];
        if stream.read_exact(&mut len).is_err() {
            return got;
        }
        let len = u32::from_le_bytes(len) as usize;
        assert!(len >= 6, "message length {len}");
        let mut body = vec![0u8; len - 4];
        stream.read_exact(&mut body).expect("a whole message");
        let mut at = 2;
        match body[0] {
            4 => {
                let title = string(&body, &mut at);
                let (w, h, n) = (
                    int(&body, &mut at),
                    int(&body, &mut at),
                    int(&body, &mut at),
                );
                let names = (0..n).map(|_| string(&body, &mut at)).collect();
                assert_eq!(at, body.len(), "create image: trailing bytes");
                got.planes = vec![vec![f32::NAN; (w * h) as usize]; n as usize];
                got.created.push((title, w, h, names));
            }
            3 => {
                let (_, width, _, names) = got.created.last().expect("created first").clone();
                let _title = string(&body, &mut at);
                let channel = string(&body, &mut at);
                let c = names.iter().position(|n| *n == channel).expect("a channel");
                let (x0, y0, w, h) = (
                    int(&body, &mut at),
                    int(&body, &mut at),
                    int(&body, &mut at),
                    int(&body, &mut at),
                );
                assert_eq!(body.len() - at, (w * h * 4) as usize, "update's values");
                for y in 0..h {
                    for x in 0..w {
                        let v = f32::from_le_bytes(body[at..at + 4].try_into().unwrap());
                        at += 4;
                        got.planes[c][((y0 + y) * width + x0 + x) as usize] = v;
                    }
                }
                got.updates += 1;
            }
            kind => panic!("unexpected message type {kind}"),
        }
    }
}

/// A fake viewer on a free port: its address and the thread that returns what it received.
fn viewer() -> (String, std::thread::JoinHandle<Received>) {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let address = listener.local_addr().unwrap().to_string();
    let thread = std::thread::spawn(move || receive(listener.accept().unwrap().0));
    (address, thread)
}

fn assert_shows_written_image(got: &Received, out: &Path) {
    let written = raylink::image::io::read(out).unwrap();
    let (title, w, h, names) = &got.created[0];
    assert!(title.starts_with("out.exr ("), "{title}");
    assert_eq!((*w, *h), (written.width, written.height));
    assert_eq!(names, &["R", "G", "B"]);
    for (c, plane) in got.planes.iter().enumerate() {
        for (i, v) in plane.iter().enumerate() {
            let expected = written.data[i * written.channels.len() + c];
            assert_eq!(v.to_bits(), expected.to_bits(), "channel {c}, pixel {i}");
        }
    }
}

#[test]
fn the_viewer_ends_with_the_written_image() {
    for integrator in ["path", "whitted"] {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("out.exr");
        let (address, viewer) = viewer();
        let run = raylink(&[
            "render",
            "scenes/cornell-box.toml",
            "--integrator",
            integrator,
            "--spp",
            "16",
            "--width",
            "150",
            "--height",
            "130",
            "-o",
            out.to_str().unwrap(),
            "--display-server",
            &address,
        ]);
        assert!(run.status.success(), "{integrator}: {}", stderr(&run));
        assert!(!stderr(&run).contains("warning"), "{}", stderr(&run));
        let got = viewer.join().unwrap();
        // 150x130 is four tiles of 128: at least one update of each channel of each.
        assert!(got.updates >= 12, "{integrator}: {} updates", got.updates);
        assert_shows_written_image(&got, &out);
    }
}

#[test]
fn a_missing_viewer_costs_a_warning_not_the_image() {
    let port = TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port();
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.exr");
    let address = format!("127.0.0.1:{port}");
    let run = raylink(&[
        "render",
        "scenes/cornell-box.toml",
        "--integrator",
        "path",
        "--spp",
        "4",
        "--width",
        "32",
        "--height",
        "32",
        "-o",
        out.to_str().unwrap(),
        "--display-server",
        &address,
    ]);
    assert!(run.status.success(), "{}", stderr(&run));
    assert!(out.exists());
    let err = stderr(&run);
    let warning = format!("raylink: warning: --display-server {address}: ");
    assert_eq!(
        err.lines().filter(|l| l.starts_with(&warning)).count(),
        1,
        "{err}"
    );
}

#[test]
fn bad_addresses_are_refused_before_any_work() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.exr");
    for (address, extra) in [
        ("localhost", &[][..]),
        ("localhost:0", &[]),
        ("localhost:99999", &[]),
        (":14158", &[]),
        ("127.0.0.1:14158", &["--crop", "0,0,8,8"]),
    ] {
        let mut args = vec![
            "render",
            "scenes/cornell-box.toml",
            "-o",
            out.to_str().unwrap(),
            "--display-server",
            address,
        ];
        args.extend_from_slice(extra);
        let run = raylink(&args);
        assert_clean_failure_of(address, &run, &["--display-server"]);
        assert!(!out.exists(), "{address}");
    }
}
