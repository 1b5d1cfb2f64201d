//! `raylink serve` through its HTTP API, what it renders and saves: the image, its auxiliary
//! images, a moved camera, relighting, an animation's frames and the reference are what
//! `raylink render` and `raylink animate` write, bit for bit; undo and reset go back.

mod common;
mod studio;

use common::{raylink, stderr};
use studio::{assert_one_line, mean, Server, PATH};

const NETWORK: [&str; 9] = [
    "scenes/network-room.toml",
    "--width",
    "48",
    "--height",
    "36",
    "--slopes",
    "6",
    "--intercept-step",
    "0.0625",
];

/// The render command's image, read back through the library.
fn rendered(args: &[&str]) -> Vec<f32> {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.exr");
    let mut all = vec!["render", "--quiet", "-o", out.to_str().unwrap()];
    all.extend(args);
    let run = raylink(&all);
    assert!(run.status.success(), "{}", stderr(&run));
    let (image, _) = raylink::read_image(&out).unwrap();
    image.pixels.iter().flat_map(|p| [p.x, p.y, p.z]).collect()
}

fn bits(v: &[f32]) -> Vec<u32> {
    v.iter().map(|x| x.to_bits()).collect()
}

/// The served images equal the render command's, bit for bit: the path tracer (its
/// passes, then the whole image) and the network.
#[test]
fn the_served_image_is_the_render_commands_bit_for_bit() {
    for args in [&PATH[..], &NETWORK[..]] {
        let server = Server::start(args);
        let state = server.wait_done(1);
        let served = server.get("/api/image").floats();
        let expected = rendered(args);
        assert_eq!(served.len(), expected.len(), "{args:?}");
        assert!(mean(&expected) > 0.0);
        assert!(bits(&served) == bits(&expected), "{args:?}: {state}");
        // The saved EXR too: under a name of the server's, in --save-dir (here the root).
        assert_eq!(server.stop().code(), Some(130));
    }
}

/// A spectral render in the studio: the status says so, the image is the render command's
/// bit for bit, and a saved EXR records the mode as the command's outputs do.
#[test]
fn the_studio_shows_and_saves_spectral_mode() {
    let dir = tempfile::tempdir().unwrap();
    let mut args = PATH.to_vec();
    args.extend(["--spectral", "true"]);
    let expected = rendered(&args);
    args.extend(["--save-dir", dir.path().to_str().unwrap()]);
    let server = Server::start(&args);
    let state = server.wait_done(1);
    assert_eq!(state["spectral"], true, "{state}");
    assert!(bits(&server.get("/api/image").floats()) == bits(&expected));
    let json = "Content-Type: application/json\r\n";
    let saved = server.request("POST", "/api/save", json, b"{\"format\":\"exr\"}");
    assert_eq!(saved.status, 200, "{}", saved.text());
    let (_, meta) = raylink::read_image(&dir.path().join("studio-0001.exr")).unwrap();
    assert!(
        meta.iter().any(|(n, _)| n == "raylink:spectral"),
        "{meta:?}"
    );
    assert_eq!(server.stop().code(), Some(130));
    // An RGB render says RGB.
    let server = Server::start(&PATH);
    assert_eq!(server.wait_done(1)["spectral"], false);
    assert_eq!(server.stop().code(), Some(130));
}

#[test]
fn saving_writes_the_image_under_generated_names_in_the_save_dir() {
    let dir = tempfile::tempdir().unwrap();
    let mut args = PATH.to_vec();
    args.extend(["--save-dir", dir.path().to_str().unwrap()]);
    let server = Server::start(&args);
    server.wait_done(1);
    let served = server.get("/api/image").floats();
    let json = "Content-Type: application/json\r\n";
    let first = server.request("POST", "/api/save", json, b"{\"format\":\"exr\"}");
    assert_eq!(first.status, 200, "{}", first.text());
    assert_eq!(first.json()["file"], "studio-0001.exr");
    let second = server.request("POST", "/api/save", json, b"{\"format\":\"png\"}");
    assert_eq!(second.json()["file"], "studio-0002.png");
    let (image, _) = raylink::read_image(&dir.path().join("studio-0001.exr")).unwrap();
    let saved: Vec<f32> = image.pixels.iter().flat_map(|p| [p.x, p.y, p.z]).collect();
    assert!(bits(&saved) == bits(&served));
    assert!(dir.path().join("studio-0002.png").exists());
    let mut names: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    names.sort();
    assert_eq!(names, ["studio-0001.exr", "studio-0002.png"]);
    assert_eq!(server.stop().code(), Some(130));
}

/// A camera move renders the new view from the network built once, and that view equals
/// `raylink render` of the scene with the page's "copy camera" snippet as its camera.
#[test]
fn a_moved_camera_renders_as_the_scene_with_the_copied_camera() {
    let server = Server::start(&NETWORK);
    server.wait_done(1);
    let first = server.get("/api/image").floats();
    let moved = b"{\"position\":[3.1,2.2,4.2],\"look_at\":[1.5,1.1,0.5],\"up\":[0,1,0],\"fov\":50}";
    let json = "Content-Type: application/json\r\n";
    assert_eq!(
        server.request("POST", "/api/camera", json, moved).status,
        200
    );
    let state = server.wait_done(2);
    assert!(state["view_ms"].as_f64().is_some(), "{state}");
    let served = server.get("/api/image").floats();
    assert!(bits(&served) != bits(&first));
    let snippet = server.get("/api/camera.toml").text();
    assert!(snippet.starts_with("[camera]"), "{snippet}");
    // The scene with its [camera] table replaced by the snippet.
    let text = std::fs::read_to_string("scenes/network-room.toml").unwrap();
    let start = text.find("[camera]").unwrap();
    let end = start + text[start..].find("\n[render]").unwrap();
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("moved.toml");
    let pasted = format!("{}{snippet}{}", &text[..start], &text[end..]);
    std::fs::write(&scene, pasted).unwrap();
    let mut args = NETWORK.to_vec();
    args[0] = scene.to_str().unwrap();
    assert!(bits(&served) == bits(&rendered(&args)));
    assert_eq!(server.stop().code(), Some(130));
}

/// The network's lamp at twice its strength doubles the image (superposition of the
/// light basis: within the distribution's tolerance, 0.1%; allowed 1%); a material's
/// colour scaled changes it; the relight's time is reported.
#[test]
fn relighting_the_network_scales_the_image_as_the_lights() {
    let server = Server::start(&NETWORK);
    let s = server.wait_done(1);
    let lights: Vec<&str> = s["lights"]
        .as_array()
        .unwrap()
        .iter()
        .map(|l| l["name"].as_str().unwrap())
        .collect();
    assert_eq!(lights, ["lamp"]);
    let before = mean(&server.get("/api/image").floats());
    let json = "Content-Type: application/json\r\n";
    let r = server.request("POST", "/api/relight", json, b"{\"lights\":{\"lamp\":2}}");
    assert_eq!(r.status, 200, "{}", r.text());
    let s = server.wait("the relit image", |s| {
        s["status"] == "done" && s["relight_ms"].is_number()
    });
    let after = mean(&server.get("/api/image").floats());
    let ratio = after / before;
    assert!((ratio - 2.0).abs() < 0.02, "{ratio}: {s}");
    let r = server.request(
        "POST",
        "/api/relight",
        json,
        b"{\"materials\":{\"white\":0.5}}",
    );
    assert_eq!(r.status, 200);
    server.wait("the recoloured image", |s| {
        s["status"] == "done" && s["materials"][0]["factor"] == serde_json::json!([0.5, 0.5, 0.5])
    });
    let darker = mean(&server.get("/api/image").floats());
    assert!(darker < 0.9 * after, "{darker} vs {after}");
    // A colour: the lamp's channels each by their own factor (the image, lit by the lamp
    // alone, follows channel by channel).
    let channels = |v: &[f32]| -> [f64; 3] {
        let mut m = [0.0f64; 3];
        for p in v.chunks(3) {
            for c in 0..3 {
                m[c] += p[c] as f64;
            }
        }
        m
    };
    let white = channels(&server.get("/api/image").floats());
    let body = b"{\"lights\":{\"lamp\":[2,1,0.5]}}";
    assert_eq!(
        server.request("POST", "/api/relight", json, body).status,
        200
    );
    server.wait("the tinted lamp", |s| {
        s["status"] == "done" && s["lights"][0]["factor"] == serde_json::json!([2.0, 1.0, 0.5])
    });
    let tinted = channels(&server.get("/api/image").floats());
    for (c, k) in [1.0, 0.5, 0.25].into_iter().enumerate() {
        let ratio = tinted[c] / white[c];
        assert!(
            (ratio - k).abs() < 0.01 * k,
            "channel {c}: x{ratio}, expected x{k}"
        );
    }
    assert_eq!(server.stop().code(), Some(130));
}

/// The auxiliary images, asked for by the page, are `raylink render --aov`'s bit for bit.
#[test]
fn the_served_aovs_are_the_render_commands() {
    let server = Server::start(&PATH);
    let first = server.get("/api/image?kind=albedo");
    assert_eq!(first.status, 409, "computed only once asked for");
    let asked = server.post("/api/aovs", "{\"wanted\":true}");
    assert_eq!(asked.status, 200, "{}", asked.text());
    server.wait("the auxiliary images", |s| s["aovs"] == true);
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.exr");
    let mut args = vec!["render", "--quiet", "--aov", "-o", out.to_str().unwrap()];
    args.extend(PATH);
    let run = raylink(&args);
    assert!(run.status.success(), "{}", stderr(&run));
    for kind in ["albedo", "normal", "depth"] {
        let served = server.get(&format!("/api/image?kind={kind}")).floats();
        let (image, _) = raylink::read_image(&dir.path().join(format!("x.{kind}.exr"))).unwrap();
        let expected: Vec<f32> = image.pixels.iter().flat_map(|p| [p.x, p.y, p.z]).collect();
        assert!(bits(&served) == bits(&expected), "{kind}");
    }
    assert_eq!(server.stop().code(), Some(130));
}

/// With `--reference`, the page gets the reference's floats and the RMSE of the image
/// against it, as the library computes it.
#[test]
fn the_reference_and_its_rmse_are_served() {
    let dir = tempfile::tempdir().unwrap();
    let reference = dir.path().join("reference.exr");
    let mut args = vec!["render", "--quiet", "-o", reference.to_str().unwrap()];
    // Another seed: an image of the same scene with other noise.
    args.extend(PATH.iter().map(|&a| if a == "5" { "9" } else { a }));
    let run = raylink(&args);
    assert!(run.status.success(), "{}", stderr(&run));
    let mut args = PATH.to_vec();
    args.extend(["--reference", reference.to_str().unwrap()]);
    let server = Server::start(&args);
    let s = server.wait_done(1);
    let (expected, _) = raylink::read_image(&reference).unwrap();
    let served = server.get("/api/image?kind=reference").floats();
    let flat: Vec<f32> = expected
        .pixels
        .iter()
        .flat_map(|p| [p.x, p.y, p.z])
        .collect();
    assert!(bits(&served) == bits(&flat));
    let image = server.get("/api/image").floats();
    let mut rendered = expected.clone();
    for (p, c) in rendered.pixels.iter_mut().zip(image.chunks_exact(3)) {
        *p = raylink::math::Vec3::new(c[0], c[1], c[2]);
    }
    // The library's f32 (JSON's parse of it may be an ulp off as f64).
    let rmse = rendered.rmse(&expected);
    assert!(rmse > 0.0);
    assert_eq!(s["rmse"].as_f64().map(|r| r as f32), Some(rmse), "{s}");
    assert_eq!(server.stop().code(), Some(130));
}

/// A keyframed scene's frame slider: each frame asked for is the frame `raylink animate`
/// writes, bit for bit, and a frame after the one before it is rendered coherently (fewer
/// pixels retraced, with their map served); frames outside the animation are refused.
#[test]
fn the_frame_slider_renders_frames_coherently_as_animate_does() {
    const ANIM: [&str; 5] = ["scenes/anim-bounce.toml", "--width", "48", "--height", "36"];
    let server = Server::start(&ANIM);
    let first = server.wait_done(1);
    assert_eq!(first["frames"], serde_json::json!([0, 11]), "{first}");
    assert!(first["frame"].is_null());
    let json = "Content-Type: application/json\r\n";
    let show = |frame: i64| {
        let before = server.state()["image_version"].as_u64().unwrap();
        let body = format!("{{\"frame\":{frame}}}");
        let r = server.request("POST", "/api/frame", json, body.as_bytes());
        assert_eq!(r.status, 200, "{}", r.text());
        let state = server.wait(&format!("frame {frame}"), |s| {
            s["status"] == "done" && s["image_version"].as_u64() > Some(before)
        });
        assert_eq!(state["frame"], frame, "{state}");
        (state, server.get("/api/image").floats())
    };
    let (full, _) = show(4);
    assert_eq!(
        full["retraced"].as_f64(),
        Some(1.0),
        "the first frame is traced in full"
    );
    let (next, served) = show(5);
    let retraced = next["retraced"].as_f64().unwrap();
    // The ball moves over part of the image: about a quarter retraced at this size.
    assert!(retraced > 0.0 && retraced < 0.6, "frame 5 after 4: {next}");
    let map = server.get("/api/image?kind=retrace");
    assert_eq!(map.status, 200);
    assert_eq!(map.floats().len(), served.len());
    // `raylink animate` of frame 5 alone (its first frame, traced in full).
    let dir = tempfile::tempdir().unwrap();
    let pattern = dir.path().join("f%d.exr");
    let mut args = vec!["animate", "--quiet", "--frames", "5", "-o"];
    args.push(pattern.to_str().unwrap());
    args.extend(&ANIM[..]);
    let run = raylink(&args);
    assert!(run.status.success(), "{}", stderr(&run));
    let (image, _) = raylink::read_image(&dir.path().join("f5.exr")).unwrap();
    let expected: Vec<f32> = image.pixels.iter().flat_map(|p| [p.x, p.y, p.z]).collect();
    assert!(mean(&expected) > 0.0);
    assert!(
        bits(&served) == bits(&expected),
        "frame 5 differs from animate's"
    );
    for bad in [
        b"{\"frame\":12}".as_slice(),
        b"{\"frame\":-1}",
        b"{\"frame\":\"x\"}",
    ] {
        let r = server.request("POST", "/api/frame", json, bad);
        assert_eq!(r.status, 400, "{}", r.text());
    }
    assert_eq!(server.stop().code(), Some(130));
    // A scene without keyframes has no slider.
    let still = Server::start(&PATH);
    still.wait_done(1);
    assert!(still.state()["frames"].is_null());
    let r = still.request("POST", "/api/frame", json, b"{\"frame\":0}");
    assert_eq!(r.status, 409, "{}", r.text());
    assert_eq!(still.stop().code(), Some(130));
}

/// A way back from any view: "previous" undoes the last move (a drag's continued moves
/// with it), "scene" returns to the scene file's camera and image, and is undone in turn.
#[test]
fn reset_view_and_undo_go_back() {
    let server = Server::start(&PATH);
    let first = server.wait_done(1);
    let scene_image = server.get("/api/image").floats();
    assert_eq!(first["back_steps"], 0);
    let back = r#"{"to":"previous"}"#;
    let r = server.post("/api/view", back);
    assert_eq!(r.status, 409, "nothing to undo: {}", r.text());
    assert_one_line("nothing to undo", &r);
    let mut view = 1;
    let mut go = |path: &str, body: String| {
        let r = server.post(path, &body);
        assert_eq!(r.status, 200, "{body}: {}", r.text());
        view += 1;
        server.wait_done(view)
    };
    let at = |x: f32, continues: bool| {
        format!(r#"{{"position":[{x},1,9],"look_at":[0,1,0],"continues":{continues}}}"#)
    };
    // Out of the scene and back: a view behind the far wall.
    let left = go("/api/camera", at(0.5, false));
    go("/api/camera", at(40.0, false));
    let s = go("/api/camera", at(80.0, true));
    assert_eq!(s["back_steps"], 2, "{s}");
    let s = go("/api/view", back.into());
    assert_eq!(s["camera"], left["camera"], "{s}");
    let s = go("/api/view", r#"{"to":"scene"}"#.into());
    assert_eq!(s["camera"], first["camera"], "{s}");
    assert!(bits(&server.get("/api/image").floats()) == bits(&scene_image));
    // A second reset changes nothing: "previous" returns to the view before the first.
    let steps = s["back_steps"].clone();
    assert_eq!(server.post("/api/view", r#"{"to":"scene"}"#).status, 200);
    assert_eq!(server.state()["back_steps"], steps);
    let s = go("/api/view", back.into());
    assert_eq!(s["camera"], left["camera"], "{s}");
    let r = server.post("/api/view", r#"{"to":"elsewhere"}"#);
    assert_eq!(r.status, 400, "{}", r.text());
    assert_eq!(server.stop().code(), Some(130));
}
