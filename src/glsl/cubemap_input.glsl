// The layered image read by the projection modules, set 0, binding 0. project.comp's cube maps:
// probe p's face f is layer 6p + f, N x N texels, faces and orientation as in texel_geometry.h;
// project_equirect.comp's equirect maps: probe p is layer p, W x H texels. The binding is named
// SHPROBE_INPUT_NAME where the includer defines it (equirects), cubemaps otherwise.
//
// With SHPROBE_STORAGE_FORMAT defined (rgba32f or rgba16f, the view's format) the binding is a
// storage image read with imageLoad, in VK_IMAGE_LAYOUT_GENERAL; without, a sampled image of any
// format read with texelFetch (the sampler does not matter). Both give the same values. Not a
// driver workaround: the storage variants are what any engine may bind (their own images in
// RGBA32F or RGBA16F), and the host bakes pick them where the device supports the format. On
// llvmpipe they also read faster (a texel fetch is a called function that looks up per-lane
// mip-level addresses; `shprobe bench`, "gpu texel reads only").
#ifndef SHPROBE_CUBEMAP_INPUT_GLSL
#define SHPROBE_CUBEMAP_INPUT_GLSL

#ifndef SHPROBE_INPUT_NAME
#define SHPROBE_INPUT_NAME cubemaps
#endif

#ifdef SHPROBE_STORAGE_FORMAT
layout(set = 0, binding = 0, SHPROBE_STORAGE_FORMAT) readonly uniform image2DArray SHPROBE_INPUT_NAME;
vec3 readRadiance(uint i, uint j, int layer) {
    return imageLoad(SHPROBE_INPUT_NAME, ivec3(i, j, layer)).rgb;
}
#else
layout(set = 0, binding = 0) uniform sampler2DArray SHPROBE_INPUT_NAME;
vec3 readRadiance(uint i, uint j, int layer) {
    return texelFetch(SHPROBE_INPUT_NAME, ivec3(i, j, layer), 0).rgb;
}
#endif

#endif
