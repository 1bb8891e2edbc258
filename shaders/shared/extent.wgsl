// The part of the frame's textures this frame covers (`gpu::Extent`): a
// renderer kept by the server for a size class has textures of the class's
// size and renders any image that fits, from the top-left corner. `frame` is
// the image's size, `low` the bloom's low-resolution size of it. Whatever
// lies outside is left over from an earlier image and is never read.
struct Extent {
    frame: vec2<u32>,
    low: vec2<u32>,
}

@group(1) @binding(0) var<uniform> extent: Extent;
