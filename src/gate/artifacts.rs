//! Artifacts of failing frames (and of each scene's worst frame): actual,
//! golden, diff heat map, SSIM map and FLIP map (magma) PNGs named `<scene>-<frame>-<adapter>-<kind>.png` (wgpu's test harness
//! names its images by adapter the same way).

use super::CheckError;
use crate::check::KeptFrame;
use crate::gpu::compare::GpuCompare;
use crate::image::Frame;
use crate::metrics::{frame_diff_heatmap, frame_flip, frame_ssim, ssim_map_image};
use std::path::Path;

/// The adapter name as a file-name part: lowercase ASCII letters and digits,
/// runs of anything else as one '-', at most 48 characters.
pub fn adapter_slug(name: &str) -> String {
    let mut slug = String::with_capacity(name.len());
    for c in name.chars() {
        if c.is_ascii_alphanumeric() {
            slug.push(c.to_ascii_lowercase());
        } else if !slug.ends_with('-') && !slug.is_empty() {
            slug.push('-');
        }
    }
    let mut slug: String = slug.chars().take(48).collect();
    while slug.ends_with('-') {
        slug.pop();
    }
    if slug.is_empty() {
        "unknown".into()
    } else {
        slug
    }
}

/// `<scene>-<frame>-<adapter>-<kind>.png`, the frame as three digits.
pub fn artifact_name(scene: &str, frame: u32, adapter_slug: &str, kind: &str) -> String {
    format!("{scene}-{frame:03}-{adapter_slug}-{kind}.png")
}

/// The five images of one kept frame as PNG files: (name, bytes). With
/// `gpu` (the check's metrics are on the device), the SSIM and FLIP maps of
/// an 8-bit frame come from the device's passes, as its figures did.
pub(super) fn render_frame(
    scene: &str,
    slug: &str,
    f: &KeptFrame,
    gpu: Option<&GpuCompare>,
) -> Result<Vec<(String, Vec<u8>)>, CheckError> {
    let fail = |name: &str, detail: String| CheckError::Artifact {
        path: name.into(),
        detail,
    };
    let name = |kind: &str| artifact_name(scene, f.frame, slug, kind);
    let metric = |e: crate::metrics::MetricsError| fail(&name("diff"), e.to_string());
    let diff = frame_diff_heatmap(&f.actual, &f.golden).map_err(metric)?;
    let on_device = match (gpu, &f.actual, &f.golden) {
        (Some(g), Frame::Rgb8(a), Frame::Rgb8(b)) => {
            Some(g.maps(a.raster(), b.raster()).map_err(metric)?)
        }
        _ => None,
    };
    let (ssim, flip) = match on_device {
        Some(maps) => maps,
        None => (
            frame_ssim(&f.actual, &f.golden).map_err(metric)?,
            frame_flip(&f.actual, &f.golden).map_err(metric)?,
        ),
    };
    let map = ssim_map_image(&ssim);
    let flip = flip.magma_image();
    let mut files = Vec::with_capacity(5);
    for (kind, img) in [("actual", &f.actual), ("golden", &f.golden)] {
        let bytes =
            crate::io::encode_frame_png(img).map_err(|e| fail(&name(kind), e.to_string()))?;
        files.push((name(kind), bytes));
    }
    for (kind, img) in [("diff", &diff), ("ssim", &map), ("flip", &flip)] {
        let bytes = crate::io::encode_png8(img).map_err(|e| fail(&name(kind), e.to_string()))?;
        files.push((name(kind), bytes));
    }
    Ok(files)
}

/// Writes rendered artifacts into `dir` (created when absent), each file
/// whole or not at all.
pub(super) fn write_files(dir: &Path, files: &[(String, Vec<u8>)]) -> Result<(), CheckError> {
    std::fs::create_dir_all(dir).map_err(|e| CheckError::Artifact {
        path: dir.to_owned(),
        detail: e.to_string(),
    })?;
    for (name, bytes) in files {
        let path = dir.join(name);
        crate::io::write_bytes_atomically(&path, bytes).map_err(|e| CheckError::Artifact {
            path: path.clone(),
            detail: e.to_string(),
        })?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn adapter_names_become_safe_file_name_parts() {
        assert_eq!(
            adapter_slug("llvmpipe (LLVM 15.0.6, 256 bits)"),
            "llvmpipe-llvm-15-0-6-256-bits"
        );
        assert_eq!(
            adapter_slug("NVIDIA H100 80GB HBM3"),
            "nvidia-h100-80gb-hbm3"
        );
        assert_eq!(adapter_slug("../../etc"), "etc");
        assert_eq!(adapter_slug("()"), "unknown");
        assert_eq!(
            artifact_name("sky", 7, "llvmpipe", "diff"),
            "sky-007-llvmpipe-diff.png"
        );
    }
}
