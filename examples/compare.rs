//! Compares a render with a reference: `cargo run --release --example compare -- RENDER REF [SIZE]`.
//! Prints the RMSE at SIZE×SIZE (box-downsampled, default 256) with and without the light's
//! pixels (reference pixels brighter than 1), and the mean colours.

use raylink::image::compare::{box_downsample, bright_mask, mean, rmse};
use raylink::image::output::read_image;
use std::path::Path;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 3 {
        eprintln!("usage: compare RENDER REFERENCE [SIZE]");
        std::process::exit(2);
    }
    let size: u32 = args
        .get(3)
        .map_or(256, |s| s.parse().expect("SIZE is a number"));
    let load = |p: &str| {
        let (img, _) = read_image(Path::new(p)).unwrap_or_else(|e| {
            eprintln!("{e}");
            std::process::exit(2)
        });
        box_downsample(&img, size, size).unwrap_or_else(|| {
            eprintln!(
                "{p}: {}x{} does not divide into {size}",
                img.width, img.height
            );
            std::process::exit(2)
        })
    };
    let (a, r) = (load(&args[1]), load(&args[2]));
    let mask = bright_mask(&r, 1.0);
    println!(
        "rmse {:.5} (without light pixels {:.5}); mean {:?} vs reference {:?}",
        rmse(&a, &r, None),
        rmse(&a, &r, Some(&mask)),
        mean(&a, Some(&mask)),
        mean(&r, Some(&mask))
    );
}
