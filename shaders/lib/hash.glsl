// cellgl: integer hashing shared by every cellular function.
//
// Only uint32 multiply / xor / shift, wrapping modulo 2^32, so NumPy
// (cellgl/basis/reference.py, np.uint32), GLSL 3.30+/4.x, GLSL ES 3.00, HLSL and WGSL
// all produce the same bits. No fract(sin(x)) anywhere.

// A strong 32-bit avalanche (two multiply-xorshift rounds; constants from
// C. Wellons' "hash prospector", bias ~0.17).
uint cell_hash_u32(uint x)
{
    x ^= x >> 16;
    x *= 0x7feb352du;
    x ^= x >> 15;
    x *= 0x846ca68bu;
    x ^= x >> 16;
    return x;
}

// A 16-bit value as a float in (0, 1), centred in its 1/65536 step: exact
// in float32 and float64, so the GPU and the reference see the same number.
float cell_u16(uint v)
{
    return (float(int(v)) + 0.5) * (1.0 / 65536.0);  // via int: v < 2^16
}
