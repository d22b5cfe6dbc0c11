// The cube maps read by the projection modules, set 0, binding 0: probe p's face f is layer 6p + f,
// N x N texels, faces and orientation as in texel_geometry.h.
//
// With SHPROBE_STORAGE_FORMAT defined (rgba32f or rgba16f, the view's format) the binding is a
// storage image read with imageLoad, in VK_IMAGE_LAYOUT_GENERAL; without, a sampled image of any
// format read with texelFetch (the sampler does not matter). Both give the same values. On llvmpipe
// a texel fetch is a called function that looks up per-lane mip-level addresses, and the storage
// read is three times faster (`shprobe bench`, "gpu texel reads only").
#ifndef SHPROBE_CUBEMAP_INPUT_GLSL
#define SHPROBE_CUBEMAP_INPUT_GLSL

#ifdef SHPROBE_STORAGE_FORMAT
layout(set = 0, binding = 0, SHPROBE_STORAGE_FORMAT) readonly uniform image2DArray cubemaps;
vec3 readRadiance(uint i, uint j, int layer) {
    return imageLoad(cubemaps, ivec3(i, j, layer)).rgb;
}
#else
layout(set = 0, binding = 0) uniform sampler2DArray cubemaps;
vec3 readRadiance(uint i, uint j, int layer) {
    return texelFetch(cubemaps, ivec3(i, j, layer), 0).rgb;
}
#endif

#endif
