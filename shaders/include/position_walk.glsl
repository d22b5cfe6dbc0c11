// Texel positions (i, j) of an N x N face visited with a fixed stride through the flat index
// j N + i, shared by the modules that stride over faces. The row and column follow the index
// without a division per step (a vector integer division is a loop of scalar ones on CPUs).
#ifndef SHPROBE_POSITION_WALK_GLSL
#define SHPROBE_POSITION_WALK_GLSL

struct PositionWalk {
    uint i, j;                    // the current position
    uint strideRows, strideColumns; // the stride as whole rows plus columns
};

PositionWalk startWalk(uint first, uint stride, uint faceSize) {
    uint j = first / faceSize;
    uint rows = stride / faceSize;
    return PositionWalk(first - j * faceSize, j, rows, stride - rows * faceSize);
}

void stepWalk(inout PositionWalk walk, uint faceSize) {
    walk.i += walk.strideColumns;
    walk.j += walk.strideRows;
    if (walk.i >= faceSize) {
        walk.i -= faceSize;
        ++walk.j;
    }
}

#endif
