//! Whether an adapter can run tonegate at all: every stage is a compute
//! shader over storage buffers. `tonegate adapters` lists what an adapter
//! lacks, and `choose` never picks one that lacks them
//! (docs/adapters.md#gl).

/// What `adapter` lacks that every stage needs: compute shaders and
/// storage buffers. A GL adapter lacks them where the driver gave wgpu an
/// OpenGL context older than 4.3 (or GLES older than 3.1): wgpu 30 asks
/// EGL for desktop GL 3.3 wherever the driver offers desktop OpenGL, and
/// gets exactly 3.3 from NVIDIA's driver (580.159.04 on an H200,
/// 2026-11-27), where Mesa gives its newest core version.
pub fn lacks(adapter: &wgpu::Adapter) -> Option<String> {
    let info = adapter.get_info();
    let down = adapter.get_downlevel_capabilities();
    let limits = adapter.limits();
    let mut missing = Vec::new();
    if !down.flags.contains(wgpu::DownlevelFlags::COMPUTE_SHADERS)
        || (info.backend == wgpu::Backend::Gl && !gl_has_compute(&info.driver_info))
    {
        missing.push("no compute shaders");
    }
    if limits.max_storage_buffer_binding_size == 0
        || limits.max_storage_buffers_per_shader_stage == 0
    {
        missing.push("no storage buffers");
    }
    if missing.is_empty() {
        return None;
    }
    let mut reason = format!("{}, which every stage needs", missing.join(" and "));
    if info.backend == wgpu::Backend::Gl {
        reason.push_str(&format!(
            " (its GL context is \"{}\"; compute needs OpenGL 4.3 or GLES 3.1; use its Vulkan adapter)",
            info.driver_info
        ));
    }
    Some(reason)
}

/// Whether a GL context's version string (GL_VERSION, wgpu's
/// `driver_info`) is one whose shading language has compute shaders:
/// desktop OpenGL 4.3 or OpenGL ES 3.1. wgpu's own flag also counts the
/// `GL_ARB_compute_shader` extension, which NVIDIA's driver offers in a 3.3
/// context; but naga writes GLSL of the context's version, and refuses
/// compute below those (on an H200, 2026-11-27: "The selected version
/// doesn't support Features(BUFFER_STORAGE | COMPUTE_SHADER)"). A string
/// that names no version is given the benefit of the doubt.
pub fn gl_has_compute(version: &str) -> bool {
    let (es, rest) = match version.trim().strip_prefix("OpenGL ES") {
        Some(rest) => (true, rest.trim_start()),
        None => (false, version.trim()),
    };
    let mut parts = rest
        .split(|c: char| !c.is_ascii_digit())
        .map(|p| p.parse::<u32>());
    let (Some(Ok(major)), Some(Ok(minor))) = (parts.next(), parts.next()) else {
        return true;
    };
    if es {
        (major, minor) >= (3, 1)
    } else {
        (major, minor) >= (4, 3)
    }
}
