// Microbenchmarks of the resources the silhouette kernel (silhouette.cl) spends per
// model-view, for its roofline (mmocap/evaluators/roofline.py): float32 arithmetic, reads of
// a cache-resident global array, and scattered ORs into a bit mask in local memory. Like the
// silhouette kernel on a CPU, each work-group is one work-item working on 8-wide vectors, and
// multiplications and additions are not fused.
#pragma OPENCL FP_CONTRACT OFF

// ARITHMETIC: 8 independent chains of x = x * m + c on float8, `iterations` times:
// 2 * 8 * 8 float operations per iteration; the sum is written so nothing is optimised away.
__kernel __attribute__((reqd_work_group_size(1, 1, 1)))
void arithmetic(const int iterations, const float m, const float c, __global float *out)
{
    const float8 start = (float8)(get_global_id(0)) * 1e-6f;
    float8 x0 = start, x1 = start + 1.0f, x2 = start + 2.0f, x3 = start + 3.0f,
           x4 = start + 4.0f, x5 = start + 5.0f, x6 = start + 6.0f, x7 = start + 7.0f;
    for (int i = 0; i < iterations; ++i) {
        x0 = x0 * m + c; x1 = x1 * m + c; x2 = x2 * m + c; x3 = x3 * m + c;
        x4 = x4 * m + c; x5 = x5 * m + c; x6 = x6 * m + c; x7 = x7 * m + c;
    }
    const float8 s = ((x0 + x1) + (x2 + x3)) + ((x4 + x5) + (x6 + x7));
    out[get_global_id(0)] = ((s.s0 + s.s1) + (s.s2 + s.s3)) + ((s.s4 + s.s5) + (s.s6 + s.s7));
}

// READS: every work-group sums the whole array (n8 float8, a multiple of 4), which all of
// them share, as every model-view reads the body's vertex array.
__kernel __attribute__((reqd_work_group_size(1, 1, 1)))
void reads(__global const float8 *data, const int n8, __global float *out)
{
    float8 s0 = 0.0f, s1 = 0.0f, s2 = 0.0f, s3 = 0.0f;
    for (int i = 0; i < n8; i += 4) {
        s0 += data[i]; s1 += data[i + 1]; s2 += data[i + 2]; s3 += data[i + 3];
    }
    const float8 s = (s0 + s1) + (s2 + s3);
    out[get_global_id(0)] = ((s.s0 + s.s1) + (s.s2 + s.s3)) + ((s.s4 + s.s5) + (s.s6 + s.s7));
}

// SCATTER: every work-group clears `words` (a power of two) words of local memory, then ORs
// one bit into `ors` (a multiple of 8) words at pseudo-random places, as the silhouette
// kernel ORs one bit per kept vertex of a vector of 8 into a layer: 8 independent linear
// congruential sequences in a uint8, so that the ORs, not the sequence, set the pace; one
// word is written out.
__kernel __attribute__((reqd_work_group_size(1, 1, 1)))
void scatter(const int words, const int ors, __local uint *mask, __global uint *out)
{
    for (int k = 0; k < words; ++k) mask[k] = 0u;
    uint8 x = (uint8)(1u, 2u, 3u, 4u, 5u, 6u, 7u, 8u) * (2654435761u * (uint)(get_global_id(0) + 1));
    const uint last = (uint)(words - 1);
    for (int i = 0; i < ors; i += 8) {
        x = x * 1664525u + 1013904223u;
        const uint8 k = (x >> 5) & last, bit = (uint8)(1u) << (x & 31u);
        mask[k.s0] |= bit.s0; mask[k.s1] |= bit.s1; mask[k.s2] |= bit.s2; mask[k.s3] |= bit.s3;
        mask[k.s4] |= bit.s4; mask[k.s5] |= bit.s5; mask[k.s6] |= bit.s6; mask[k.s7] |= bit.s7;
    }
    out[get_global_id(0)] = mask[x.s0 & last];
}
