// Relighting with per-vertex radiance transfer (docs/transfer.md; Sloan, Kautz and Snyder 2002): a
// vertex's outgoing radiance is L_out = sum_i T_i L_i, with T_i its transfer (`shprobe transfer`'s
// _SH_TRANSFER_k attributes) and L_i the light's radiance coefficients (one vec4 each, rgb).
//
// The includer defines SHPROBE_TRANSFER_ATTRIBUTES, the number of vec4 transfer attributes its
// vertex shader declares (at least ceil(order^2 channels / 4)).
#ifndef SHPROBE_SH_TRANSFER_GLSL
#define SHPROBE_SH_TRANSFER_GLSL

// Float f of a vertex's transfer: the floats are packed 4 to an attribute, in order.
float shTransferFloat(vec4 transfer[SHPROBE_TRANSFER_ATTRIBUTES], uint f) {
    return transfer[f >> 2u][f & 3u];
}

// T_i (rgb): channels 3 holds T_i's r, g, b at floats 3i, 3i+1, 3i+2; channels 1 (a grey file) one
// float at i, the same for the three.
vec3 shTransferCoefficient(vec4 transfer[SHPROBE_TRANSFER_ATTRIBUTES], uint i, uint channels) {
    if (channels == 1u) return vec3(shTransferFloat(transfer, i));
    return vec3(shTransferFloat(transfer, 3u * i), shTransferFloat(transfer, 3u * i + 1u),
                shTransferFloat(transfer, 3u * i + 2u));
}

#endif
