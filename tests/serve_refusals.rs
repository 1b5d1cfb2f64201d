//! `raylink serve` through its HTTP API, what it refuses: tokens, paths, other sites (reads,
//! event streams, framing), malformed commands, floods and bad options. The server goes on
//! serving after each refusal.

mod common;
mod studio;

use common::{assert_clean_failure_of, raylink, stderr};
use std::io::Read;
use std::net::TcpStream;
use std::time::{Duration, Instant};
use studio::{assert_no_framing, assert_one_line, Server, CROSS_SITE, PATH};

#[test]
fn with_a_token_every_request_must_carry_it() {
    let server = Server::start(&["--token", "s3cret-token", PATH[0], "--width", "8"]);
    let host = format!("Host: {}\r\n", server.addr);
    let ask = |target: &str, extra: &str| {
        server
            .raw(format!("GET {target} HTTP/1.1\r\n{host}{extra}\r\n").as_bytes())
            .status
    };
    for path in ["/", "/api/state", "/api/events", "/api/image", "/nothing"] {
        assert_eq!(ask(path, ""), 401, "{path} without a token");
        assert_eq!(ask(&format!("{path}?token=wrong"), ""), 403, "{path}");
        assert_eq!(
            ask(&format!("{path}?token=s3cret-tokeN"), ""),
            403,
            "{path}"
        );
        assert_eq!(ask(path, "Authorization: Bearer wrong\r\n"), 403, "{path}");
    }
    assert_eq!(ask("/api/state?token=s3cret-token", ""), 200);
    // The scheme's name is case-insensitive; a token given as another scheme is not one.
    for header in ["Bearer", "bearer", "BEARER", "bEaReR"] {
        assert_eq!(
            ask(
                "/api/state",
                &format!("Authorization: {header} s3cret-token\r\n")
            ),
            200,
            "{header}"
        );
    }
    assert_eq!(
        ask("/api/state", "Authorization: Basic s3cret-token\r\n"),
        401
    );
    let page = server.get("/");
    assert_eq!(page.status, 200);
    assert!(page.text().contains("raylink studio"));
    // A command without the token changes nothing.
    let raw = format!(
        "POST /api/camera HTTP/1.1\r\n{host}Content-Type: application/json\r\n\
         Content-Length: 47\r\n\r\n{{\"position\":[0,1,9],\"look_at\":[0,1,0],\"fov\":30}}"
    );
    assert_eq!(server.raw(raw.as_bytes()).status, 401);
    assert_eq!(server.state()["view"], 1);
    assert_eq!(server.stop().code(), Some(130));
}

#[test]
fn no_path_in_a_request_reaches_the_file_system() {
    let server = Server::start(&[PATH[0], "--width", "8"]);
    let host = &server.addr;
    for target in [
        "/../Cargo.toml",
        "/%2e%2e/Cargo.toml",
        "/%2e%2e%2fCargo.toml",
        "/..%2fCargo.toml",
        "/api/../../Cargo.toml",
        "/Cargo.toml",
        "/cli/serve/page.js",
        "//etc/passwd",
        "/etc/passwd",
        "/%2Fetc%2Fpasswd",
        "/api/image/../../../../etc/passwd",
        "/api/image?kind=../../Cargo.toml",
        "/%zz",
        "/%00",
        "http://localhost/../Cargo.toml",
        "../Cargo.toml",
        "C:\\Windows\\win.ini",
    ] {
        let r = server.raw(format!("GET {target} HTTP/1.1\r\nHost: {host}\r\n\r\n").as_bytes());
        assert!((400..500).contains(&r.status), "{target}: {}", r.status);
        let body = r.text();
        assert!(
            !body.contains("[package]") && !body.contains("root:") && !body.contains("studio"),
            "{target}: {body}"
        );
    }
    // Not from another host name (a page elsewhere reaching this one by DNS).
    let r = server.raw(b"GET /api/state HTTP/1.1\r\nHost: attacker.example:80\r\n\r\n");
    assert_eq!(r.status, 403);
    assert_eq!(server.get("/api/state").status, 200);
    assert_eq!(server.stop().code(), Some(130));
}

#[test]
fn malformed_commands_are_refused_and_the_server_goes_on() {
    let server = Server::start(&PATH);
    let json = "Content-Type: application/json\r\n";
    for (body, status) in [
        ("{bad", 400),
        ("", 400),
        ("[]", 400),
        ("{\"position\":[0,1]}", 400),
        ("{\"position\":[0,1,9],\"look_at\":[0,1,0],\"zoom\":2}", 400),
        ("{\"position\":[0,1,9],\"look_at\":[0,1,9]}", 400),
        (
            "{\"position\":[0,1,9],\"look_at\":[0,1,0],\"fov\":500}",
            400,
        ),
        (
            "{\"position\":[0,1,9],\"look_at\":[0,1,0],\"up\":[0,0,1]}",
            400,
        ),
        // Values that are finite but whose differences, lengths or rays overflow, or lie
        // past what the backends trace (Embree aborts on such rays).
        ("{\"position\":[-3e38,0,0],\"look_at\":[3e38,0,0]}", 400),
        ("{\"position\":[0,1,9],\"look_at\":[3e38,3e38,0]}", 400),
        ("{\"position\":[1e30,1,9],\"look_at\":[0,1,0]}", 400),
        (
            "{\"position\":[0,1,9],\"look_at\":[0,1,0],\"up\":[3e38,3e38,0]}",
            400,
        ),
    ] {
        let r = server.request("POST", "/api/camera", json, body.as_bytes());
        assert_eq!(r.status, status, "{body}: {}", r.text());
    }
    let r = server.request(
        "POST",
        "/api/camera",
        json,
        b"{\"position\":[0,1,9],\"look_at\":[3e38,3e38,0]}",
    );
    assert!(
        r.text().contains("look_at") && r.text().contains("overflows"),
        "{}",
        r.text()
    );
    for (path, body) in [
        ("/api/relight", "{\"lights\":{\"nothing\":2}}"),
        ("/api/relight", "{\"lights\":{\"light\":-1}}"),
        ("/api/relight", "{\"materials\":{\"floor\":1.5}}"),
        ("/api/save", "{\"format\":\"exr\",\"path\":\"/tmp/x.exr\"}"),
        ("/api/save", "{\"format\":\"../x\"}"),
    ] {
        let r = server.request("POST", path, json, body.as_bytes());
        assert_eq!(r.status, 400, "{path} {body}: {}", r.text());
    }
    let good = b"{\"position\":[0,1,9],\"look_at\":[0,1,0]}";
    assert_eq!(server.request("POST", "/api/camera", "", good).status, 415);
    // Only the media type application/json itself (any case, with parameters) is JSON: a
    // malformed body is then read as JSON and refused as such (400), not for its type.
    for (content_type, status) in [
        ("application/jsonfoo", 415),
        ("application/json-seq", 415),
        ("text/plain", 415),
        ("Application/JSON; charset=utf-8", 400),
    ] {
        let header = format!("Content-Type: {content_type}\r\n");
        let r = server.request("POST", "/api/camera", &header, b"{bad");
        assert_eq!(r.status, status, "{content_type}");
    }
    let other = "Content-Type: application/json\r\nOrigin: http://attacker.example\r\n";
    assert_eq!(
        server.request("POST", "/api/camera", other, good).status,
        403
    );
    let big = vec![b' '; 65 * 1024];
    assert_eq!(
        server.request("POST", "/api/camera", json, &big).status,
        413
    );
    assert_eq!(server.get("/api/camera").status, 405);
    assert_eq!(server.request("DELETE", "/", "", b"").status, 405);
    assert_eq!(server.get("/api/nothing").status, 404);
    let r = server.raw(b"NONSENSE\r\n\r\n");
    assert_eq!(r.status, 400);
    let huge_head = format!("GET / HTTP/1.1\r\nX: {}\r\n\r\n", "a".repeat(20_000));
    assert_eq!(server.raw(huge_head.as_bytes()).status, 431);
    // None of these moved the camera; the server still answers and renders.
    let s = server.wait_done(1);
    assert_eq!(s["spp"].as_f64(), Some(16.0), "{s}");
    assert_eq!(server.stop().code(), Some(130));
}

/// Hundreds of idle connections: the server handles 32 at a time and answers the rest 503
/// at once (it starts no thread for them), then serves again when they close.
#[test]
fn a_flood_of_connections_is_bounded_and_the_server_recovers() {
    let server = Server::start(&[PATH[0], "--width", "8"]);
    let flood: Vec<TcpStream> = (0..300)
        .map(|_| TcpStream::connect(&server.addr).unwrap())
        .collect();
    // Every connection accepted: the probe, made last, is refused as busy.
    let start = Instant::now();
    let probe = loop {
        let r = server.get("/api/state");
        if r.status == 503 || start.elapsed() > Duration::from_secs(5) {
            break r;
        }
        std::thread::sleep(Duration::from_millis(10));
    };
    assert_eq!(probe.status, 503, "{}", probe.text());
    assert_no_framing("the busy answer", &probe);
    let mut busy = 0;
    for mut s in flood.iter() {
        s.set_read_timeout(Some(Duration::from_millis(1))).unwrap();
        let mut buf = [0u8; 64];
        if let Ok(n) = s.read(&mut buf) {
            busy += buf[..n].starts_with(b"HTTP/1.1 503") as usize;
        }
    }
    assert!(
        (300 - 32..300).contains(&busy),
        "{busy} of 300 refused as busy"
    );
    drop(flood);
    let start = Instant::now();
    loop {
        let r = server.get("/api/state");
        if r.status == 200 {
            break;
        }
        assert!(start.elapsed() < Duration::from_secs(15), "{}", r.status);
        std::thread::sleep(Duration::from_millis(20));
    }
    assert_eq!(server.stop().code(), Some(130));
}

#[test]
fn a_non_loopback_bind_without_a_token_gets_a_random_one() {
    let server = Server::start(&["--bind", "0.0.0.0", PATH[0], "--width", "8"]);
    let token = server.token.clone().expect("a token printed with the URL");
    assert!(
        token.len() == 32 && token.bytes().all(|b| b.is_ascii_hexdigit()),
        "{token}"
    );
    let host = &server.addr;
    let no_token = format!("GET /api/state HTTP/1.1\r\nHost: {host}\r\n\r\n");
    assert_eq!(server.raw(no_token.as_bytes()).status, 401);
    assert_eq!(server.get("/api/state").status, 200);
    assert_eq!(server.stop().code(), Some(130));
}

/// Without a token, a server on another loopback address answers to it as its host (and
/// still to no other name).
#[test]
fn a_server_answers_to_the_address_it_listens_on() {
    let server = Server::start(&["--bind", "127.0.0.2", PATH[0], "--width", "8"]);
    assert!(server.addr.starts_with("127.0.0.2:"), "{}", server.addr);
    assert_eq!(server.token, None);
    assert_eq!(server.get("/api/state").status, 200);
    let other = b"GET /api/state HTTP/1.1\r\nHost: raylink.example:80\r\n\r\n";
    assert_eq!(server.raw(other).status, 403);
    assert_eq!(server.stop().code(), Some(130));
}

#[test]
fn bad_options_are_one_line_errors() {
    let dir = tempfile::tempdir().unwrap();
    let small = dir.path().join("small.exr");
    let w = raylink(&[
        "render",
        PATH[0],
        "--width",
        "4",
        "--height",
        "4",
        "--quiet",
        "-o",
        small.to_str().unwrap(),
    ]);
    assert!(w.status.success(), "{}", stderr(&w));
    for (args, needles) in [
        (vec!["--bind", "localhost"], vec!["--bind", "IP address"]),
        (vec!["--token", "a b"], vec!["--token"]),
        (vec!["-o", "x.png"], vec!["-o/--output", "serve"]),
        (vec!["--resume"], vec!["--resume", "serve"]),
        (vec!["--save-dir", "/nonexistent/dir"], vec!["--save-dir"]),
        (
            vec!["--reference", small.to_str().unwrap()],
            vec!["small.exr", "4x4"],
        ),
        (vec!["--spp", "0"], vec!["--spp"]),
    ] {
        let mut all = vec!["serve", PATH[0], "--port", "0", "--integrator", "path"];
        all.extend(&args);
        let out = raylink(&all);
        assert_clean_failure_of(&format!("{args:?}"), &out, &needles);
    }
}

/// Another site's page reads no state, image, camera or event stream (403, one line saying
/// why); the studio's own page, a typed URL and a client without a browser's headers do.
/// The page itself stays reachable from a link elsewhere.
#[test]
fn cross_site_reads_are_refused_and_own_ones_served() {
    let server = Server::start(&PATH);
    server.wait_done(1);
    for path in [
        "/api/state",
        "/api/image",
        "/api/camera.toml",
        "/api/events",
    ] {
        let ask = |headers: &str| match path {
            "/api/events" => server.open_events(headers).0,
            _ => server.request("GET", path, headers, b""),
        };
        for headers in CROSS_SITE {
            let r = ask(headers);
            assert_eq!(r.status, 403, "{path} with {headers:?}: {}", r.text());
            assert_one_line(path, &r);
        }
        for headers in server.own_headers() {
            let r = ask(&headers);
            assert_eq!(r.status, 200, "{path} with {headers:?}: {}", r.text());
        }
    }
    let page = server.request("GET", "/", CROSS_SITE[1], b"");
    assert_eq!(page.status, 200);
    assert_eq!(server.stop().code(), Some(130));
}

/// Event streams asked for by another site's pages are refused without taking one of the
/// 8 slots: the studio's own page still gets its stream and its events, and all 8 slots.
#[test]
fn cross_site_event_streams_do_not_lock_the_page_out() {
    let server = Server::start(&[PATH[0], "--width", "8"]);
    let held: Vec<TcpStream> = (0..8)
        .map(|i| {
            let (r, s) = server.open_events(CROSS_SITE[i % 2]);
            assert_eq!(r.status, 403, "cross-site stream {i}");
            s
        })
        .collect();
    let own = &server.own_headers()[0];
    let (r, mut stream) = server.open_events(own);
    assert_eq!(r.status, 200, "{}", r.text());
    let mut event = Vec::new();
    let mut byte = [0u8; 1];
    while !event.ends_with(b"\n\n") {
        assert_eq!(stream.read(&mut byte).unwrap(), 1);
        event.push(byte[0]);
    }
    assert!(event.starts_with(b"data: {"), "{event:?}");
    let mut streams: Vec<TcpStream> = (1..8)
        .map(|i| {
            let (r, s) = server.open_events(own);
            assert_eq!(r.status, 200, "own stream {i}: {}", r.text());
            s
        })
        .collect();
    assert_eq!(server.open_events(own).0.status, 503, "a ninth stream");
    streams.push(stream);
    drop((held, streams));
    assert_eq!(server.stop().code(), Some(130));
}

/// Reading an auxiliary image changes nothing: not from another site (403), nor from the
/// page (409 until asked for by POST); a later view computes none until then.
#[test]
fn reading_an_aov_does_not_change_what_later_views_compute() {
    let server = Server::start(&PATH);
    server.wait_done(1);
    for headers in CROSS_SITE {
        let r = server.request("GET", "/api/image?kind=albedo", headers, b"");
        assert_eq!(r.status, 403, "{headers:?}");
    }
    let r = server.get("/api/image?kind=normal");
    assert_eq!(r.status, 409, "{}", r.text());
    assert!(r.text().contains("POST /api/aovs"), "{}", r.text());
    assert_eq!(server.state()["aovs_wanted"], false);
    let moved = server.post(
        "/api/camera",
        "{\"position\":[0.5,1,7],\"look_at\":[0,1,0]}",
    );
    assert_eq!(moved.status, 200, "{}", moved.text());
    let s = server.wait_done(2);
    assert!(s["aovs"] == false && s["aovs_wanted"] == false, "{s}");
    assert_eq!(server.get("/api/image?kind=depth").status, 409);
    assert_eq!(server.post("/api/aovs", "{\"wanted\":true}").status, 200);
    let s = server.wait("the auxiliary images", |s| s["aovs"] == true);
    assert_eq!(s["aovs_wanted"], true);
    assert_eq!(server.get("/api/image?kind=depth").status, 200);
    assert_eq!(server.stop().code(), Some(130));
}

/// Every answer forbids framing: the page (whose own policy still lets its inline script
/// and style run), the API, the event stream, errors, refusals and malformed requests.
#[test]
fn every_response_forbids_framing() {
    let server = Server::start(&[PATH[0], "--width", "8"]);
    let page = server.get("/");
    assert_no_framing("the page", &page);
    let policy = page.header("content-security-policy").unwrap();
    for needed in ["script-src 'unsafe-inline'", "style-src 'unsafe-inline'"] {
        assert!(policy.contains(needed), "{policy}");
    }
    let json = "Content-Type: application/json\r\n";
    let chunked = format!(
        "POST /api/camera HTTP/1.1\r\nHost: {}\r\nTransfer-Encoding: chunked\r\n\r\n",
        server.addr
    );
    for (what, r) in [
        ("state", server.get("/api/state")),
        ("image", server.get("/api/image")),
        ("camera.toml", server.get("/api/camera.toml")),
        ("events", server.open_events("").0),
        (
            "a command",
            server.request("POST", "/api/aovs", json, b"{\"wanted\":false}"),
        ),
        (
            "a bad command",
            server.request("POST", "/api/camera", json, b"{"),
        ),
        ("not JSON", server.request("POST", "/api/camera", "", b"{}")),
        ("unknown path", server.get("/nothing")),
        ("wrong method", server.request("DELETE", "/", "", b"")),
        (
            "cross-site",
            server.request("GET", "/api/state", CROSS_SITE[0], b""),
        ),
        (
            "another host",
            server.raw(b"GET / HTTP/1.1\r\nHost: attacker.example\r\n\r\n"),
        ),
        ("malformed", server.raw(b"NONSENSE\r\n\r\n")),
        ("chunked", server.raw(chunked.as_bytes())),
    ] {
        assert_no_framing(what, &r);
    }
    assert_eq!(server.stop().code(), Some(130));
    let server = Server::start(&["--token", "t0ken", PATH[0], "--width", "8"]);
    let r = server.raw(format!("GET / HTTP/1.1\r\nHost: {}\r\n\r\n", server.addr).as_bytes());
    assert_eq!(r.status, 401);
    assert_no_framing("no token", &r);
    assert_eq!(server.stop().code(), Some(130));
}
