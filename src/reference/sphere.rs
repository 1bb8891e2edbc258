//! `sphere`: the view from the centre of the rotating environment sphere.

use crate::conventions::{bilinear, equirect_uv, jitter, sphere_direction, Camera, Mat3};
use crate::image::{HdrImage, LinearImage};
use crate::par::*;

/// Renders `camera`'s view of `env` rotated by `rotation`, averaging `spp`
/// Halton(2,3)-jittered samples per pixel in f64 (the accumulation buffer of
/// the TAA thesis, docs/bibliography.md; 1 spp is the unjittered plain path).
/// Each pixel is computed on its own in a fixed sample order, so the result
/// does not depend on threads.
pub fn sphere(env: &HdrImage, camera: &Camera, rotation: &Mat3, spp: u32) -> LinearImage {
    let spp = spp.max(1);
    let offsets: Vec<(f64, f64)> = (0..spp).map(|k| jitter(k, spp)).collect();
    sphere_samples(env, camera, rotation, &offsets)
}

/// One sample per pixel at the sub-pixel `offset`: a TAA frame
/// (`conventions::taa_jitter`).
pub fn sphere_jittered(
    env: &HdrImage,
    camera: &Camera,
    rotation: &Mat3,
    offset: (f64, f64),
) -> LinearImage {
    sphere_samples(env, camera, rotation, &[offset])
}

fn sphere_samples(
    env: &HdrImage,
    camera: &Camera,
    rotation: &Mat3,
    offsets: &[(f64, f64)],
) -> LinearImage {
    let (w, h) = (camera.width as usize, camera.height as usize);
    let spp = offsets.len();
    let mut pixels = vec![[0.0f64; 3]; w * h];
    pixels.par_chunks_mut(w).enumerate().for_each(|(j, row)| {
        for (i, out) in row.iter_mut().enumerate() {
            let mut acc = [0.0f64; 3];
            for &(jx, jy) in offsets {
                let d = camera.ray(i as f64 + 0.5 + jx, j as f64 + 0.5 + jy);
                let (u, v) = equirect_uv(sphere_direction(rotation, d));
                let c = bilinear(env, u, v);
                acc[0] += c[0];
                acc[1] += c[1];
                acc[2] += c[2];
            }
            let n = spp as f64;
            *out = [acc[0] / n, acc[1] / n, acc[2] / n];
        }
    });
    LinearImage {
        width: camera.width,
        height: camera.height,
        pixels,
    }
}
