//! Agreement of independent estimators of one image (path, light and bidirectional path
//! tracing), each rendered with several seeds: per pixel, Welch's t of two estimators' means
//! over the standard error of their difference, and the same over the whole image.

use raylink::image::Image;

/// Per-pixel mean and variance of the mean, over renders with different seeds, of the sum
/// of the channels.
pub fn stats(images: &[Image]) -> (Vec<f64>, Vec<f64>) {
    let k = images.len() as f64;
    let n = images[0].pixels.len();
    let (mut mean, mut var) = (vec![0.0; n], vec![0.0; n]);
    for i in 0..n {
        let v: Vec<f64> = images
            .iter()
            .map(|im| {
                let p = im.pixels[i];
                (p.x + p.y + p.z) as f64
            })
            .collect();
        let m = v.iter().sum::<f64>() / k;
        mean[i] = m;
        var[i] = v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (k - 1.0) / k;
    }
    (mean, var)
}

/// For each of `runs` (a name and what to render), [`stats`] over 8 renders by `render`
/// with seeds 100 to 107, as [`assert_agree`] takes them.
pub fn over_seeds<'a, R>(
    runs: impl IntoIterator<Item = (&'a str, R)>,
    render: impl Fn(&R, u64) -> Image,
) -> Vec<(&'a str, Vec<f64>, Vec<f64>)> {
    runs.into_iter()
        .map(|(name, run)| {
            let images: Vec<Image> = (100..108).map(|seed| render(&run, seed)).collect();
            let (m, v) = stats(&images);
            (name, m, v)
        })
        .collect()
}

/// Asserts that every pair of `results` (name, per-pixel means and variances from
/// [`stats`]) agrees: at most 1% of the compared pixels beyond 5 standard errors, and the
/// image-wide mean difference within 4. `compared(a, b, i)` says whether pixel `i` counts
/// between the estimators named `a` and `b`.
pub fn assert_agree(
    results: &[(&str, Vec<f64>, Vec<f64>)],
    compared: impl Fn(&str, &str, usize) -> bool,
) {
    for a in 0..results.len() {
        for b in a + 1..results.len() {
            let (ka, ma, va) = &results[a];
            let (kb, mb, vb) = &results[b];
            let (mut outliers, mut count) = (0, 0);
            let (mut diff, mut var) = (0.0, 0.0);
            for i in (0..ma.len()).filter(|&i| compared(ka, kb, i)) {
                count += 1;
                let d = ma[i] - mb[i];
                let se = (va[i] + vb[i]).sqrt();
                diff += d;
                var += va[i] + vb[i];
                if se > 0.0 && (d / se).abs() > 5.0 || se == 0.0 && d.abs() > 1e-4 {
                    outliers += 1;
                }
            }
            let z = diff / var.sqrt();
            eprintln!(
                "{ka} vs {kb}: {outliers} of {count} pixels beyond 5 se, image-wide z = {z:.2}"
            );
            assert!(count > 0, "{ka} vs {kb}: no pixel compared");
            assert!(outliers <= count / 100, "{ka} vs {kb}: {outliers} outliers");
            assert!(
                z.abs() < 4.0,
                "{ka} vs {kb}: mean differs by {z:.1} standard errors"
            );
        }
    }
}
