//! The geometric conventions of docs/conventions.md, in one place.
//!
//! `shaders/shared/conventions.wgsl` mirrors every function here under the same
//! name; a test renders both and compares. Change one, change the other.

use crate::image::HdrImage;
use std::f64::consts::PI;

/// Pinhole camera at the sphere's centre, looking down −z with y up.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub width: u32,
    pub height: u32,
    /// Vertical field of view in degrees.
    pub fov_y_deg: f64,
}

/// A row-major 3×3 rotation matrix.
pub type Mat3 = [[f64; 3]; 3];

impl Camera {
    /// The (unnormalised) view direction through the film point (px, py), in
    /// pixels from the top-left corner: pixel (i, j) with jitter (jx, jy) is
    /// sampled at (i + 0.5 + jx, j + 0.5 + jy).
    pub fn ray(&self, px: f64, py: f64) -> [f64; 3] {
        let tan_half = libm::tan(0.5 * self.fov_y_deg.to_radians());
        let aspect = self.width as f64 / self.height as f64;
        let x = (2.0 * px / self.width as f64 - 1.0) * tan_half * aspect;
        let y = (1.0 - 2.0 * py / self.height as f64) * tan_half;
        [x, y, -1.0]
    }
}

/// Rotation by `angle` radians about `axis` (Rodrigues); the axis need not be
/// normalised but must not be zero (scene validation guarantees it).
pub fn rotation_matrix(axis: [f64; 3], angle: f64) -> Mat3 {
    let n = (axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]).sqrt();
    let [x, y, z] = [axis[0] / n, axis[1] / n, axis[2] / n];
    let (s, c) = (libm::sin(angle), libm::cos(angle));
    let t = 1.0 - c;
    [
        [t * x * x + c, t * x * y - s * z, t * x * z + s * y],
        [t * x * y + s * z, t * y * y + c, t * y * z - s * x],
        [t * x * z - s * y, t * y * z + s * x, t * z * z + c],
    ]
}

/// Frame n rotates the sphere by n·ω; a view direction d then meets the map at
/// Rᵀ·d (rotating the sphere by R is rotating the view by R⁻¹ = Rᵀ).
pub fn sphere_direction(rotation: &Mat3, d: [f64; 3]) -> [f64; 3] {
    let r = rotation;
    [
        r[0][0] * d[0] + r[1][0] * d[1] + r[2][0] * d[2],
        r[0][1] * d[0] + r[1][1] * d[1] + r[2][1] * d[2],
        r[0][2] * d[0] + r[1][2] * d[1] + r[2][2] * d[2],
    ]
}

/// Equirectangular texture coordinates of a direction (need not be normalised):
/// u = 0.5 + atan2(d.x, −d.z)/(2π), v = acos(clamp(d.y/|d|, −1, 1))/π.
pub fn equirect_uv(d: [f64; 3]) -> (f64, f64) {
    let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    let u = 0.5 + libm::atan2(d[0], -d[2]) / (2.0 * PI);
    let v = libm::acos((d[1] / len).clamp(-1.0, 1.0)) / PI;
    (u, v)
}

/// The unit direction whose equirect coordinates are (u, v): the inverse of
/// [`equirect_uv`], used to generate the built-in environments.
pub fn equirect_direction(u: f64, v: f64) -> [f64; 3] {
    let theta = v * PI;
    let phi = (u - 0.5) * 2.0 * PI;
    let s = libm::sin(theta);
    [s * libm::sin(phi), libm::cos(theta), -s * libm::cos(phi)]
}

/// Bilinear lookup with texel centres at (k + 0.5)/W, wrapping in u and
/// clamping in v.
pub fn bilinear(env: &HdrImage, u: f64, v: f64) -> [f64; 3] {
    let (w, h) = (env.width as i64, env.height as i64);
    let x = u * w as f64 - 0.5;
    let y = v * h as f64 - 0.5;
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let (x0, y0) = (x0 as i64, y0 as i64);
    let xa = x0.rem_euclid(w) as usize;
    let xb = (x0 + 1).rem_euclid(w) as usize;
    let ya = y0.clamp(0, h - 1) as usize;
    let yb = (y0 + 1).clamp(0, h - 1) as usize;
    let row = env.width as usize;
    let texel = |xi: usize, yi: usize| env.pixels[yi * row + xi];
    let (p00, p10, p01, p11) = (texel(xa, ya), texel(xb, ya), texel(xa, yb), texel(xb, yb));
    let mut out = [0.0; 3];
    for c in 0..3 {
        let top = p00[c] as f64 * (1.0 - fx) + p10[c] as f64 * fx;
        let bottom = p01[c] as f64 * (1.0 - fx) + p11[c] as f64 * fx;
        out[c] = top * (1.0 - fy) + bottom * fy;
    }
    out
}

/// The radical inverse of `index` in `base` (the Halton sequence).
pub fn halton(mut index: u32, base: u32) -> f64 {
    let mut f = 1.0;
    let mut r = 0.0;
    while index > 0 {
        f /= base as f64;
        r += f * (index % base) as f64;
        index /= base;
    }
    r
}

/// Largest supersampling a render may ask for (docs/taa.md: the accumulation
/// reference uses up to 128 jittered samples).
pub const MAX_SPP: u32 = 128;

/// Sub-pixel offset of sample `k` (0-based) out of `spp`, in [−0.5, 0.5):
/// none for a single sample (the plain GPU path), otherwise Halton(2,3) from
/// index 1 (index 0 would put every first sample on the pixel corner).
pub fn jitter(k: u32, spp: u32) -> (f64, f64) {
    if spp <= 1 {
        (0.0, 0.0)
    } else {
        (halton(k + 1, 2) - 0.5, halton(k + 1, 3) - 0.5)
    }
}

/// TAA's jitter cycle: frame n of a TAA sequence renders one sample at the
/// (n mod 16)-th offset of the accumulation reference's own Halton(2,3)
/// sequence (the TAA thesis, docs/bibliography.md, uses its first 16 points
/// in §3.6.1), so 16 consecutive TAA frames visit exactly the 16 sub-pixel
/// positions a 16-spp golden averages.
pub const TAA_JITTER_CYCLE: u32 = 16;

/// The sub-pixel offset frame `n` of a TAA sequence renders at: the same
/// function the supersampling reference uses, sample n mod 16 of 16.
pub fn taa_jitter(n: u32) -> (f64, f64) {
    jitter(n % TAA_JITTER_CYCLE, TAA_JITTER_CYCLE)
}

impl Camera {
    /// The film point (in pixels from the top-left corner) a view direction
    /// passes through: the inverse of [`Camera::ray`]. None when the
    /// direction points away from the film (z ≥ 0).
    pub fn project(&self, d: [f64; 3]) -> Option<(f64, f64)> {
        if d[2].is_nan() || d[2] >= 0.0 {
            return None;
        }
        let tan_half = libm::tan(0.5 * self.fov_y_deg.to_radians());
        let aspect = self.width as f64 / self.height as f64;
        let (x, y) = (d[0] / -d[2], d[1] / -d[2]);
        let px = (x / (tan_half * aspect) + 1.0) * 0.5 * self.width as f64;
        let py = (1.0 - y / tan_half) * 0.5 * self.height as f64;
        Some((px, py))
    }
}

/// The matrix taking a view direction of frame n to the view direction that
/// saw the same point of the sphere in frame n − 1: R(n−1)·R(n)ᵀ. The camera
/// is fixed at the centre and the sphere turns by a known rotation, so TAA's
/// reprojection is exact (the TAA thesis needs a velocity buffer; this scene
/// does not).
pub fn reprojection(previous: &Mat3, current: &Mat3) -> Mat3 {
    let mut m = [[0.0; 3]; 3];
    for (i, row) in m.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = (0..3).map(|k| previous[i][k] * current[j][k]).sum();
        }
    }
    m
}

/// Where pixel (i, j)'s centre was in the previous frame, in pixels from the
/// top-left corner, given the [`reprojection`] matrix: None when that point
/// of the sphere was behind the camera or off the film (history rejected).
/// The centre is unjittered: the jitter moves samples, not the history grid.
pub fn reproject(camera: &Camera, m: &Mat3, i: u32, j: u32) -> Option<(f64, f64)> {
    let d = camera.ray(i as f64 + 0.5, j as f64 + 0.5);
    let p = [
        m[0][0] * d[0] + m[0][1] * d[1] + m[0][2] * d[2],
        m[1][0] * d[0] + m[1][1] * d[1] + m[1][2] * d[2],
        m[2][0] * d[0] + m[2][1] * d[1] + m[2][2] * d[2],
    ];
    let (px, py) = camera.project(p)?;
    let on_film =
        (0.0..=camera.width as f64).contains(&px) && (0.0..=camera.height as f64).contains(&py);
    on_film.then_some((px, py))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn equirect_round_trip() {
        for &(u, v) in &[(0.1, 0.2), (0.5, 0.5), (0.9, 0.7), (0.25, 0.99)] {
            let (u2, v2) = equirect_uv(equirect_direction(u, v));
            assert!(
                (u - u2).abs() < 1e-12 && (v - v2).abs() < 1e-12,
                "{u},{v} -> {u2},{v2}"
            );
        }
    }

    #[test]
    fn centre_ray_looks_down_minus_z_at_u_half() {
        let cam = Camera {
            width: 4,
            height: 2,
            fov_y_deg: 60.0,
        };
        let d = cam.ray(2.0, 1.0);
        assert_eq!(d, [0.0, 0.0, -1.0]);
        assert_eq!(equirect_uv(d), (0.5, 0.5));
    }

    #[test]
    fn rotation_is_orthonormal_and_turns_the_right_way() {
        let r = rotation_matrix([1.0, 0.0, 0.0], std::f64::consts::FRAC_PI_2);
        // Rotating the sphere +90° about x brings what was at +y... the view
        // direction −z meets the map at Rᵀ(−z).
        let d = sphere_direction(&r, [0.0, 0.0, -1.0]);
        assert!(
            (d[0]).abs() < 1e-15 && (d[1] + 1.0).abs() < 1e-15 && d[2].abs() < 1e-15,
            "{d:?}"
        );
        for i in 0..3 {
            for j in 0..3 {
                let dot: f64 = (0..3).map(|k| r[i][k] * r[j][k]).sum();
                assert!((dot - if i == j { 1.0 } else { 0.0 }).abs() < 1e-15);
            }
        }
    }

    #[test]
    fn bilinear_hits_texel_centres_and_wraps() {
        let env = HdrImage::from_fn(4, 2, |x, y| [x as f32, y as f32, 0.0]);
        assert_eq!(bilinear(&env, 0.125, 0.25), [0.0, 0.0, 0.0]);
        assert_eq!(bilinear(&env, 0.375, 0.75), [1.0, 1.0, 0.0]);
        // Halfway between the last and the first column wraps around.
        assert_eq!(bilinear(&env, 1.0, 0.25)[0], 1.5);
        // Above the first texel row clamps.
        assert_eq!(bilinear(&env, 0.125, 0.0)[1], 0.0);
    }

    #[test]
    fn halton_first_values() {
        assert_eq!(halton(1, 2), 0.5);
        assert_eq!(halton(2, 2), 0.25);
        assert_eq!(halton(3, 2), 0.75);
        assert!((halton(1, 3) - 1.0 / 3.0).abs() < 1e-16);
        assert_eq!(jitter(0, 1), (0.0, 0.0));
        let (jx, jy) = jitter(0, 16);
        assert!((-0.5..0.5).contains(&jx) && (-0.5..0.5).contains(&jy));
    }

    #[test]
    fn projection_inverts_the_camera_ray() {
        let cam = Camera {
            width: 320,
            height: 180,
            fov_y_deg: 60.0,
        };
        for &(px, py) in &[(0.5, 0.5), (160.0, 90.0), (319.5, 10.25), (3.0, 179.9)] {
            let (qx, qy) = cam.project(cam.ray(px, py)).unwrap();
            assert!(
                (qx - px).abs() < 1e-9 && (qy - py).abs() < 1e-9,
                "{px},{py} -> {qx},{qy}"
            );
        }
        assert_eq!(cam.project([0.0, 0.0, 1.0]), None);
    }

    #[test]
    fn reprojection_follows_the_sphere_and_rejects_what_left_the_film() {
        let cam = Camera {
            width: 64,
            height: 64,
            fov_y_deg: 60.0,
        };
        let axis = [1.0, 0.0, 0.0];
        let (prev, cur) = (rotation_matrix(axis, 0.10), rotation_matrix(axis, 0.13));
        let m = reprojection(&prev, &cur);
        // A still sphere maps every pixel onto itself.
        let still = reprojection(&cur, &cur);
        let (x, y) = reproject(&cam, &still, 7, 9).unwrap();
        assert!((x - 7.5).abs() < 1e-9 && (y - 9.5).abs() < 1e-9, "{x},{y}");
        // The point pixel (i, j) sees now met the map where, one frame
        // earlier, the reprojected film point's ray met it.
        for (i, j) in [(5, 5), (32, 20), (60, 3)] {
            let Some((px, py)) = reproject(&cam, &m, i, j) else {
                continue;
            };
            let now = sphere_direction(&cur, cam.ray(i as f64 + 0.5, j as f64 + 0.5));
            let then = sphere_direction(&prev, cam.ray(px, py));
            let (a, b) = (equirect_uv(now), equirect_uv(then));
            assert!(
                (a.0 - b.0).abs() < 1e-12 && (a.1 - b.1).abs() < 1e-12,
                "{a:?} {b:?}"
            );
        }
        // Turning about x moves content vertically: the top row came from
        // above the film after a large enough step.
        let big = reprojection(&rotation_matrix(axis, 0.0), &rotation_matrix(axis, 0.3));
        let top = reproject(&cam, &big, 32, 0);
        let bottom = reproject(&cam, &big, 32, 63);
        assert!(top.is_none() != bottom.is_none(), "{top:?} {bottom:?}");
    }

    #[test]
    fn taa_jitter_cycles_through_the_reference_offsets() {
        for n in 0..40 {
            assert_eq!(taa_jitter(n), jitter(n % 16, 16));
        }
        assert_ne!(taa_jitter(0), taa_jitter(1));
    }
}
