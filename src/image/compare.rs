//! Comparing renders with references: box downsampling (a Lanczos resize rings at a light's
//! edges) and root-mean-square error, optionally excluding the pixels of light sources.

use super::Image;
use crate::math::Rgb;

/// Averages `image` onto a `width`×`height` grid; each dimension must divide evenly.
pub fn box_downsample(image: &Image, width: u32, height: u32) -> Option<Image> {
    if width == 0
        || height == 0
        || !image.width.is_multiple_of(width)
        || !image.height.is_multiple_of(height)
    {
        return None;
    }
    let (fx, fy) = (image.width / width, image.height / height);
    let mut out = Image::new(width, height);
    let norm = 1.0 / (fx * fy) as f32;
    for y in 0..height {
        for x in 0..width {
            let mut sum = Rgb::ZERO;
            for dy in 0..fy {
                for dx in 0..fx {
                    sum += image.get(x * fx + dx, y * fy + dy);
                }
            }
            out.set(x, y, sum * norm);
        }
    }
    Some(out)
}

/// Pixels of `reference` brighter than `threshold` in any channel, and their 8 neighbours:
/// the light sources, whose pixels and edges dominate an image-wide error (a sub-pixel
/// difference in where an edge falls changes an edge pixel by a large fraction of the
/// light's radiance).
pub fn bright_mask(reference: &Image, threshold: f32) -> Vec<bool> {
    let (w, h) = (reference.width as i64, reference.height as i64);
    let bright: Vec<bool> = reference
        .pixels
        .iter()
        .map(|p| p.max_element() > threshold)
        .collect();
    let mut mask = bright.clone();
    for y in 0..h {
        for x in 0..w {
            if bright[(y * w + x) as usize] {
                for dy in -1..=1 {
                    for dx in -1..=1 {
                        let (nx, ny) = (x + dx, y + dy);
                        if (0..w).contains(&nx) && (0..h).contains(&ny) {
                            mask[(ny * w + nx) as usize] = true;
                        }
                    }
                }
            }
        }
    }
    mask
}

/// RMSE over all channels of the pixels not excluded by `exclude` (same length as the
/// images when given).
pub fn rmse(a: &Image, b: &Image, exclude: Option<&[bool]>) -> f64 {
    assert_eq!((a.width, a.height), (b.width, b.height));
    let mut sum = 0.0f64;
    let mut n = 0usize;
    for (i, (p, q)) in a.pixels.iter().zip(&b.pixels).enumerate() {
        if exclude.is_some_and(|e| e[i]) {
            continue;
        }
        let d = *p - *q;
        sum += (d.x as f64).powi(2) + (d.y as f64).powi(2) + (d.z as f64).powi(2);
        n += 3;
    }
    (sum / n.max(1) as f64).sqrt()
}

/// Mean colour of the pixels not excluded.
pub fn mean(image: &Image, exclude: Option<&[bool]>) -> Rgb {
    let mut sum = [0.0f64; 3];
    let mut n = 0usize;
    for (i, p) in image.pixels.iter().enumerate() {
        if exclude.is_some_and(|e| e[i]) {
            continue;
        }
        sum[0] += p.x as f64;
        sum[1] += p.y as f64;
        sum[2] += p.z as f64;
        n += 1;
    }
    let n = n.max(1) as f64;
    Rgb::new(
        (sum[0] / n) as f32,
        (sum[1] / n) as f32,
        (sum[2] / n) as f32,
    )
}
