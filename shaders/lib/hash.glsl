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

// Bob Jenkins' lookup3 hash of 1..4 uint32 words, as Blender's Voronoi node
// hashes the float bits of a cell's coordinates (distribution "blender";
// cellgl/basis/population.py jenkins_hash is the NumPy twin). A rotation, the
// three-word final mix, and the mix that absorbs the first three of four words.
uint _cell_rot(uint x, int k)
{
    return (x << uint(k)) | (x >> uint(32 - k));
}

uint _cell_jenkins_final(uint a, uint b, uint c)
{
    c ^= b; c -= _cell_rot(b, 14);
    a ^= c; a -= _cell_rot(c, 11);
    b ^= a; b -= _cell_rot(a, 25);
    c ^= b; c -= _cell_rot(b, 16);
    a ^= c; a -= _cell_rot(c, 4);
    b ^= a; b -= _cell_rot(a, 14);
    c ^= b; c -= _cell_rot(b, 24);
    return c;
}

uint cell_jenkins(uint x)
{
    uint s = 0xdeadbeefu + 17u;          // seed: 0xdeadbeef + 4 n + 13, n words
    return _cell_jenkins_final(s + x, s, s);
}

uint cell_jenkins(uint x, uint y)
{
    uint s = 0xdeadbeefu + 21u;
    return _cell_jenkins_final(s + x, s + y, s);
}

uint cell_jenkins(uint x, uint y, uint z)
{
    uint s = 0xdeadbeefu + 25u;
    return _cell_jenkins_final(s + x, s + y, s + z);
}

uint cell_jenkins(uint x, uint y, uint z, uint w)
{
    uint s = 0xdeadbeefu + 29u;
    uint a = s + x, b = s + y, c = s + z;
    a -= c; a ^= _cell_rot(c, 4);  c += b;
    b -= a; b ^= _cell_rot(a, 6);  a += c;
    c -= b; c ^= _cell_rot(b, 8);  b += a;
    a -= c; a ^= _cell_rot(c, 16); c += b;
    b -= a; b ^= _cell_rot(a, 19); a += c;
    c -= b; c ^= _cell_rot(b, 4);  b += a;
    return _cell_jenkins_final(a + w, b, c);
}

// A uint32 hash as Blender's float in [0, 1]: float(h) rounded to float32, / 2^32.
float cell_unit_float(uint h)
{
    return float(h) * (1.0 / 4294967296.0);
}
