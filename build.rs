//! Locates the system Embree (4, else 3) and OpenImageIO, generates Embree bindings with
//! bindgen and compiles the small C API over OpenImageIO in `ffi/oiio.cpp` and the processor
//! and clock functions in `ffi/platform.c`.

use std::env;
use std::path::{Path, PathBuf};

/// An Embree installation: its major version, the directory holding `embreeN/rtcore.h`,
/// and where to find the library (None: leave it to the linker's default path).
struct Embree {
    major: u32,
    include_dir: PathBuf,
    lib_dirs: Vec<PathBuf>,
}

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-changed=ffi/embree.h");
    println!("cargo:rerun-if-changed=ffi/oiio.h");
    println!("cargo:rerun-if-changed=ffi/oiio.cpp");
    println!("cargo:rerun-if-changed=ffi/platform.h");
    println!("cargo:rerun-if-changed=ffi/platform.c");
    println!("cargo:rerun-if-env-changed=EMBREE_DIR");
    println!("cargo::rustc-check-cfg=cfg(embree4)");
    println!("cargo::rustc-check-cfg=cfg(embree3)");

    let embree = find_embree().unwrap_or_else(|| {
        fail(
            "Embree was not found (looked in $EMBREE_DIR, /usr/local, /usr and pkg-config for \
             embree4 and embree3). Install it with `apt-get install libembree-dev` \
             (Debian 12 ships Embree 3, Debian 13 Embree 4), or set EMBREE_DIR to its prefix.",
        )
    });
    bind_embree(&embree);
    build_oiio();
    build_platform();
}

/// The processor and clock functions of `ffi/platform.c`.
fn build_platform() {
    cc::Build::new()
        .file("ffi/platform.c")
        .warnings(true)
        .compile("raylink_platform");
}

fn fail(message: &str) -> ! {
    eprintln!("error: {message}");
    panic!("{message}");
}

/// Embree 4 first, then Embree 3; within each, `EMBREE_DIR`, then pkg-config, then the usual prefixes.
fn find_embree() -> Option<Embree> {
    let override_dir = env::var_os("EMBREE_DIR").map(PathBuf::from);
    for major in [4, 3] {
        if let Some(prefix) = &override_dir {
            if let Some(found) = embree_in_prefix(prefix, major) {
                return Some(found);
            }
        }
        if let Ok(lib) = pkg_config::Config::new()
            .cargo_metadata(false)
            .probe(&format!("embree{major}"))
        {
            if let Some(include_dir) = lib
                .include_paths
                .iter()
                .find(|dir| dir.join(format!("embree{major}/rtcore.h")).exists())
            {
                return Some(Embree {
                    major,
                    include_dir: include_dir.clone(),
                    lib_dirs: lib.link_paths.clone(),
                });
            }
        }
        for prefix in ["/usr/local", "/usr"] {
            if let Some(found) = embree_in_prefix(Path::new(prefix), major) {
                return Some(found);
            }
        }
    }
    None
}

fn embree_in_prefix(prefix: &Path, major: u32) -> Option<Embree> {
    let include_dir = prefix.join("include");
    if !include_dir.join(format!("embree{major}/rtcore.h")).exists() {
        return None;
    }
    let lib_name = format!("libembree{major}.so");
    let lib_dirs = [
        "lib",
        "lib64",
        "lib/x86_64-linux-gnu",
        "lib/aarch64-linux-gnu",
    ]
    .iter()
    .map(|sub| prefix.join(sub))
    .filter(|dir| dir.join(&lib_name).exists())
    .collect();
    Some(Embree {
        major,
        include_dir,
        lib_dirs,
    })
}

fn bind_embree(embree: &Embree) {
    let major = embree.major;
    println!("cargo:rustc-cfg=embree{major}");
    for dir in &embree.lib_dirs {
        println!("cargo:rustc-link-search=native={}", dir.display());
    }
    println!("cargo:rustc-link-lib=dylib=embree{major}");

    let bindings = bindgen::Builder::default()
        .header("ffi/embree.h")
        .clang_arg(format!("-I{}", embree.include_dir.display()))
        .clang_arg(format!("-DRAYLINK_EMBREE_MAJOR={major}"))
        .allowlist_function("rtc.*")
        .allowlist_type("RTC.*")
        .allowlist_var("RTC.*")
        .layout_tests(true)
        .derive_default(true)
        .prepend_enum_name(false)
        .generate()
        .unwrap_or_else(|e| {
            fail(&format!(
                "bindgen failed on ffi/embree.h ({e}); it needs libclang: `apt-get install libclang-dev`"
            ))
        });
    let out = PathBuf::from(env::var("OUT_DIR").expect("cargo sets OUT_DIR"));
    bindings
        .write_to_file(out.join("embree_bindings.rs"))
        .expect("writing the Embree bindings to OUT_DIR");
}

fn build_oiio() {
    let oiio = pkg_config::Config::new()
        .atleast_version("2.2")
        .probe("OpenImageIO")
        .unwrap_or_else(|e| {
            fail(&format!(
                "OpenImageIO was not found by pkg-config ({e}). Install it with \
                 `apt-get install libopenimageio-dev pkg-config`."
            ))
        });
    let mut build = cc::Build::new();
    build
        .cpp(true)
        .std("c++17")
        .file("ffi/oiio.cpp")
        .warnings(true);
    for dir in &oiio.include_paths {
        build.include(dir);
    }
    for (name, value) in &oiio.defines {
        build.define(name, value.as_deref());
    }
    build.compile("raylink_oiio");
}
