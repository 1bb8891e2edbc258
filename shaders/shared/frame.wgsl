// Per-frame uniforms shared by the stages. Mirrors `gpu::FrameUniforms`.
struct FrameUniforms {
    // Rows of the sphere rotation R (xyz; w unused).
    rot0: vec4<f32>,
    rot1: vec4<f32>,
    rot2: vec4<f32>,
    // Output frame size in pixels.
    size: vec2<u32>,
    // tan(fov_y / 2) and width / height.
    tan_half: f32,
    aspect: f32,
    // The frame's sub-pixel jitter (a TAA frame; 0 otherwise), added to
    // every sample's offset as `conventions::taa_jitter` says.
    jitter: vec2<f32>,
    // The scene's light at this frame (a `[[light]]` step's scale; 1 by
    // default), which every sample is scaled by after the average.
    light: f32,
}
