//! The scene readers against the technique list (`raylink::job::TECHNIQUES`): every setting
//! a registered technique reads from a scene file is read by the native format at the key
//! the technique declares, and the pbrt reader renders every pbrt-v4 `Integrator` type a
//! technique claims with that technique, and warns of the others.

use raylink::job::TECHNIQUES;
use std::path::Path;

/// The Cornell box without its render settings.
fn world() -> String {
    let text = std::fs::read_to_string("scenes/cornell-box.toml").unwrap();
    let render = "[render]\nintegrator = \"path\"\nspp = 64\nmax_depth = 8\n";
    assert!(text.contains(render), "the scene's render table changed");
    text.replace(render, "")
}

#[test]
fn the_scene_format_reads_every_setting_of_every_technique() {
    let world = world();
    let mut checked = 0;
    for technique in TECHNIQUES {
        for setting in technique.all_settings() {
            let Some((table, key)) = setting.scene_key else {
                continue;
            };
            let mut text = world.clone() + "\n[render]\n";
            if setting.name != "integrator" {
                text += &format!("integrator = \"{}\"\n", technique.kind.name());
            }
            if table != "render" {
                text += &format!("[{table}]\n");
            }
            text += &format!("{key} = {}\n", setting.example);
            let scene = raylink::scene::toml::from_str(&text, Path::new("scenes/t.toml"))
                .unwrap_or_else(|e| panic!("{} [{table}] {key}: {e}", technique.kind));
            let mut given = scene.settings.given();
            given.sort();
            let mut expected = vec![setting.name, "integrator"];
            expected.sort();
            expected.dedup();
            assert_eq!(given, expected, "{} [{table}] {key}", technique.kind);
            checked += 1;
        }
    }
    assert!(checked > 30, "{checked} settings checked");
}

#[test]
fn the_pbrt_reader_maps_integrators_as_the_techniques_declare() {
    // pbrt-v4's integrators (src/pbrt/cpu/integrators.cpp, Integrator::Create).
    let pbrt_v4 = [
        "volpath",
        "path",
        "simplepath",
        "simplevolpath",
        "bdpt",
        "lighttracer",
        "mlt",
        "sppm",
        "ambientocclusion",
        "aov",
        "randomwalk",
        "function",
    ];
    for ty in pbrt_v4 {
        let text = format!(
            "Integrator \"{ty}\"\nCamera \"perspective\"\nWorldBegin\n\
             LightSource \"point\" \"point3 from\" [0 0 -2]\nShape \"sphere\"\n"
        );
        let scene = raylink::scene::pbrt::from_str(&text, Path::new("t.pbrt"))
            .unwrap_or_else(|e| panic!("{ty}: {e}"));
        let claimed = TECHNIQUES.iter().find(|t| t.pbrt.contains(&ty));
        let warned = scene
            .warnings
            .iter()
            .any(|w| w.contains(&format!("Integrator \"{ty}\" is not supported")));
        match claimed {
            Some(t) => {
                assert_eq!(scene.settings.integrator, Some(t.kind), "{ty}");
                assert!(!warned, "{ty}: {:?}", scene.warnings);
            }
            None => assert!(
                warned,
                "{ty} is read without a warning: {:?}",
                scene.warnings
            ),
        }
    }
    // What the techniques claim is pbrt-v4's.
    for t in TECHNIQUES {
        for ty in t.pbrt {
            assert!(
                pbrt_v4.contains(ty),
                "{}: {ty} is not a pbrt-v4 integrator",
                t.kind
            );
        }
    }
}
