//! With the `embree` feature, locates the system Embree (4, else 3) and generates its
//! bindings with bindgen; with `oiio`, locates OpenImageIO and compiles the small C API over
//! it in `ffi/oiio.cpp`; with either, compiles the exception guards in `ffi/exceptions.cpp`.
//! Without both (the portable build) it does nothing: no C compiler, libclang or pkg-config.

#[cfg(feature = "embree")]
use std::path::Path;
#[cfg(any(feature = "embree", feature = "oiio"))]
use std::{env, path::PathBuf};

#[cfg(feature = "embree")]
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
    println!("cargo:rerun-if-changed=ffi/exceptions.cpp");
    println!("cargo:rerun-if-env-changed=EMBREE_DIR");
    println!("cargo::rustc-check-cfg=cfg(embree4)");
    println!("cargo::rustc-check-cfg=cfg(embree3)");

    #[cfg(feature = "embree")]
    {
        let embree = find_embree().unwrap_or_else(|| {
            fail(
                "Embree was not found (looked in $EMBREE_DIR, /usr/local, /usr and pkg-config \
                 for embree4 and embree3). Install it with `apt-get install libembree-dev` \
                 (Debian 12 ships Embree 3, Debian 13 Embree 4), or set EMBREE_DIR to its \
                 prefix; or build without Embree: \
                 `cargo build --release --no-default-features --features portable`.",
            )
        });
        bind_embree(&embree);
    }
    #[cfg(feature = "oiio")]
    build_oiio();
    #[cfg(any(feature = "embree", feature = "oiio"))]
    build_exception_guards();
}

/// The exception guards of `ffi/exceptions.cpp`: C++ (std::set_terminate, try around
/// dlopen), for the C++ libraries; libstdc++ is Embree's and OpenImageIO's already.
#[cfg(any(feature = "embree", feature = "oiio"))]
fn build_exception_guards() {
    cc::Build::new()
        .cpp(true)
        .file("ffi/exceptions.cpp")
        .warnings(true)
        .compile("raylink_exceptions");
}

#[cfg(any(feature = "embree", feature = "oiio"))]
fn fail(message: &str) -> ! {
    eprintln!("error: {message}");
    panic!("{message}");
}

#[cfg(feature = "embree")]
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

#[cfg(feature = "embree")]
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

#[cfg(feature = "embree")]
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

#[cfg(feature = "oiio")]
/// The C API over OpenImageIO as a shared object, `libraylink_oiio.so` in OUT_DIR, linked
/// against OpenImageIO. The binary does not link OpenImageIO itself: it loads this object
/// when it first reads or writes an image (see `src/image/oiio_sys.rs`), so that starting
/// the program does not load OpenImageIO's ~260 shared libraries (0.25 s, 130 MB).
fn build_oiio() {
    let oiio = pkg_config::Config::new()
        .atleast_version("2.2")
        .cargo_metadata(false)
        .probe("OpenImageIO")
        .unwrap_or_else(|e| {
            fail(&format!(
                "OpenImageIO was not found by pkg-config ({e}). Install it with \
                 `apt-get install libopenimageio-dev pkg-config`, or build without it: \
                 `cargo build --release --no-default-features --features portable`."
            ))
        });
    // The PNG check in ffi/oiio.cpp calls libpng itself (the one OpenImageIO reads PNGs with).
    let png = pkg_config::Config::new()
        .cargo_metadata(false)
        .probe("libpng")
        .unwrap_or_else(|e| {
            fail(&format!(
                "libpng was not found by pkg-config ({e}). Install it with \
                 `apt-get install libpng-dev pkg-config`."
            ))
        });
    // pkg-config may add Debian's fourth component (2.4.7.1): the library's own is three.
    let version: Vec<&str> = oiio.version.split('.').take(3).collect();
    println!(
        "cargo:rustc-env=RAYLINK_OIIO_BUILD_VERSION={}",
        version.join(".")
    );
    let out = PathBuf::from(env::var("OUT_DIR").expect("cargo sets OUT_DIR"));
    let object = out.join("libraylink_oiio.so");
    let compiler = cc::Build::new()
        .cpp(true)
        .std("c++17")
        .pic(true)
        .warnings(true)
        .get_compiler();
    let mut cmd = compiler.to_command();
    cmd.args([
        "-shared",
        "-Wl,-soname,libraylink_oiio.so",
        "-Wl,--no-undefined",
    ]);
    for dir in oiio.include_paths.iter().chain(&png.include_paths) {
        cmd.arg(format!("-I{}", dir.display()));
    }
    for (name, value) in &oiio.defines {
        match value {
            Some(v) => cmd.arg(format!("-D{name}={v}")),
            None => cmd.arg(format!("-D{name}")),
        };
    }
    cmd.arg("ffi/oiio.cpp").arg("-o").arg(&object);
    let system = ["/lib", "/usr/lib", "/lib64", "/usr/lib64"];
    for dir in oiio.link_paths.iter().chain(&png.link_paths) {
        cmd.arg(format!("-L{}", dir.display()));
        // Found at run time without help only in the system's own directories.
        if !system.iter().any(|s| dir.starts_with(s)) {
            cmd.arg(format!("-Wl,-rpath,{}", dir.display()));
        }
    }
    for lib in oiio.libs.iter().chain(&png.libs) {
        cmd.arg(format!("-l{lib}"));
    }
    let status = cmd
        .status()
        .unwrap_or_else(|e| fail(&format!("cannot run the C++ compiler ({e}): {cmd:?}")));
    if !status.success() {
        fail(&format!(
            "compiling ffi/oiio.cpp into a shared object failed: {cmd:?}"
        ));
    }
}
